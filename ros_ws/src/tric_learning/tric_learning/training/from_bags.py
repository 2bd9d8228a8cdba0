"""Training on bags: the whole job that the trainer node and tric-train share, for TRIC's value
function (training.train_from_bags) and DPL's policies (dpl.train_dpl_from_bags) alike: bags ->
dataset -> a training -> model file, with every input checked before anything is written."""

import pathlib
from dataclasses import dataclass

from tric_learning.bags.loader import bag_paths, load_dataset
from tric_learning.model_file import expected_size
from tric_learning.training.dataset import Dataset
from tric_sim.tools.claims import claim
from tric_sim.tools.output_files import check_output_file
from tric_sim.world.robot_model import RobotModel

#: The model file written next to the first bag when no output path is given.
DEFAULT_MODEL_NAME = "model.safetensors"
MODEL_SUFFIX = ".safetensors"


@dataclass
class BagTraining:
    """What a training on bags did: the model file written, the dataset and the training result (a
    training.TrainingResult or a dpl.DplResult)."""

    path: pathlib.Path
    dataset: Dataset
    result: object


def model_output_path(
    output_path, first_bag: pathlib.Path, inputs=(), overwrite: bool = True
) -> pathlib.Path:
    """Where the model goes: output_path, or DEFAULT_MODEL_NAME next to first_bag when output_path
    is empty; ValueError if it is not a writable .safetensors file path, is one of inputs, or
    exists and overwrite is False (tric_sim.tools.output_files.check_output_file)."""
    path = pathlib.Path(output_path) if output_path else first_bag.parent / DEFAULT_MODEL_NAME
    return check_output_file(
        path, (MODEL_SUFFIX,), "the model path", inputs=inputs, overwrite=overwrite
    )


def train_on_bags(
    paths,
    output_path,
    robot: RobotModel,
    progress,
    fit,
    to_model_file,
    *,
    include_failed: bool = False,
    tolerant: bool = False,
    notice=None,
    hidden_units: int = 0,
    overwrite: bool = True,
    bytes_per_demo: int = 0,
) -> BagTraining:
    """Load the demonstrations in the bags at paths (files or folders, see bag_dataset.load_dataset
    for include_failed, tolerant and notice), train on them with fit(dataset, report) -> result and
    write to_model_file(result, dataset) to output_path (see model_output_path). The model path is
    claimed for this run (tric_sim.tools.claims) before anything is read, and the room its file
    takes (model_file.expected_size, hidden_units: the model's; bytes_per_demo more for each
    demonstration, the metadata that grows with them) checked
    before the training; a bad bag or path raises ValueError and leaves no file. A model file that
    appeared at the path meanwhile is replaced only if overwrite (else the model goes beside it:
    tric_sim.tools.output_files.atomic_path). progress(stage, fraction, losses) is handed on to fit
    as report, with the stages "loading" before and "saving" after it."""
    files = bag_paths(paths, tolerant, notice)
    path = model_output_path(output_path, files[0])
    with claim(path, "the model path"):
        report = progress or (lambda *_: None)
        report("loading", 0.0, None)
        dataset = load_dataset(
            files,
            robot,
            lambda done, total: report("loading", done / total, None),
            include_failed=include_failed,
            tolerant=tolerant,
            notice=notice,
        )
        check_output_file(
            path,
            what="the model path",
            expected_bytes=expected_size(dataset.definition.size, hidden_units)
            + bytes_per_demo * len(dataset.demos),
        )
        result = fit(dataset, report)
        report("saving", 0.0, result.losses)
        to_model_file(result, dataset).save(path, replace=overwrite)
        report("saving", 1.0, result.losses)
    return BagTraining(path, dataset, result)

"""Model files: weights as safetensors (no code runs on loading), the rest as JSON metadata.

A model file holds the arrays of a learned model and a "tric" metadata entry: the model kind, the
feature definition it was trained with, the kept features and their scaling, the hyper-parameters,
the dataset's fingerprint, the robot profile it was trained on (name and digest: its info's
"robot_profile"), the final loss terms, training times, the controller's delta, and each
kept feature's score s(y) (Sec. 5.5.1), and a digest of the arrays (tensor_digest). Loading checks
the digest, and the file against the feature definition it is used with, and refuses anything else
with a message that says why. A file written before model files carried a digest loads with a
warning: its arrays cannot be checked.
"""

import hashlib
import json
import logging
import pathlib
import tempfile
from dataclasses import dataclass, field

import numpy as np
from safetensors import SafetensorError, safe_open
from safetensors.numpy import load_file, save

from tric_learning.features import FeatureDefinition
from tric_learning.training.hyperparameters import KINDS
from tric_learning.value_function import Scaling, ValueFunction
from tric_sim.tools.output_files import atomic_path
from tric_sim.tools.provenance import code_digest
from tric_sim.tools.untrusted import check_input_file, load_data, quoted

FORMAT = "tric-model"
VERSION = 1
_log = logging.getLogger(__name__)


def tensor_digest(arrays: dict) -> str:
    """ "sha256:<hex>" over the arrays in name order: each one's name, dtype, shape and bytes (C
    order)."""
    digest = hashlib.sha256()
    for name in sorted(arrays):
        array = np.ascontiguousarray(arrays[name])
        header = json.dumps([name, array.dtype.str, list(array.shape)])
        digest.update(f"{len(header)}:{header}".encode())
        digest.update(array.tobytes())
    return f"sha256:{digest.hexdigest()}"


def expected_size(features: int, hidden_units: int, outputs: int = 16) -> int:
    """A bound on the bytes of a model file, to check its room before training: float64 arrays of
    at most hidden_units x (features + outputs + 2) + 4 x features values (hidden_units: the
    model's, every ensemble member's together; outputs: a DPL policy's, at most 16), 100 bytes of
    metadata per feature and 16 kB more. Measured: 42 kB for K = 30 on the grasps' 224 features
    (bound: 100 kB), 55 kB for 3 members of K = 30 on the boxes' features."""
    values = hidden_units * (features + outputs + 2) + 4 * features
    return 8 * values + 100 * features + 16_000


@dataclass
class ModelFile:
    """A model with what it was trained with. arrays: name -> array; info: JSON-compatible dict."""

    kind: str
    definition: FeatureDefinition
    arrays: dict
    info: dict = field(default_factory=dict)

    def save(self, path, replace: bool = True) -> pathlib.Path:
        """Write atomically (a temporary file renamed into place; removed again if writing fails;
        a file that appeared at path meanwhile kept unless replace: atomic_path)."""
        path = pathlib.Path(path)
        arrays = {k: np.ascontiguousarray(v) for k, v in self.arrays.items()}
        meta = {
            "format": FORMAT,
            "version": VERSION,
            "kind": self.kind,
            "definition": self.definition.to_dict(),
            "fingerprint": self.definition.fingerprint,
            "info": self.info,
            "digest": tensor_digest(arrays),
        }
        content = save(arrays, metadata={"tric": json.dumps(meta)})
        with atomic_path(path, replace) as temporary:  # written by Python: an OSError if it fails
            temporary.write_bytes(content)
        return path

    @classmethod
    def load(cls, path, expected: FeatureDefinition | None = None) -> "ModelFile":
        """Read a model file; ValueError if unreadable, not a TRIC model, its arrays not those its
        digest was made of, or (when expected is given) trained on another feature definition. A
        file without a digest (older) is read with a warning logged."""
        path = check_input_file(path, "model file")
        try:
            arrays = load_file(str(path))
            with safe_open(str(path), framework="numpy") as handle:
                text = (handle.metadata() or {}).get("tric", "null")
        except (SafetensorError, OSError, ValueError) as error:
            raise ValueError(f"{path} is not a readable model file: {quoted(str(error))}") from None
        meta = load_data(text, f"model file {path}: its 'tric' metadata", json_format=True)
        if not isinstance(meta, dict) or meta.get("format") != FORMAT:
            raise ValueError(
                f"{path} is a safetensors file but not a TRIC model (no 'tric' metadata)"
            )
        if meta.get("version") != VERSION:
            raise ValueError(
                f"{path} has model format version {meta.get('version')}; this reads {VERSION}"
            )
        if "digest" not in meta:
            _log.warning(
                "%s was written before model files carried a digest: its arrays are not checked",
                path,
            )
        elif meta["digest"] != tensor_digest(arrays):
            raise ValueError(
                f"{path}: its arrays do not match the digest recorded with them (the file was "
                "damaged or edited); train the model again"
            )
        if meta.get("kind") not in KINDS:
            raise ValueError(f"{path} holds an unknown model kind '{meta.get('kind')}'")
        try:
            definition = FeatureDefinition.from_dict(meta.get("definition"))
        except ValueError as error:
            raise ValueError(f"{path}: {error}") from None
        if not isinstance(meta.get("info", {}), dict):
            raise ValueError(f"{path}: its 'info' metadata is not a mapping")
        if definition.fingerprint != meta.get("fingerprint"):
            raise ValueError(
                f"{path}: its feature definition does not match its recorded fingerprint"
            )
        if expected is not None:
            expected.check_same(definition, f"model {path}")
        return cls(meta["kind"], definition, arrays, meta.get("info", {}))


def from_bytes(content: bytes, expected: FeatureDefinition | None = None) -> ModelFile:
    """The ModelFile of a model file's bytes (ModelFile.load's checks): what workers send back."""
    with tempfile.TemporaryDirectory(prefix="tric-model-") as folder:
        path = pathlib.Path(folder) / "model.safetensors"
        path.write_bytes(content)
        return ModelFile.load(path, expected)


def made_as(path, kind: str, hyperparameters: dict, dataset_fingerprint: str, code: str) -> bool:
    """Whether the model file at path exists and was trained as asked: of this kind, with these
    hyper-parameters, on the dataset of this fingerprint, by the training code of this digest
    (tric_sim.tools.provenance). A cache re-uses a model only then; an unreadable file is not
    one."""
    try:
        model = ModelFile.load(path)
    except ValueError:
        return False
    info = model.info
    return (
        model.kind == kind
        and info.get("hyperparameters") == hyperparameters
        and info.get("dataset_fingerprint") == dataset_fingerprint
        and info.get("training_code") == code
    )


def value_function_arrays(model: ValueFunction) -> dict:
    """The arrays of a TRIC value function for a ModelFile."""
    return {
        "w1": model.w1,
        "w2": model.w2,
        "w3": model.w3,
        "b1": model.b1,
        "kept": model.scaling.kept.astype(np.int64),
        "low": model.scaling.low,
        "high": model.scaling.high,
    }


def value_function(model_file: ModelFile) -> ValueFunction:
    """The TRIC value function of a ModelFile, or ValueError if its arrays are inconsistent. A file
    without hidden biases b1 (written before they existed) has zero ones, the paper's model."""
    if model_file.kind != "tric":
        raise ValueError(f"the model is a '{model_file.kind}' model, not a TRIC value function")
    a = model_file.arrays
    try:
        kept, size = a["kept"], model_file.definition.size
        if kept.ndim != 1 or not np.issubdtype(kept.dtype, np.integer):
            raise ValueError("the model file's kept feature indices are not a list of integers")
        kept = kept.astype(int)
        s = len(kept)
        b1 = a.get("b1", np.zeros(a["w2"].shape))
        consistent = (
            a["w1"].ndim == 2
            and a["w1"].shape[1] == s
            and a["w2"].shape == (a["w1"].shape[0],)
            and b1.shape == a["w2"].shape
            and a["w3"].shape == (s,)
            and a["low"].shape == (s,)
            and a["high"].shape == (s,)
            and np.all((kept >= 0) & (kept < size))
            and np.all(a["high"] > a["low"])
        )
    except KeyError as missing:
        raise ValueError(f"the model file lacks the array {missing}") from None
    if not consistent:
        raise ValueError("the model file's arrays have inconsistent shapes")
    for name, array in (
        *((name, a[name]) for name in ("w1", "w2", "w3", "low", "high")),
        ("b1", b1),
    ):
        if not np.all(np.isfinite(array)):
            raise ValueError(f"the model file's {name} has non-finite values")
    return ValueFunction(Scaling(kept, a["low"], a["high"], size), a["w1"], a["w2"], a["w3"], b1)


def from_training(result, dataset) -> ModelFile:
    """The ModelFile of a TRIC training result (tric_learning.training.value.TrainingResult) on
    dataset."""
    model = result.model
    names = np.array(dataset.definition.feature_names)[model.scaling.kept]
    return ModelFile(
        "tric",
        dataset.definition,
        value_function_arrays(model),
        {
            "hyperparameters": result.config.to_dict(),
            "dataset_fingerprint": dataset.fingerprint,
            "training_code": code_digest("tric_learning.training.value"),
            "demos": [demo.name for demo in dataset.demos],
            "losses": result.losses,
            "iterations": result.iterations,
            "sampling_time_s": result.sampling_time_s,
            "optimization_time_s": result.optimization_time_s,
            "train_time_s": result.train_time_s,
            "robot_profile": result.robot_profile,
            "delta": result.delta,
            "rho": result.rho,
            "selected_features": result.selected_features,
            "mean_samples_per_step": result.mean_samples_per_step,
            "rest": result.rest,
            "kept_features": names.tolist(),
            "scores": model.scores().tolist(),
        },
    )

"""A training that chooses its model (what tric-train, the trainer node, tric-demo and
tric-experiments run): S candidates trained side by side on an executor
(tric_control.evaluation.executors), each rolled out from every demonstration's start, ranked,
the best kept (tric_control.selection.choice); and the same from bags to a model file. ROS-free."""

import pathlib
import time
from dataclasses import dataclass, replace

from tric_control.evaluation.executors import ProcessExecutor
from tric_control.selection.candidates import candidate
from tric_control.selection.choice import Choice, choose
from tric_control.selection.settings import SelectionConfig
from tric_learning.training.dataset import Dataset
from tric_learning.training.from_bags import train_on_bags
from tric_learning.training.value import TrainingConfig
from tric_sim.tools.provenance import code_digest
from tric_sim.world.robot_model import RobotModel
from tric_sim.world.robot_profile import DEFAULT_ROBOT

#: The module whose code (and all it imports: the training, the rollouts' controller and physics,
#: the scores and the choice) makes a chosen model.
SELECTION_CODE = "tric_control.selection.select_model"
#: A bound on the bytes of a model file's selection provenance per candidate and demonstration (its
#: rollout's outcome and error), for the room checked before the candidates train.
PROVENANCE_BYTES = 400


@dataclass
class Selection:
    """A finished selection: the choice (its model file, chosen seeds, provenance), the dataset,
    the candidates, the model file's path (None until written) and the wall seconds it took."""

    choice: Choice
    dataset: Dataset
    candidates: list
    wall_s: float
    path: pathlib.Path | None = None

    @property
    def losses(self) -> dict:
        """The chosen model's loss terms."""
        return self.choice.model.info["losses"]


def candidate_seeds(config: TrainingConfig, selection: SelectionConfig) -> list:
    """The candidates' seeds: G, G + 1, ..., G + S - 1 (G: config.seed), within [0, 2^32)."""
    return [(config.seed + k) % 2**32 for k in range(selection.candidates)]


def select_model(
    dataset: Dataset,
    config: TrainingConfig,
    selection: SelectionConfig,
    executor=None,
    jobs: int = 1,
    progress=None,
    max_steps: int = 0,
    controller_options: dict | None = None,
    robot: str = DEFAULT_ROBOT,
) -> Selection:
    """Train selection.candidates candidates on dataset with config (their seeds
    candidate_seeds), at most jobs at once on executor (None: processes here), roll each out from
    every demonstration's start (max_steps ticks at most, 0: the task's default;
    controller_options: OfflineEvaluator's) and choose. progress(done, total, candidate) after
    each candidate (candidate None before the first); robot: the demonstrations' robot, a profile's
    name or file. RuntimeError naming every candidate that failed, when too few are left to choose
    from."""
    config.validate()
    selection.validate()
    dataset.check()
    executor = executor or ProcessExecutor()
    report = progress or (lambda *_: None)
    seeds = candidate_seeds(config, selection)
    # the lift test costs a sixth of a grasp's rollout, and only the "successes" score reads it
    lift_test = selection.reads_lift_test
    calls = [
        (replace(config, seed=seed), max_steps, controller_options, None, lift_test, robot)
        for seed in seeds
    ]
    started = time.monotonic()
    report(0, len(calls), None)
    trained, failures, errors = [], [], []
    for k, result in executor.run_calls(candidate, calls, jobs, (dataset,)):
        if isinstance(result, Exception):
            errors.append(result)
            failures.append(f"seed {seeds[k]}: {type(result).__name__}: {result}")
        else:
            trained.append(result)
        report(len(trained) + len(failures), len(calls), result)
    if not trained and errors and all(isinstance(e, ValueError) for e in errors):
        raise errors[0]  # the data's fault, alike for every candidate (a demonstration it refuses)
    if len(trained) < selection.members:
        raise RuntimeError(
            f"{len(failures)} of {len(calls)} candidates failed ({'; '.join(failures)}); "
            f"{len(trained)} left, {selection.members} needed"
        )
    trained.sort(key=lambda c: c.seed)
    choice = choose(trained, dataset, config, selection)
    choice.provenance["code"] = code_digest(SELECTION_CODE)
    if failures:
        choice.provenance["failed"] = failures
    return Selection(choice, dataset, trained, time.monotonic() - started)


def select_from_bags(
    paths,
    output_path,
    config: TrainingConfig,
    selection: SelectionConfig,
    robot: RobotModel,
    executor=None,
    jobs: int = 1,
    progress=None,
    *,
    include_failed: bool = False,
    tolerant: bool = False,
    notice=None,
    overwrite: bool = True,
) -> Selection:
    """Load the demonstrations in the bags at paths, choose a model on them (select_model) and
    write it to output_path, as tric_learning.training.from_bags.train_on_bags trains one: every
    input checked and the model path claimed before any work, its room (with the selection's
    provenance) checked before the candidates train, a model file that appeared there meanwhile
    replaced only if overwrite. progress(stage, fraction, what): stage "loading" (what None),
    "candidates" (what: the candidate that just ended, or its Exception, None before the first),
    then "saving" (what: the chosen model's losses)."""
    config.validate()
    selection.validate()
    report = progress or (lambda *_: None)

    def fit(dataset, _report):
        return select_model(
            dataset,
            config,
            selection,
            executor,
            jobs,
            lambda done, total, candidate: report("candidates", done / total, candidate),
            robot=robot.profile.spec,
        )

    trained = train_on_bags(
        paths,
        output_path,
        robot,
        report,
        fit,
        lambda chosen, _dataset: chosen.choice.model,
        include_failed=include_failed,
        tolerant=tolerant,
        notice=notice,
        hidden_units=config.hidden_units * selection.members,
        overwrite=overwrite,
        bytes_per_demo=PROVENANCE_BYTES * selection.candidates,
    )
    chosen = trained.result
    assert isinstance(chosen, Selection), "the fit returns a Selection"
    chosen.path = trained.path
    return chosen

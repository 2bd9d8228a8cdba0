"""A study's tasks and variants (tric-study): the bags and sets of each task, the options a variant
may change and their parsing, and the numbers recorded of each model. No heavy imports: tric-study
checks its arguments with them before the libraries load."""

import dataclasses

from tric_control.selection.settings import SelectionConfig
from tric_learning.training.hyperparameters import TrainingConfig

#: Each task: the bags its model is trained on, the sets it is measured on, and the kind of its
#: episodes, whose step budget is the controller's default for the kind
#: (tric_control.episode_runner.DEFAULT_MAX_STEPS).
TASKS = {
    "sphere": ("sphere", ("sphere_val",), "grasp"),
    "cylinder": ("cylinder", ("cylinder_train", "cylinder_val"), "grasp"),
    # a second draw of the cylinder demonstrations, and both draws stratified over the angles
    "cylinder_b": ("cylinder_b", ("cylinder_b_train", "cylinder_val"), "grasp"),
    "cylinder_strat": (
        "cylinder_strat",
        ("cylinder_strat_train", "cylinder_val"),
        "grasp",
    ),
    "cylinder_strat_b": (
        "cylinder_strat_b",
        ("cylinder_strat_b_train", "cylinder_val"),
        "grasp",
    ),
    "box": ("box", ("box_train", "box_val"), "open_box"),
    "obstacle": ("sphere", ("obstacle_val",), "grasp"),
}


#: The tasks a study measures unless told otherwise.
DEFAULT_TASKS = ("sphere", "cylinder", "cylinder_b", "box", "obstacle")


#: The analysis' numbers of a model on its own demonstrations that a study records
#: (tric_learning.analysis.key_numbers: gradient_measures and features_carrying; and
#: tric_learning.analysis.attraction.end_measures: whether f has its minimum at their ends).
MODEL_MEASURES = (
    "cosine_weighted",
    "cosine_moving",
    "cosine_slow",
    "falls",
    "falls_moving",
    "features_95",
    "end_samples_above",
    "end_gradient_ratio",
)


#: Controller settings a variant may change, with their types: the hand's lead, the step budgets,
#: the task's contact rules (tric_sim.world.scene.TASK_CONTACTS): how deep the hand may press into a
#: grasp target and its cushion (m), how deep into the lid (m) and whether only from beneath;
#: whether the domain damper (tric_control.limits.DomainDamper) is among the limits; a factor on
#: the model's rho (tric_control.objectives.make_objective); whether the task's grip closes the
#: hand once at rest (tric_sim.world.scene.task_grip); and the fall pace's knee
#: (tric_control.fall_pace.FallPace, its other settings the defaults; absent: the default knee, as
#: the controller node's; 0: no pace, the paper's constant delta); and the walks out of stalls an
#: episode may take (tric_control.stall_escape.StallEscape; absent: 3, as the node's; 0: none).
CONTROLLER_OPTIONS = {
    "hand_lead": float,
    "grasp_steps": int,
    "box_steps": int,
    "grasp_depth": float,
    "grasp_cushion": float,
    "lid_depth": float,
    "lid_beneath_only": bool,
    "domain_damper": bool,
    "rho_scale": float,
    "grip": bool,
    "fall_pace": float,
    "stall_escapes": int,
}
#: Training procedures beyond TrainingConfig: rounds of hard negatives
#: (tric_control.study.hard_negatives).
PROCEDURE_OPTIONS = {"hard_negative_rounds": int}
#: How a cell chooses its model (tric_control.selection.settings.SelectionConfig): candidates, the
#: best kept (members) and the score that ranks them.
SELECTION_OPTIONS = {"candidates": int, "members": int, "score": str}


#: The longest variant name, characters: a model's file is named after it, with the bags' name and
#: the seed, within the file systems' 255 bytes.
MAX_NAME_LENGTH = 100


def model_file_name(variant: str, bags: str, seed: int) -> str:
    """The file name of a study's model of variant trained on bags/<bags> with seed, in its
    models/ folder."""
    return f"{variant}_{bags}_s{seed}.safetensors"


def model_file_names(variants: list, tasks, seeds) -> dict:
    """{"VARIANT/BAGS/SEED": file name} of every model a study of the (name, changes) variants on
    tasks and seeds may write; ValueError naming a variant given twice."""
    names = [name for name, _ in variants]
    repeated = sorted({name for name in names if names.count(name) > 1})
    if repeated:
        raise ValueError(f"variant {repeated[0]!r} is given twice: give each a name of its own")
    return {
        f"{name}/{TASKS[task][0]}/{seed}": model_file_name(name, TASKS[task][0], seed)
        for name in names
        for task in tasks
        for seed in seeds
    }


def parse_variant(text: str):
    """(name, {field: value}) from NAME=FIELD=VALUE,FIELD=VALUE (TrainingConfig fields,
    CONTROLLER_OPTIONS, PROCEDURE_OPTIONS and SELECTION_OPTIONS); ValueError naming a bad
    part."""
    name, _, options = text.partition("=")
    if not name or not name.replace("_", "").replace("-", "").isalnum():
        raise ValueError(f"variant '{text[:80]}': the name must be letters, digits, - and _")
    if len(name) > MAX_NAME_LENGTH:
        raise ValueError(
            f"variant '{name[:40]}...': the name is {len(name)} characters long, over "
            f"{MAX_NAME_LENGTH} (its models' files are named after it)"
        )
    fields = {f.name: f for f in dataclasses.fields(TrainingConfig)}
    changes = {}
    for option in filter(None, options.split(",")):
        key, _, value = option.partition("=")
        extras = {**CONTROLLER_OPTIONS, **PROCEDURE_OPTIONS, **SELECTION_OPTIONS}
        if (key not in fields and key not in extras) or key == "seed":
            raise ValueError(
                f"variant '{name}': unknown option '{key}' (known: "
                f"{', '.join([k for k in fields if k != 'seed'] + list(extras))})"
            )
        kind = extras[key] if key in extras else type(getattr(TrainingConfig(), key))
        if kind is bool:
            if value.lower() not in ("true", "false"):
                raise ValueError(f"variant '{name}': {key} must be true or false")
            changes[key] = value.lower() == "true"
        else:
            try:
                changes[key] = kind(value)
            except ValueError:
                raise ValueError(
                    f"variant '{name}': {key} must be a {kind.__name__}, got '{value}'"
                ) from None
    TrainingConfig(**training_part(changes)).validate()
    try:
        SelectionConfig(**selection_part(changes)).validate()
    except ValueError as error:
        raise ValueError(f"variant '{name}': {error}") from None
    if (
        changes.get("hand_lead", 0.0) < 0
        or changes.get("grasp_steps", 1) < 1
        or changes.get("box_steps", 1) < 1
    ):
        raise ValueError(
            f"variant '{name}': hand_lead must be >= 0 rad and the step budgets >= 1 tick"
        )
    if any(not 0 <= changes.get(key, 0.0) <= 0.05 for key in CONTACT_OPTIONS):
        raise ValueError(f"variant '{name}': contact depths and cushions must be in [0, 0.05] m")
    if changes.get("hard_negative_rounds", 0) < 0:
        raise ValueError(f"variant '{name}': hard_negative_rounds must be >= 0")
    if not 0 <= changes.get("fall_pace", 1.0) <= 1:
        raise ValueError(f"variant '{name}': fall_pace (its knee; 0: none) must be in [0, 1]")
    if changes.get("stall_escapes", 0) < 0:
        raise ValueError(f"variant '{name}': stall_escapes must be >= 0")
    if not 0.001 <= changes.get("rho_scale", 1.0) <= 1000:
        raise ValueError(f"variant '{name}': rho_scale must be in [0.001, 1000]")
    return name, changes


#: The contact options of CONTROLLER_OPTIONS given in metres.
CONTACT_OPTIONS = ("grasp_depth", "grasp_cushion", "lid_depth")


def training_part(changes: dict) -> dict:
    """The TrainingConfig fields (but the seed) of a variant's changes or a model's record."""
    fields = {f.name for f in dataclasses.fields(TrainingConfig)} - {"seed"}
    return {k: v for k, v in changes.items() if k in fields}


def selection_part(changes: dict) -> dict:
    """The SelectionConfig fields of a variant's changes."""
    return {k: v for k, v in changes.items() if k in SELECTION_OPTIONS}

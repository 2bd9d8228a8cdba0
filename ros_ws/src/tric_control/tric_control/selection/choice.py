"""Choosing among candidates (tric_control.selection.candidates): rank them by a score
(tric_control.selection.scores), keep the best, or the best N averaged into one f, and write its
model file with the selection's provenance: every candidate's seed, score, rollouts' errors, the
hidden metrics' verdicts on its rollouts (a reference, never the default score's input) and its
share of the time; and for a single model kept, its done_value: the median f at the end of its
rollouts, where the model comes to rest having done what its demonstrations did (the stall
escape's reference, tric_control.stall_escape). ROS-free."""

from dataclasses import dataclass

import numpy as np

from tric_control.selection.scores import per_rollout_errors
from tric_control.selection.settings import SelectionConfig
from tric_learning import model_file
from tric_learning.model_file import ModelFile, tensor_digest
from tric_learning.training.dataset import Dataset
from tric_learning.training.rest import rest_info
from tric_learning.training.value import (
    TrainingConfig,
    TrainingResult,
    controller_gains,
    mean_of_members,
    selected_count,
)
from tric_learning.value_function import Scaling


@dataclass
class Choice:
    """The chosen model file, the seeds of the candidates in it (best first) and the provenance
    written into it (ModelFile.info["selection"])."""

    model: ModelFile
    chosen: list
    provenance: dict


def ranked(candidates: list, dataset: Dataset, selection: SelectionConfig) -> list:
    """[(score, errors (demos,), candidate)] best first (lower scores; ties by seed)."""
    rows = []
    for candidate in candidates:
        model = model_file.value_function(model_file.from_bytes(candidate.model))
        errors = per_rollout_errors(selection.score, candidate.rollouts, dataset, model)
        total = float(np.sum(errors)) if selection.score == "successes" else float(np.mean(errors))
        rows.append((total, errors, candidate))
    return sorted(rows, key=lambda row: (row[0], row[2].seed))


def choose(
    candidates: list, dataset: Dataset, config: TrainingConfig, selection: SelectionConfig
) -> Choice:
    """The model of the best selection.members candidates by selection.score: the best one's model
    file itself, or the mean of their f_k / fall_k on the union of their scalings
    (training.value.mean_of_members); config: the training's (its seed the group's). ValueError
    if there are fewer candidates than members."""
    selection.validate()
    if len(candidates) < selection.members:
        raise ValueError(f"{len(candidates)} candidates cannot give {selection.members} members")
    rows = ranked(candidates, dataset, selection)
    best = [candidate for _, _, candidate in rows[: selection.members]]
    files = [model_file.from_bytes(candidate.model) for candidate in best]
    if len(best) == 1:
        chosen = files[0]
    else:
        functions = [model_file.value_function(file) for file in files]
        union = Scaling.union(function.scaling for function in functions)
        ensemble = mean_of_members([f.on_scaling(union) for f in functions], dataset)
        delta, rho = controller_gains(ensemble, dataset)
        losses = {
            key: float(np.mean([file.info["losses"][key] for file in files]))
            for key in files[0].info["losses"]
        }
        result = TrainingResult(
            model=ensemble,
            config=config,
            losses=losses,
            iterations=sum(file.info["iterations"] for file in files),
            sampling_time_s=sum(file.info["sampling_time_s"] for file in files),
            optimization_time_s=sum(file.info["optimization_time_s"] for file in files),
            delta=delta,
            rho=rho,
            selected_features=selected_count(ensemble),
            mean_samples_per_step=float(
                np.mean([file.info["mean_samples_per_step"] for file in files])
            ),
            rest=rest_info(ensemble, dataset),
            robot_profile=files[0].info.get("robot_profile", ""),
        )
        chosen = model_file.from_training(result, dataset)
    provenance = _provenance(rows, best, selection, config)
    chosen.info = {
        **chosen.info,
        "hyperparameters": config.to_dict(),
        "selection": provenance,
    }
    done = done_value(best[0].rollouts) if len(best) == 1 else None
    if done is not None:
        chosen.info["done_value"] = done
    return Choice(chosen, [candidate.seed for candidate in best], provenance)


def done_value(rollouts: list) -> float | None:
    """The median f at the end of rollouts ([Rollout]) that ran (their f finite), or None if none
    did."""
    ends = [r.value_end for r in rollouts if not r.failed and np.isfinite(r.value_end)]
    return float(np.median(ends)) if ends else None


def _provenance(rows, best, selection: SelectionConfig, config: TrainingConfig) -> dict:
    """What the model file records of its selection (see the module docstring)."""
    total = sum(candidate.train_s + candidate.rollout_s for _, _, candidate in rows)
    chosen = {candidate.seed for candidate in best}
    return {
        "config": selection.to_dict(),
        "group_seed": config.seed,
        "chosen": [candidate.seed for candidate in best],
        "candidates": [
            {
                "seed": candidate.seed,
                "rank": rank,
                "chosen": candidate.seed in chosen,
                "score": score if np.isfinite(score) else None,
                "errors": [float(e) if np.isfinite(e) else None for e in errors],
                "train_s": candidate.train_s,
                "rollout_s": candidate.rollout_s,
                "time_share": (candidate.train_s + candidate.rollout_s) / total if total else 0.0,
                "tensor_digest": tensor_digest(model_file.from_bytes(candidate.model).arrays),
                "losses": candidate.record["losses"],
                "rollouts": [
                    {
                        "demo": rollout.demo,
                        "outcome": rollout.outcome,
                        "steps": rollout.steps,
                        **rollout.to_dict()["judged"],
                    }
                    for rollout in candidate.rollouts
                ],
            }
            for rank, (score, errors, candidate) in enumerate(rows)
        ],
    }

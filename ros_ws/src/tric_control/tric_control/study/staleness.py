"""Why a kept row of a study is not re-used (tric-study names each one it measures again): what
differs between the key it was made with and the cell's key now (tric_control.study.runs.Study's
cell_key: its candidates' keys, each a rollouts key holding its model's training key, and the
cell's own settings). ROS-free and light."""

#: How a change of each part of a cell's key is named.
CELL_CHANGES = {
    "selection": "the selection changed",
    "every_candidate": "--every-candidate changed",
    "sets": "the sets changed",
    "choice_code": "the choice's code changed",
}
#: ... of each part of a candidate's rollouts key.
ROLLOUT_CHANGES = {
    "controller": "the controller settings changed",
    "max_steps": "the step budget changed",
    "rollout_code": "the rollouts' code changed",
    "episode_code": "the episodes' code changed",
}
#: ... of each part of a candidate's training key (any other part: its training options).
TRAINING_CHANGES = {
    "data_digest": "the bags changed",
    "training_code": "the training code changed",
}
#: The most stale rows named one by one.
NAMED_ROWS = 5


def key_changes(kept, key: dict) -> str:
    """What differs between a kept row's key (None, or not a dict: none) and a cell's key, named
    ("" when nothing does)."""
    if not isinstance(kept, dict):
        return "kept without a key"
    changes = [why for part, why in CELL_CHANGES.items() if kept.get(part) != key.get(part)]
    kept_candidates, candidates = kept.get("candidates"), key.get("candidates", [])
    if not isinstance(kept_candidates, list) or not all(
        isinstance(c, dict) and isinstance(c.get("model"), dict) for c in kept_candidates
    ):
        return ", ".join(["its candidates' keys are missing", *changes])
    if len(kept_candidates) != len(candidates):
        changes.append("the number of candidates changed")
    found: list = []
    for old, new in zip(kept_candidates, candidates):
        found += [why for part, why in ROLLOUT_CHANGES.items() if old.get(part) != new.get(part)]
        model, new_model = old["model"], new.get("model", {})
        found += [
            why for part, why in TRAINING_CHANGES.items() if model.get(part) != new_model.get(part)
        ]
        others = {*model, *new_model} - set(TRAINING_CHANGES)
        if any(model.get(k) != new_model.get(k) for k in others):
            found.append("the training options changed")
    return ", ".join([*dict.fromkeys(found), *changes])


def stale_line(stale: list) -> str:
    """The line naming the kept rows measured again ("NAME (why)", at most NAMED_ROWS by name)."""
    named = ", ".join(stale[:NAMED_ROWS])
    more = f" and {len(stale) - NAMED_ROWS} more" if len(stale) > NAMED_ROWS else ""
    rows = "row" if len(stale) == 1 else "rows"
    return f"{len(stale)} kept {rows} made otherwise, measured again: {named}{more}"

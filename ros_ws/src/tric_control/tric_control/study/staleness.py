"""Why a kept row of a study is not re-used (tric-study names each one it measures again): what
differs between the key it was made with and the cell's key now (tric_control.study.runs.Study's
cell_key). ROS-free and light."""

#: How a change of each part of a cell's key, or of its model's config, is named.
KEY_CHANGES = {
    "controller": "the controller settings changed",
    "max_steps": "the step budget changed",
    "sets": "the sets changed",
    "episode_code": "the episodes' code changed",
}
MODEL_CHANGES = {
    "bags_digest": "the bags changed",
    "training_code": "the training code changed",
    "analysis_code": "the analysis code changed",
}
#: The most stale rows named one by one.
NAMED_ROWS = 5


def key_changes(kept, key: dict) -> str:
    """What differs between a kept row's key (None, or not a dict: none) and a cell's key, named
    ("" when nothing does)."""
    if not isinstance(kept, dict):
        return "kept without a key"
    changes = [why for part, why in KEY_CHANGES.items() if kept.get(part) != key.get(part)]
    kept_model, model = kept.get("model"), key.get("model", {})
    if not isinstance(kept_model, dict):
        return ", ".join(["its model's key is missing", *changes])
    named = [why for part, why in MODEL_CHANGES.items() if kept_model.get(part) != model.get(part)]
    others = {k for k in {*kept_model, *model} - set(MODEL_CHANGES)}
    if any(kept_model.get(k) != model.get(k) for k in others):
        named.append("the training options changed")
    return ", ".join(named + changes)


def stale_line(stale: list) -> str:
    """The line naming the kept rows measured again ("NAME (why)", at most NAMED_ROWS by name)."""
    named = ", ".join(stale[:NAMED_ROWS])
    more = f" and {len(stale) - NAMED_ROWS} more" if len(stale) > NAMED_ROWS else ""
    rows = "row" if len(stale) == 1 else "rows"
    return f"{len(stale)} kept {rows} made otherwise, measured again: {named}{more}"

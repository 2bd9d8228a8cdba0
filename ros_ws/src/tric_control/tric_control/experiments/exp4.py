"""Experiment 4: the sphere model facing an obstacle in the approach path, never seen in
training."""

from tric_control.experiments.paper import PAPER_REPORTS
from tric_control.experiments.rows import grasp_result, grasp_rows, spread
from tric_control.experiments.runner import Runner

#: The experiment's heading in the report and the log.
TITLE = (
    "The sphere model (three groups: each the model chosen among its candidates) with an obstacle "
    "in the approach path, never seen in training."
)


def run(runner: Runner) -> dict:
    """The experiment's rows, table, figure(s), the paper's numbers and the discussion."""
    tric = dict(name="sphere_k30", bags="sphere")
    rows = grasp_rows(runner, runner.situations("obstacle_test"), {"TRIC": tric})
    return grasp_result(rows, "Exp. 4: unseen obstacle", PAPER_REPORTS["exp4"], discussion(rows))


def discussion(rows: dict) -> str:
    teacher, tric = rows["teacher"], rows["TRIC"]
    n = tric["episodes"]
    text = (
        f"Behind the unseen obstacle TRIC grasps {spread(tric['good'])} of {n} spheres well "
        f"(groups {'/'.join(map(str, tric['seeds']))}; mean cost "
        f"{spread([r['cost_mean'] for r in tric['seeds'].values()], '.3f')}) with "
        f"{'/'.join(map(str, tric['collisions']))} collisions. "
    )
    if not any(tric["collisions"]) and min(tric["good"]) == n:
        text += (
            "This matches the paper with every group: the collision prior steers it to another "
            "grasp. "
        )
    elif not any(tric["collisions"]):
        text += (
            "As in the paper it never collides, but not every grasp is good with every group, so "
            "we fall short of the paper there. "
        )
    else:
        text += "It collides, unlike the paper. "
    if teacher["collisions"]:
        text += (
            f"The teacher, which does not see obstacles, collided in {teacher['collisions']} of "
            f"{teacher['episodes']}: the obstacle does block its usual approach."
        )
    return text

"""What a study's episodes run with and what is measured of them: the controller options a
variant's settings make (contact rules, the hand's lead, the domain damper) and the summary numbers
of a set's offline episodes. ROS-free."""

import collections
import dataclasses
import math

import numpy as np

from tric_control.evaluation.records import task_done
from tric_control.motion_rate import MAX_LEAD
from tric_sim.physics.metrics import GOOD_GRASP, LID_OPEN_ANGLE
from tric_sim.world.robot_model import RobotModel
from tric_sim.world.scene import TASK_CONTACTS


def contact_rules(changes: dict, task: str):
    """The contacts ({scene body name: tric_sim.world.scene.Contact}) a variant's contact options
    make of the task's, or None when it changes none of them."""
    if task == "open_box":
        if "lid_depth" not in changes and "lid_beneath_only" not in changes:
            return None
        lid = TASK_CONTACTS["open_box"]["lid"]
        beneath = changes.get("lid_beneath_only", lid.side is not None)
        return {
            "lid": dataclasses.replace(
                lid,
                depth=changes.get("lid_depth", lid.depth),
                side=(0.0, 0.0, -1.0) if beneath else None,
            )
        }
    if "grasp_depth" not in changes and "grasp_cushion" not in changes:
        return None
    target = TASK_CONTACTS["grasp"]["target"]
    return {
        "object": dataclasses.replace(
            target,
            depth=changes.get("grasp_depth", target.depth),
            cushion=changes.get("grasp_cushion", target.cushion),
        )
    }


def controller_options(changes: dict, task: str, robot: RobotModel) -> dict:
    """The keyword arguments of MotionRateController that a variant's controller settings make for
    the task (OfflineEvaluator's controller_options)."""
    options: dict = {}
    if "hand_lead" in changes:
        lead = np.full(robot.n_joints, MAX_LEAD)
        lead[robot.hand_indices] = changes["hand_lead"]
        options["max_lead"] = lead
    if "domain_damper" in changes:
        options["domain_damper"] = changes["domain_damper"]
    if "fall_pace" in changes:
        options["fall_pace_knee"] = changes["fall_pace"]
    for option in ("rho_scale", "grip", "stall_escapes"):
        if option in changes:
            options[option] = changes[option]
    contacts = contact_rules(changes, "open_box" if task == "box" else "grasp")
    if contacts is not None:
        options["contacts"] = contacts
    return options


def measure_set(records) -> dict:
    """Summary numbers of one set's offline episodes."""
    grasps = [r for r in records if r.task == "grasp"]
    rest = {
        "converged": sum(r.outcome == "converged" for r in records),
        "good_converged": sum(r.outcome == "converged" for r in records if task_done(r)),
        "collisions": sum(bool(r.collided) for r in records),
        "overshoot": max(r.max_joint_overshoot for r in records),
        "failures": dict(collections.Counter(r.failure for r in records if r.failure)),
    }
    if grasps:
        costs = [r.grasp_cost for r in grasps if math.isfinite(r.grasp_cost)]
        return {
            "episodes": len(records),
            "cost_mean": float(np.mean(costs)) if costs else math.nan,
            "good": sum(r.grasp_cost < GOOD_GRASP for r in grasps),
            "lifted": sum(r.lift_passed is True for r in grasps),
            **rest,
        }
    return {
        "episodes": len(records),
        "opened": sum(r.lid_angle > LID_OPEN_ANGLE for r in records),
        "lid_mean": float(np.mean([r.lid_angle for r in records])),
        **rest,
    }

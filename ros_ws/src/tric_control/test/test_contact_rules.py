"""ContactRules: which pairs of a Closest hold their body's contact (the hand's pairs with a body
the task lets it touch, from the contact's side if it has one), the per-body tables the limits
read, and one answer per Closest. Units: m."""

from dataclasses import replace

import numpy as np
import pinocchio as pin
from closest_samples import hand_made

from tric_control.limits import ContactRules
from tric_sim.world import scene

GRASP = scene.Contact(depth=0.005, cushion=0.003, cushion_weight=3.0)


def test_only_the_hand_s_pairs_with_an_allowed_body_hold_its_contact():
    """The hand against the object holds; the arm against it, the hand against the table, and a
    pair within the robot do not."""
    rules = ContactRules({"object": GRASP})
    pairs = hand_made([0.001] * 4, bodies=[1, 1, 0, -1], hand=[True, False, True, True])
    assert rules.held(pairs).tolist() == [True, False, False, False]


def test_the_tables_give_each_body_its_contact_and_the_robot_none():
    """Per body of the Closest (table, object, lid, then the robot's own pairs): allowed, depth,
    cushion (-inf: none) and cushion weight; the widest cushion of all the contacts."""
    rules = ContactRules({"object": GRASP, "lid": scene.Contact(depth=0.015)})
    rules.held(hand_made([0.01], bodies=[0], hand=[True]))
    assert rules.allowed.tolist() == [False, True, True, False]
    assert rules.depth.tolist() == [0.0, 0.005, 0.015, 0.0]
    assert rules.cushion.tolist() == [-np.inf, 0.003, -np.inf, -np.inf]
    assert rules.cushion_weight.tolist() == [0.0, 3.0, 0.0, 0.0]
    assert rules.widest_cushion == 0.003
    assert ContactRules({}).widest_cushion == 0.0


def test_a_sided_contact_holds_only_from_its_side():
    """A contact from beneath (side (0, 0, -1) in the body's frame): held while the hand moves away
    from the body downwards (it is beneath), not while it moves away upwards (above), also for a
    body turned upside down."""
    rules = ContactRules({"lid": scene.Contact(depth=0.015, side=(0.0, 0.0, -1.0))})
    aways = [[0.0, 0.0, -1.0], [0.0, 0.0, 1.0], [1.0, 0.0, -0.01]]
    upright = hand_made([0.001] * 3, bodies=[2] * 3, hand=[True] * 3, aways=aways)
    assert rules.held(upright).tolist() == [True, False, True]
    flipped = np.tile(np.eye(3), (3, 1, 1))
    flipped[2] = pin.utils.rotate("x", np.pi)
    upside_down = replace(upright, body_rotations=flipped)
    assert rules.held(upside_down).tolist() == [False, True, False]


def test_one_answer_per_closest():
    """The limits that share the rules share the answer for the same Closest; another Closest gets
    its own."""
    rules = ContactRules({"object": GRASP})
    first = hand_made([0.001, 0.002], bodies=[1, 1], hand=[True, False])
    assert rules.held(first) is rules.held(first)
    second = hand_made([0.001, 0.002], bodies=[1, 1], hand=[False, True])
    assert rules.held(second).tolist() == [False, True]
    assert rules.held(first).tolist() == [True, False]

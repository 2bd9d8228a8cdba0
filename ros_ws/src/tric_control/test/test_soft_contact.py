"""SoftContact: within a contact's cushion the hand is pushed back by a quadratic cost whose
gradient and Hessian in dq match finite differences of w (d + r dq - c)^2; pairs that do not hold a
contact with a cushion, or are beyond it, add nothing. Units: m, rad."""

import numpy as np
from closest_samples import hand_made

from tric_control.limits import ContactRules, SoftContact, StepState
from tric_sim.world import scene
from tric_sim.world.proximity import Closest

CUSHION, WEIGHT = 0.003, 3.0


def added(pairs: Closest, contacts: dict, n: int = 3):
    hessian, linear = np.zeros((n, n)), np.zeros(n)
    SoftContact(ContactRules(contacts)).add_cost(StepState(closest=pairs), hessian, linear)
    return hessian, linear


def test_the_cost_matches_finite_differences_of_the_springs():
    """Two hand pairs inside the cushion of the object: the added 1/2 dq^T H dq + c^T dq is the sum
    of w_k (d_k + r_k dq - c)^2 (w_k = weight / |r_k|^2) up to a constant, checked through its
    gradient and Hessian by central differences at random dq."""
    rows = np.array([[1.0, 2.0, 0.0], [0.0, -1.0, 0.5], [0.3, 0.3, 0.3]])
    pairs = hand_made([0.001, -0.002, 0.02], bodies=[1, 1, 1], hand=[True, True, True], rows=rows)
    hessian, linear = added(
        pairs, {"object": scene.Contact(depth=0.005, cushion=CUSHION, cushion_weight=WEIGHT)}
    )

    def cost(dq):
        return sum(
            WEIGHT / (r @ r) * (d + r @ dq - CUSHION) ** 2
            for d, r in zip([0.001, -0.002], rows[:2])
        )

    h = 1e-5
    for dq in np.random.default_rng(0).normal(0, 0.01, (3, 3)):
        gradient = np.array([(cost(dq + h * e) - cost(dq - h * e)) / (2 * h) for e in np.eye(3)])
        assert np.allclose(hessian @ dq + linear, gradient, atol=1e-7)
        second = np.array(
            [
                [
                    (
                        cost(dq + h * a + h * b)
                        - cost(dq + h * a - h * b)
                        - cost(dq - h * a + h * b)
                        + cost(dq - h * a - h * b)
                    )
                    / (4 * h * h)
                    for b in np.eye(3)
                ]
                for a in np.eye(3)
            ]
        )
        assert np.allclose(hessian, second, rtol=1e-4, atol=1e-4)
    assert np.linalg.norm(linear) > 0


def test_only_held_contacts_with_a_cushion_push():
    """The arm against the object, the hand against the table, the hand beyond the cushion, or a
    contact without a cushion: nothing is added."""
    rows = np.eye(3)
    for pairs, contacts in [
        (
            hand_made([0.001], bodies=[1], hand=[False], rows=rows[:1]),
            {"object": scene.Contact(0.005, None, CUSHION, WEIGHT)},
        ),
        (
            hand_made([0.001], bodies=[0], hand=[True], rows=rows[:1]),
            {"object": scene.Contact(0.005, None, CUSHION, WEIGHT)},
        ),
        (
            hand_made([0.004], bodies=[1], hand=[True], rows=rows[:1]),
            {"object": scene.Contact(0.005, None, CUSHION, WEIGHT)},
        ),
        (
            hand_made([-0.001], bodies=[1], hand=[True], rows=rows[:1]),
            {"object": scene.Contact(0.015)},
        ),
    ]:
        hessian, linear = added(pairs, contacts)
        assert not hessian.any() and not linear.any()

"""The hard stops of the simulated joints (the robot's, and the box lid's hinge), and how far a
measured joint went past one. ROS-free.

PyBullet's joint-limit constraints are soft: measured, a constant 3 N m on a finger's distal joint
holds it 0.22 rad past its limit without any contact, and a grasped object pushed distal joints up
to 1 rad past (more solver iterations, a finer physics step or a larger jointLimitForce only shrink
that). JointStops.enforce puts a joint found past a limit after a physics step back on it, and
removes its velocity into the stop. Units: rad, rad/s.
"""

import numpy as np

from tric_sim.physics.bullet import pb
from tric_sim.physics.bullet_scene import LID_RANGE


class JointStops:
    """The stops of a robot's joints in a PyBullet client, and the largest overshoot seen.

    Args:
        client: the PyBullet client id.
        robot_id: the robot's body id.
        joints: the joint indices to hold (n,): the actuated joints, then the mimic joints.
    """

    def __init__(self, client: int, robot_id: int, joints: list):
        self.client, self.robot_id, self.joints = client, robot_id, joints
        infos = [pb.getJointInfo(robot_id, i, physicsClientId=client) for i in joints]
        #: Lower and upper stops (n,), rad, and the joints' names, in the order of joints.
        self.low = np.array([info[8] for info in infos])
        self.high = np.array([info[9] for info in infos])
        self.names = [info[1].decode() for info in infos]
        self.clear()

    def clear(self) -> None:
        """Forget the overshoot measured so far (at a scene's reset)."""
        #: The largest distance a measured joint went past its limit since clear(), rad, and which
        #: joint ("" for none; "lid_hinge" for the box's lid).
        self.max_overshoot, self.max_overshoot_joint = 0.0, ""

    def enforce(self, box) -> None:
        """Put every joint past a stop back on it, its velocity into the stop removed; likewise the
        lid's hinge of the box body (None in a scene without a box)."""
        states = pb.getJointStates(self.robot_id, self.joints, physicsClientId=self.client)
        for k, (position, velocity, *_rest) in enumerate(states):
            if position < self.low[k]:
                pb.resetJointState(
                    self.robot_id,
                    self.joints[k],
                    self.low[k],
                    max(velocity, 0.0),
                    physicsClientId=self.client,
                )
            elif position > self.high[k]:
                pb.resetJointState(
                    self.robot_id,
                    self.joints[k],
                    self.high[k],
                    min(velocity, 0.0),
                    physicsClientId=self.client,
                )
        if box is not None:
            angle, velocity = pb.getJointState(box, 0, physicsClientId=self.client)[:2]
            if not LID_RANGE[0] <= angle <= LID_RANGE[1]:
                low = angle < LID_RANGE[0]
                pb.resetJointState(
                    box,
                    0,
                    LID_RANGE[0] if low else LID_RANGE[1],
                    max(velocity, 0.0) if low else min(velocity, 0.0),
                    physicsClientId=self.client,
                )

    def measure(self, box) -> None:
        """Track the largest distance of a joint (or of the box's lid hinge; box None without a
        box) past its limit now, rad, and the joint it was."""
        states = pb.getJointStates(self.robot_id, self.joints, physicsClientId=self.client)
        positions = np.array([state[0] for state in states])
        overshoot = np.maximum(self.low - positions, positions - self.high)
        worst = int(np.argmax(overshoot))
        candidates = [(float(overshoot[worst]), self.names[worst])]
        if box is not None:
            angle = pb.getJointState(box, 0, physicsClientId=self.client)[0]
            candidates.append((max(LID_RANGE[0] - angle, angle - LID_RANGE[1]), "lid_hinge"))
        best = max(candidates)
        if best[0] > self.max_overshoot:
            self.max_overshoot, self.max_overshoot_joint = best

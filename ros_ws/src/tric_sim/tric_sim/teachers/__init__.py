"""The teachers: expert controllers that know the task and the world, and whose motions TRIC
watches. GraspTeacher (tric_sim.teachers.grasp) grasps spheres and cylinders; BoxTeacher
(tric_sim.teachers.box) plans the box opening. Teachers are ROS-free: each control period they map
the time, the measured joint positions and the objects' poses to joint position targets. This
module picks the teacher of a task and runs it on the physics without ROS. Units: m, rad, s.
"""

from tric_sim.teachers.box import BoxTeacher
from tric_sim.teachers.grasp import GraspTeacher
from tric_sim.world.robot_model import RobotModel
from tric_sim.world.situation import Situation


def make_teacher(robot: RobotModel, situation: Situation, q_start, period: float = 0.01):
    """The teacher of the situation's task (a box teacher plans here, which takes seconds)."""
    if situation.task == "open_box":
        return BoxTeacher(robot, situation, q_start, period)
    return GraspTeacher(robot, situation, period)


def demonstrate(world, robot: RobotModel, situation: Situation, duration: float, on_period=None):
    """Run the situation's teacher on a PhysicsWorld directly (no ROS) for duration simulated
    seconds; on_period(world, teacher, k) is called after each control period. Returns the
    teacher."""
    world.reset(situation)
    q, _ = world.joint_state()
    teacher = make_teacher(robot, situation, q, world.control_period)
    for k in range(int(round(duration / world.control_period))):
        q, _ = world.joint_state()
        world.command(teacher.command(k * world.control_period, q, world.object_poses()))
        world.step()
        if on_period is not None:
            on_period(world, teacher, k)
    return teacher

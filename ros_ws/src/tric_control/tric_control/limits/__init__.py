"""The pieces of the motion-rate step's QP, one class per file (see base.Limit for what a piece may
add): the joints' limits and step bound (JointLimits), collision avoidance (CollisionDamper), the
learned model's domain (DomainDamper), and the soft side of contact (SoftContact). The controller
(tric_control.motion_rate) only stacks what they return."""

from tric_control.limits.base import UNBOUNDED_BELOW, Limit, StepState, damper_bounds
from tric_control.limits.collision_damper import CollisionDamper
from tric_control.limits.contact_rules import ContactRules
from tric_control.limits.domain_damper import DomainDamper
from tric_control.limits.joint_limits import JointLimits
from tric_control.limits.soft_contact import SoftContact

__all__ = [
    "UNBOUNDED_BELOW",
    "Limit",
    "StepState",
    "damper_bounds",
    "CollisionDamper",
    "ContactRules",
    "DomainDamper",
    "JointLimits",
    "SoftContact",
]

"""femb's element library (installed as ``femb.elements``).

Bodies: :class:`RigidBody`, :class:`PointMass`, :class:`Ground`.
Joints: :class:`Hinge`, :class:`Slider`, :class:`PointOnLine`.
Drivers (rheonomic constraints): :class:`DrivenAngle`, :class:`DrivenDisplacement`.
Forces: :class:`SpringDamper`, :class:`RotationalSpringDamper`, :class:`Force`,
:class:`Torque`, :class:`Gravity`.
"""
from .bodies import Body, Ground, PointMass, RigidBody
from .forces import Force, Gravity, RotationalSpringDamper, SpringDamper, Torque
from .joints import DrivenAngle, DrivenDisplacement, Hinge, PointOnLine, Slider

__all__ = ["Body", "Ground", "PointMass", "RigidBody", "Hinge", "Slider", "PointOnLine",
           "DrivenAngle", "DrivenDisplacement", "SpringDamper", "RotationalSpringDamper", "Force",
           "Torque", "Gravity"]

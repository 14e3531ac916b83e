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
from .beam import BeamMesh, BeamNode, Clamp, ReissnerBeam, Section, add_beam, beam_resultants, beam_strain_energy  # noqa: E402
__all__ += ["Section", "BeamNode", "ReissnerBeam", "Clamp", "BeamMesh", "add_beam", "beam_resultants", "beam_strain_energy"]

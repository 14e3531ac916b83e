"""femb's element library (installed as ``femb.elements``).

Bodies: :class:`RigidBody`, :class:`PointMass`, :class:`Ground`.
Joints: :class:`Hinge`, :class:`Slider`, :class:`PointOnLine`.
Drivers (rheonomic constraints): :class:`DrivenAngle`, :class:`DrivenDisplacement`.
Forces: :class:`SpringDamper`, :class:`RotationalSpringDamper`, :class:`Force`,
:class:`Torque`, :class:`Gravity`.
Beams: :class:`ReissnerBeam`, :class:`BeamNode`, :class:`Clamp`, :func:`add_beam`.

Spatial (``docs/spatial.md``) — bodies: :class:`SpatialRigidBody`,
:class:`SpatialPointMass`; joints: :class:`SphericalJoint`, :class:`RevoluteJoint`,
:class:`UniversalJoint`, :class:`CylindricalJoint`, :class:`PrismaticJoint`,
:class:`FixedJoint`, :class:`DistanceJoint`; drivers: :class:`DrivenRevoluteAngle`,
:class:`DrivenPrismaticDisplacement`; forces: :class:`PointSpringDamper`,
:class:`Bushing`, :class:`SpatialRotationalSpringDamper` (the class
``RotationalSpringDamper`` of :mod:`femb.elements.spatial_forces`; the planar one
keeps the short name here), :class:`SpatialForce`, :class:`SpatialTorque`,
:class:`SpatialGravity`.
"""
from .bodies import Body, Ground, PointMass, RigidBody
from .forces import Force, Gravity, RotationalSpringDamper, SpringDamper, Torque
from .joints import DrivenAngle, DrivenDisplacement, Hinge, PointOnLine, Slider

__all__ = ["Body", "Ground", "PointMass", "RigidBody", "Hinge", "Slider", "PointOnLine",
           "DrivenAngle", "DrivenDisplacement", "SpringDamper", "RotationalSpringDamper", "Force",
           "Torque", "Gravity"]
from .beam import BeamMesh, BeamNode, Clamp, ReissnerBeam, Section, add_beam, beam_resultants, beam_strain_energy  # noqa: E402
__all__ += ["Section", "BeamNode", "ReissnerBeam", "Clamp", "BeamMesh", "add_beam", "beam_resultants", "beam_strain_energy"]
from .spatial_bodies import FrameNode, SpatialPointMass, SpatialRigidBody, spatial_ground  # noqa: E402
from .spatial_joints import (CylindricalJoint, DistanceJoint, DrivenPrismaticDisplacement,  # noqa: E402
                             DrivenRevoluteAngle, FixedJoint, PrismaticJoint, RevoluteJoint, SphericalJoint,
                             UniversalJoint)
from .spatial_forces import Bushing, PointSpringDamper, SpatialForce, SpatialGravity, SpatialTorque  # noqa: E402
from .spatial_forces import RotationalSpringDamper as SpatialRotationalSpringDamper  # noqa: E402
__all__ += ["FrameNode", "SpatialPointMass", "SpatialRigidBody", "spatial_ground", "SphericalJoint", "RevoluteJoint", "UniversalJoint", "CylindricalJoint",
            "PrismaticJoint", "FixedJoint", "DistanceJoint", "DrivenRevoluteAngle", "DrivenPrismaticDisplacement",
            "PointSpringDamper", "Bushing", "SpatialRotationalSpringDamper", "SpatialForce", "SpatialTorque",
            "SpatialGravity"]
# penalty (compliant) contact: force elements of the compiled engine (docs/contact.md)
from .penalty_contact import (PenaltySphereOnPlane, SpatialPenaltySphereOnBodyPlane,  # noqa: E402
                              SpatialPenaltySpherePair, SpatialPenaltySphereOnPlane)
__all__ += ["PenaltySphereOnPlane", "SpatialPenaltySphereOnPlane", "SpatialPenaltySpherePair",
            "SpatialPenaltySphereOnBodyPlane"]

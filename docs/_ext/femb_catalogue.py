"""Sphinx extension: the element catalogue, pictured by femb itself.

For every element type of :mod:`femb.elements` (planar, spatial, spatial
beams, rolling, contact) a tiny mechanism (a builder function below) is
compiled, simulated for a moment with :func:`femb.simulate` (contact:
:func:`femb.contact.simulate`; rolling constraints, which the time loop
refuses: no run, the initial configuration), written as a VTK time series and
rendered off-screen with :func:`femb.io.render.render_png`. The pictures and the catalogue text
(``catalogue.inc``, with each builder's source) go to ``_generated/``.

The build fails (a Sphinx warning, an error under ``-W``) when an element
type exported by :mod:`femb.elements` has no entry here, and (an extension
error) when a mechanism fails to simulate or render.
"""
from __future__ import annotations

import inspect
import math
import shutil
import tempfile
import textwrap
import time
from dataclasses import dataclass
from pathlib import Path

from sphinx.errors import ExtensionError
from sphinx.util import logging

logger = logging.getLogger(__name__)

PICTURE_SIZE = (640, 400)


# ---------------------------------------------------------------------------
# one tiny mechanism per element type
# ---------------------------------------------------------------------------
def rigid_body():
    import femb
    from femb.elements import RigidBody

    mech = femb.Mechanism("rigid_bodies")
    mech.add(RigidBody("bar", 1.0, 0.02, (0.0, 0.0), 0.3, omega=2.0,
                       points={"A": (-0.25, 0.0), "B": (0.25, 0.0)}, shape={"type": "bar", "width": 0.04}))
    mech.add(RigidBody("box", 1.0, 0.01, (0.5, 0.1), velocity=(0.2, 0.0), shape={"type": "box", "size": (0.2, 0.12)}))
    mech.add(RigidBody("disc", 1.0, 0.01, (0.9, 0.0), shape={"type": "disc", "radius": 0.1}))
    mech.add(RigidBody("plate", 1.0, 0.01, (1.3, 0.0), omega=-1.0,
                       shape={"type": "polygon", "points": [(-0.1, -0.1), (0.15, -0.05), (0.0, 0.15)]}))
    return mech


def point_mass():
    import femb
    from femb.elements import Gravity, PointMass

    mech = femb.Mechanism("point_masses")
    mech.add(PointMass("p1", 1.0, (0.0, 0.0), velocity=(1.0, 2.0), shape={"type": "box", "size": (0.08, 0.08)}))
    mech.add(PointMass("p2", 1.0, (0.4, 0.0), velocity=(0.5, 1.0), shape={"type": "disc", "radius": 0.05}))
    mech.add(Gravity((0.0, -9.81)))
    return mech


def ground():
    import femb
    from femb.elements import Hinge, RigidBody

    mech = femb.Mechanism("ground_points")
    g = mech.ground
    for k, xy in enumerate([(0.0, 0.0), (0.6, 0.0), (1.2, 0.0), (0.6, 0.4)]):
        g.add_point(f"P{k}", xy)
    arm = mech.add(RigidBody("arm", 1.0, 0.02, (0.15, 0.0), points={"O": (-0.15, 0.0)},
                                velocity=(0.0, 0.15), omega=1.0))          # v = ω × (r − r_O)
    mech.add(Hinge("pin", g, arm, point_a="P0", point_b="O"))
    return mech


def hinge():
    import femb
    from femb.elements import Gravity, Hinge, RigidBody

    mech = femb.Mechanism("double_pendulum")
    b1 = mech.add(RigidBody("b1", 1.0, 1 / 48, (0.25, 0.0), points={"O": (-0.25, 0.0), "A": (0.25, 0.0)},
                            shape={"type": "bar", "width": 0.03}))
    b2 = mech.add(RigidBody("b2", 1.0, 1 / 48, (0.75, 0.0), points={"A": (-0.25, 0.0)},
                            shape={"type": "bar", "width": 0.03}))
    mech.add(Hinge("O", "ground", b1, point_b="O"), Hinge("A", b1, b2, at=(0.5, 0.0)), Gravity())
    return mech


def slider():
    import femb
    from femb.elements import Hinge, RigidBody, Slider

    mech = femb.Mechanism("slider_on_arm")
    arm = mech.add(RigidBody("arm", 2.0, 0.2, (0.5, 0.0), omega=1.5, velocity=(0.0, 0.75),
                             points={"O": (-0.5, 0.0)}, shape={"type": "bar", "width": 0.03}))
    blk = mech.add(RigidBody("block", 0.5, 0.002, (0.3, 0.0), omega=1.5, velocity=(0.0, 0.45),
                             shape={"type": "box", "size": (0.12, 0.08)}))
    mech.add(Hinge("O", "ground", arm, point_b="O"), Slider("rail", arm, blk, axis=(1.0, 0.0)))
    return mech


def point_on_line():
    import femb
    from femb.elements import Gravity, PointMass, PointOnLine

    mech = femb.Mechanism("incline")
    a = 0.5
    p = mech.add(PointMass("p", 1.0, (0.6 * math.cos(a), 0.6 * math.sin(a)), shape={"type": "disc", "radius": 0.04}))
    mech.add(PointOnLine("track", "ground", p, axis=(math.cos(a), math.sin(a))), Gravity())
    return mech


def driven_angle():
    import femb
    from femb.base.functions import Linear
    from femb.elements import DrivenAngle, Hinge, RigidBody

    mech = femb.Mechanism("motor")
    crank = mech.add(RigidBody("crank", 1.0, 0.01, (0.15, 0.0), points={"O": (-0.15, 0.0)},
                               shape={"type": "bar", "width": 0.03}))
    mech.add(Hinge("O", "ground", crank, point_b="O"),
             DrivenAngle("motor", "ground", crank, Linear(3.0)))      # φ(t) = 3 t rad
    return mech


def driven_displacement():
    import femb
    from femb.base.functions import Harmonic
    from femb.elements import DrivenDisplacement, RigidBody, Slider

    mech = femb.Mechanism("actuator")
    blk = mech.add(RigidBody("block", 1.0, 0.01, (0.3, 0.0), shape={"type": "box", "size": (0.12, 0.08)}))
    mech.add(Slider("rail", "ground", blk, axis=(1.0, 0.0)),
             DrivenDisplacement("act", "ground", blk, Harmonic(0.1, 2 * math.pi), axis=(1.0, 0.0)))
    return mech


def spring_damper():
    import femb
    from femb.elements import Gravity, PointMass, SpringDamper

    mech = femb.Mechanism("hanging_mass")
    mech.ground.add_point("top", (0.0, 0.5))
    m = mech.add(PointMass("m", 1.0, (0.2, 0.0), shape={"type": "box", "size": (0.1, 0.1)}))
    mech.add(SpringDamper("spring", "ground", m, stiffness=50.0, damping=0.5, length=0.4, point_a="top"), Gravity())
    return mech


def rotational_spring_damper():
    import femb
    from femb.elements import Hinge, RigidBody, RotationalSpringDamper

    mech = femb.Mechanism("torsion")
    bar = mech.add(RigidBody("bar", 1.0, 0.03, (0.3, 0.0), points={"O": (-0.3, 0.0)}, omega=2.0, velocity=(0.0, 0.6),
                             shape={"type": "bar", "width": 0.03}))
    mech.add(Hinge("O", "ground", bar, point_b="O"),
             RotationalSpringDamper("torsion", "ground", bar, stiffness=5.0, damping=0.05))
    return mech


def force():
    import femb
    from femb.elements import Force, Hinge, RigidBody

    mech = femb.Mechanism("loaded_bar")
    bar = mech.add(RigidBody("bar", 1.0, 0.03, (0.3, 0.0), points={"O": (-0.3, 0.0), "tip": (0.3, 0.0)},
                             shape={"type": "bar", "width": 0.03}))
    mech.add(Hinge("O", "ground", bar, point_b="O"),
             Force("push", bar, (0.0, 2.0), point="tip"),                 # inertial components
             Force("follower", bar, (0.0, -1.0), point=(0.0, 0.0), frame="body"))
    return mech


def torque():
    import femb
    from femb.elements import Hinge, RigidBody, Torque

    mech = femb.Mechanism("wheel")
    wheel = mech.add(RigidBody("wheel", 1.0, 0.005, (0.0, 0.0), points={"rim": (0.1, 0.0)},
                               shape={"type": "disc", "radius": 0.1}))
    mech.add(Hinge("axle", "ground", wheel), Torque("drive", wheel, 0.05))
    return mech


def gravity():
    import femb
    from femb.elements import Gravity, Hinge, RigidBody

    mech = femb.Mechanism("pendulum")
    bar = mech.add(RigidBody("bar", 1.0, 1 / 12, (0.5, 0.0), points={"O": (-0.5, 0.0)},
                             shape={"type": "bar", "width": 0.04}))
    mech.add(Hinge("pivot", "ground", bar, point_b="O"), Gravity((0.0, -9.81)))
    return mech


def beam():
    import femb
    from femb.elements import Gravity, Section, add_beam

    mech = femb.Mechanism("cantilever")
    steel = Section.circle(2.1e11, 8.1e10, 0.01, 7850.0)                 # E, G, diameter, density
    add_beam(mech, "beam", steel, (0.0, 0.0), (1.0, 0.0), 8, start_joint="clamp")
    mech.add(Gravity())
    return mech


def clamp():
    import femb
    from femb.elements import Clamp, Gravity, Hinge, RigidBody

    mech = femb.Mechanism("welded_L")
    b1 = mech.add(RigidBody("b1", 1.0, 0.03, (0.3, 0.0), points={"O": (-0.3, 0.0), "A": (0.3, 0.0)},
                            shape={"type": "bar", "width": 0.03}))
    b2 = mech.add(RigidBody("b2", 0.5, 0.004, (0.6, -0.15), 0.5 * math.pi, points={"A": (0.15, 0.0)},
                            shape={"type": "bar", "width": 0.03}))
    mech.add(Hinge("O", "ground", b1, point_b="O"), Clamp("weld", b1, b2, at=(0.6, 0.0)), Gravity())
    return mech


# ---------------------------------------------------------------------------
# spatial element types (pictured as 3-D mechanisms: bodies, joints, ground)
# ---------------------------------------------------------------------------
def spatial_bodies():
    import femb
    from femb.elements.spatial_bodies import SpatialPointMass, SpatialRigidBody, box_inertia
    from femb.elements.spatial_forces import SpatialGravity

    mech = femb.Mechanism("spatial_bodies")
    J = box_inertia(1.0, 0.3, 0.15, 0.08)
    mech.add(SpatialRigidBody("box", 1.0, J, position=(0.0, 0.0, 0.5), velocity=(0.4, 0.0, 1.2),
                              omega=(0.5, 3.0, 1.0), shape={"type": "box", "size": (0.3, 0.15, 0.08)}))
    mech.add(SpatialRigidBody("drum", 1.0, (0.01, 0.01, 0.005), position=(0.5, 0.0, 0.5), velocity=(0.0, 0.3, 1.2),
                              omega=(2.0, 0.0, 4.0),
                              shape={"type": "cylinder", "radius": 0.08, "length": 0.2, "axis": (0, 0, 1)}))
    mech.add(SpatialRigidBody("ball", 1.0, (0.004, 0.004, 0.004), position=(1.0, 0.0, 0.5), velocity=(0.0, 0.0, 1.0),
                              shape={"type": "sphere", "radius": 0.1}))
    mech.add(SpatialRigidBody("tetra", 1.0, (0.005, 0.005, 0.005), position=(0.0, 0.5, 0.5), omega=(1.0, 2.0, 0.0),
                              points={"a": (0.15, 0.0, -0.05), "b": (-0.1, 0.12, -0.05), "c": (-0.1, -0.12, -0.05),
                                      "d": (0.0, 0.0, 0.15)}))        # no shape: the hull of its points
    mech.add(SpatialPointMass("pebble", 0.2, position=(0.5, 0.5, 0.5), velocity=(0.3, 0.0, 1.5)))
    mech.add(SpatialGravity((0.0, 0.0, -9.81)))
    return mech


def spatial_pendulum():
    import femb
    from femb.elements.spatial_bodies import SpatialRigidBody, rod_inertia, spatial_ground
    from femb.elements.spatial_forces import SpatialGravity
    from femb.elements.spatial_joints import RevoluteJoint, SphericalJoint

    mech = femb.Mechanism("revolute_spherical")
    spatial_ground(mech).add_point("pivot", (0.0, 0.0, 1.0))          # a named ground point
    upper = mech.add(SpatialRigidBody("upper", 1.0, rod_inertia(1.0, 0.4, 0.02), position=(0.2, 0.0, 1.0),
                                      points={"O": (-0.2, 0, 0), "A": (0.2, 0, 0)}))
    lower = mech.add(SpatialRigidBody("lower", 1.0, rod_inertia(1.0, 0.4, 0.02), position=(0.4, 0.0, 0.8),
                                      rotation=[[0, 0, 1], [0, 1, 0], [-1, 0, 0]],   # body x pointing down
                                      velocity=(0.0, 0.6, 0.0), omega_space=(3.0, 0.0, 0.0),
                                      points={"A": (-0.2, 0, 0)}))
    mech.add(RevoluteJoint("hinge", "ground", upper, point_a="pivot", point_b="O", axis=(0.0, 1.0, 0.0)),
             SphericalJoint("ball", upper, lower, at=(0.4, 0.0, 1.0)), SpatialGravity((0.0, 0.0, -9.81)))
    return mech


def spatial_line_joints():
    import numpy as np

    import femb
    from femb.elements.spatial_bodies import SpatialRigidBody, box_inertia, rod_inertia
    from femb.elements.spatial_forces import SpatialGravity
    from femb.elements.spatial_joints import CylindricalJoint, PrismaticJoint, UniversalJoint

    mech = femb.Mechanism("line_joints")
    rail = np.array([1.0, 0.0, -0.5]) / np.sqrt(1.25)                      # a tilted rail
    block = mech.add(SpatialRigidBody("block", 1.0, box_inertia(1.0, 0.12, 0.1, 0.08), position=(0.0, 0.0, 0.6),
                                      shape={"type": "box", "size": (0.12, 0.1, 0.08)}))
    sleeve = mech.add(SpatialRigidBody("sleeve", 0.5, (0.002, 0.002, 0.001), position=(0.0, 0.6, 0.6),
                                       omega=(0.0, 0.0, 8.0), velocity=(0.0, 0.0, 2.0),
                                       shape={"type": "cylinder", "radius": 0.05, "length": 0.1, "axis": (0, 0, 1)}))
    arm = mech.add(SpatialRigidBody("arm", 0.5, rod_inertia(0.5, 0.3, 0.02), position=(0.6, 0.3, 0.45),
                                    rotation=[[0, 0, 1], [0, 1, 0], [-1, 0, 0]], omega_space=(2.0, 0.0, 0.0),
                                    velocity=(0.0, 0.3, 0.0), points={"top": (-0.15, 0, 0)}))
    mech.add(PrismaticJoint("slide", "ground", block, at=(0.0, 0.0, 0.6), axis=rail),
             CylindricalJoint("post", "ground", sleeve, at=(0.0, 0.6, 0.6), axis=(0.0, 0.0, 1.0)),
             UniversalJoint("cardan", "ground", arm, axis_a=(1.0, 0.0, 0.0), axis_b=(0.0, 1.0, 0.0),
                            at=(0.6, 0.3, 0.6)),
             SpatialGravity((0.0, 0.0, -9.81)))
    return mech


def spatial_fixed_distance():
    import femb
    from femb.elements.spatial_bodies import SpatialRigidBody, rod_inertia, spatial_ground
    from femb.elements.spatial_forces import SpatialGravity
    from femb.elements.spatial_joints import DistanceJoint, FixedJoint

    mech = femb.Mechanism("weld_and_link")
    spatial_ground(mech).add_point("hook", (0.0, 0.0, 1.0))
    a = mech.add(SpatialRigidBody("beam", 1.0, rod_inertia(1.0, 0.4, 0.02), position=(0.3, 0.0, 0.6),
                                  velocity=(0.0, 0.8, 0.0), points={"end": (-0.2, 0, 0), "tip": (0.2, 0, 0)},
                                  shape={"type": "box", "size": (0.4, 0.04, 0.04)}))
    b = mech.add(SpatialRigidBody("post", 0.5, rod_inertia(0.5, 0.2, 0.02), position=(0.5, 0.0, 0.7),
                                  rotation=[[0, 0, -1], [0, 1, 0], [1, 0, 0]], velocity=(0.0, 0.8, 0.0),
                                  shape={"type": "box", "size": (0.2, 0.04, 0.04)}))
    mech.add(DistanceJoint("link", "ground", a, point_a="hook", point_b="end"),        # a massless rod
             FixedJoint("weld", a, b, at=(0.5, 0.0, 0.6)), SpatialGravity((0.0, 0.0, -9.81)))
    return mech


def spatial_drives():
    import femb
    from femb.elements.spatial_bodies import SpatialRigidBody, box_inertia, rod_inertia
    from femb.elements.spatial_joints import (DrivenPrismaticDisplacement, DrivenRevoluteAngle, PrismaticJoint,
                                              RevoluteJoint)
    from femb.base.functions import Harmonic, Linear

    mech = femb.Mechanism("drives")
    crank = mech.add(SpatialRigidBody("crank", 1.0, rod_inertia(1.0, 0.4, 0.02), position=(0.2, 0.0, 0.3),
                                      points={"O": (-0.2, 0, 0)}))
    table = mech.add(SpatialRigidBody("table", 1.0, box_inertia(1.0, 0.2, 0.2, 0.05), position=(0.0, 0.7, 0.1),
                                      shape={"type": "box", "size": (0.2, 0.2, 0.05)}))
    mech.add(RevoluteJoint("axle", "ground", crank, at=(0.0, 0.0, 0.3), axis=(0.0, 0.0, 1.0)),
             DrivenRevoluteAngle("motor", "ground", crank, Linear(2.0), at=(0.0, 0.0, 0.3), axis=(0.0, 0.0, 1.0)),
             PrismaticJoint("guide", "ground", table, at=(0.0, 0.7, 0.1), axis=(0.0, 0.0, 1.0)),
             DrivenPrismaticDisplacement("lift", "ground", table, Harmonic(0.15, 3.0), at=(0.0, 0.7, 0.1),
                                         axis=(0.0, 0.0, 1.0)))
    return mech


def spatial_springs():
    import femb
    from femb.elements.spatial_bodies import SpatialRigidBody, box_inertia, rod_inertia, spatial_ground
    from femb.elements.spatial_forces import Bushing, PointSpringDamper, RotationalSpringDamper, SpatialGravity
    from femb.elements.spatial_joints import RevoluteJoint

    mech = femb.Mechanism("springs")
    spatial_ground(mech).add_point("top", (0.0, 0.0, 1.0))
    bob = mech.add(SpatialRigidBody("bob", 1.0, box_inertia(1.0, 0.1, 0.1, 0.1), position=(0.1, 0.0, 0.6),
                                    shape={"type": "sphere", "radius": 0.05}))
    pad = mech.add(SpatialRigidBody("pad", 1.0, box_inertia(1.0, 0.12, 0.12, 0.04), position=(0.5, 0.0, 0.55),
                                    velocity=(0.0, 0.0, 0.5), omega=(1.0, 0.0, 0.0),
                                    shape={"type": "box", "size": (0.12, 0.12, 0.04)}))
    bar = mech.add(SpatialRigidBody("bar", 1.0, rod_inertia(1.0, 0.3, 0.02), position=(1.0, 0.0, 0.65),
                                    omega_space=(0.0, 0.0, 3.0), velocity=(0.0, 0.45, 0.0),
                                    points={"O": (-0.15, 0, 0)}))
    mech.add(PointSpringDamper("coil", "ground", bob, stiffness=60.0, damping=0.5, length=0.3, point_a="top"),
             Bushing("mount", "ground", pad, stiffness=(200.0, 200.0, 200.0), rotational_stiffness=(5.0, 5.0, 5.0),
                     at=(0.5, 0.0, 0.45)),                               # under the pad
             RevoluteJoint("pin", "ground", bar, at=(0.85, 0.0, 0.65), axis=(0.0, 0.0, 1.0)),
             RotationalSpringDamper("torsion", "ground", bar, stiffness=2.0, damping=0.02, at=(0.85, 0.0, 0.65),
                                    axis=(0.0, 0.0, 1.0)),
             SpatialGravity((0.0, 0.0, -9.81)))
    return mech


def spatial_loads():
    import femb
    from femb.elements.spatial_bodies import SpatialRigidBody, rod_inertia
    from femb.elements.spatial_forces import SpatialForce, SpatialTorque
    from femb.elements.spatial_joints import SphericalJoint

    mech = femb.Mechanism("loads")
    rod = mech.add(SpatialRigidBody("rod", 1.0, rod_inertia(1.0, 0.6, 0.02), position=(0.3, 0.0, 0.5),
                                    points={"O": (-0.3, 0, 0), "tip": (0.3, 0, 0)}))
    mech.add(SphericalJoint("ball", "ground", rod, at=(0.0, 0.0, 0.5)),
             SpatialForce("push", rod, (0.0, 1.0, 0.0), point="tip", follower=True),    # turns with the rod
             SpatialTorque("twist", rod, (0.0, 0.0, 0.05), follower=True))
    return mech


def spatial_beam():
    import femb
    from femb.elements.spatial_beam import SpatialSection, spatial_beam as mesh_beam
    from femb.elements.spatial_bodies import SpatialRigidBody, box_inertia
    from femb.elements.spatial_forces import SpatialGravity

    mech = femb.Mechanism("cantilever_3d")
    steel = SpatialSection.rectangle(E=2.1e11, G=8.1e10, width=0.02, height=0.01, density=7850.0)
    tip = mech.add(SpatialRigidBody("tip_mass", 0.5, box_inertia(0.5, 0.06, 0.06, 0.06), position=(0.8, 0.3, 0.5),
                                    shape={"type": "box", "size": (0.06, 0.06, 0.06)}))
    mesh_beam(mech, "arm", steel, [(0.0, 0.0, 0.5), (0.5, 0.0, 0.5), (0.8, 0.3, 0.5)], (5, 3),  # an L: a rigid elbow
              start="clamp", end=tip)                                                       # welded to the mass
    mech.add(SpatialGravity((0.0, 0.0, -9.81)))
    return mech


def rolling_disc():
    import numpy as np

    import femb
    from femb.base.rotations import expm
    from femb.elements.rolling import RollingDisc, SpinRate
    from femb.elements.spatial_bodies import SpatialRigidBody
    from femb.elements.spatial_forces import SpatialGravity

    mech = femb.Mechanism("rolling_coin")
    R0 = expm(np.array([0.3, 0.0, 0.2]))                     # tilted by 0.3 rad, heading 0.2 rad
    a, n = R0 @ np.array([0.0, 1.0, 0.0]), np.array([0.0, 0.0, 1.0])
    d = (n - (n @ a) * a) / np.linalg.norm(n - (n @ a) * a)  # from the contact point to the centre
    mech.add(SpatialRigidBody("coin", 1.0, (0.25, 0.5, 0.25), position=0.5 * d, rotation=R0,
                              shape={"type": "cylinder", "radius": 0.5, "length": 0.05, "axis": (0.0, 1.0, 0.0)}),
             RollingDisc("roll", "coin", 0.5, (0.0, 1.0, 0.0)),
             SpatialRigidBody("frame", 2.0, (0.3, 0.4, 0.5), position=(0.0, 0.0, 1.2),
                              shape={"type": "box", "size": (0.3, 0.2, 0.1)}),
             SpinRate("drive", "frame", "coin", (0.0, 1.0, 0.0), 3.0),
             SpatialGravity())
    return mech


def planar_rolling():
    import femb
    from femb.elements import RigidBody
    from femb.elements.rolling import KnifeEdge, PlanarWheel

    mech = femb.Mechanism("wheel_and_sled")
    mech.add(RigidBody("wheel", 1.0, 0.045, position=(0.0, 0.3), angle=0.2, shape={"type": "disc", "radius": 0.3}),
             PlanarWheel("rolls", "wheel", 0.3),
             RigidBody("sled", 1.0, 0.1, position=(1.0, 0.3), angle=0.2,
                       shape={"type": "box", "size": (0.5, 0.2)}),
             KnifeEdge("blade", "sled", 0.0, (0.2, 0.0)))
    return mech


def planar_contact():
    import femb
    from femb.elements import Gravity, Hinge, RigidBody
    from femb.elements.contact import DiscOnDisc, PinInHole, SphereOnPlane

    mech = femb.Mechanism("contacts")
    ball = mech.add(RigidBody("ball", 1.0, 0.004, (0.0, 0.3), shape={"type": "disc", "radius": 0.1}))
    puck = mech.add(RigidBody("puck", 1.0, 0.004, (0.05, 0.7), shape={"type": "disc", "radius": 0.1}))
    mech.ground.add_point("P", (0.8, 0.5))
    arm = mech.add(RigidBody("arm", 1.0, 0.03, (0.8, 0.3), 1.5707963267948966, points={"hole": (0.2, 0.0)},
                             velocity=(0.3, 0.0), shape={"type": "bar", "width": 0.05}))
    mech.add(SphereOnPlane("floor", ball, radius=0.1, e_N=0.5),           # a ball on the floor y = 0
             DiscOnDisc("stack", ball, puck, 0.1, 0.1, e_N=0.3, mu=0.2),   # a puck falling on it
             PinInHole("clearance", arm, "ground", 0.03, 0.02, point_a="hole", point_b="P"),
             Gravity((0.0, -9.81)))
    return mech


def spatial_contact():
    import femb
    from femb.elements.contact import SpatialSphereOnPlane, SpatialSpherePair
    from femb.elements.spatial_bodies import SpatialRigidBody
    from femb.elements.spatial_forces import SpatialGravity

    mech = femb.Mechanism("ball_3d")
    mech.add(SpatialRigidBody("ball", 1.0, (0.004, 0.004, 0.004), position=(0.0, 0.0, 0.4), velocity=(0.5, 0.2, 0.0),
                              omega=(0.0, 20.0, 0.0), shape={"type": "sphere", "radius": 0.1}),
             SpatialSphereOnPlane("floor", "ball", radius=0.1, e_N=0.5, mu=0.3),
             SpatialRigidBody("ball2", 1.0, (0.004, 0.004, 0.004), position=(-0.43, 0.02, 0.5),
                              shape={"type": "sphere", "radius": 0.1}),         # falls on a sphere fixed in space
             SpatialSpherePair("on_sphere", "ground", "ball2", 0.15, 0.1, point_a=(-0.45, 0.0, 0.15), e_N=0.3, mu=0.3),
             SpatialSphereOnPlane("floor2", "ball2", radius=0.1, e_N=0.5, mu=0.3),
             SpatialGravity((0.0, 0.0, -9.81)))
    return mech


def body_plane_contact():
    import femb
    from femb.elements import Gravity, Hinge, RigidBody
    from femb.elements.contact import SphereOnBodyPlane

    mech = femb.Mechanism("seesaw")
    mech.add(RigidBody("board", 2.0, 0.1, (0.0, 0.2), -0.15, shape={"type": "box", "size": (0.8, 0.04)}),
             Hinge("pivot", "ground", "board", at=(0.0, 0.2)),
             RigidBody("ball", 0.5, 0.002, (0.3, 0.6), shape={"type": "disc", "radius": 0.1}),
             # the board's top face (y = 0.02 in its frame) moves and turns with it
             SphereOnBodyPlane("on_board", "ball", "board", radius=0.1, plane_point=(0.0, 0.02), e_N=0.3, mu=0.4),
             Gravity((0.0, -9.81)))
    return mech


def spatial_body_plane_contact():
    import femb
    from femb.elements.contact import SpatialSphereOnBodyPlane
    from femb.elements.spatial_bodies import SpatialRigidBody
    from femb.elements.spatial_forces import SpatialGravity
    from femb.elements.spatial_joints import RevoluteJoint

    mech = femb.Mechanism("tilting_table")
    mech.add(SpatialRigidBody("table", 4.0, (0.05, 0.2, 0.25), position=(0.0, 0.0, 0.2),
                              rotation=(0.9950042, 0.0998334, 0.0, 0.0), shape={"type": "box", "size": (0.8, 0.5, 0.04)}),
             RevoluteJoint("axle", "ground", "table", at=(0.0, 0.0, 0.2), axis=(0.0, 1.0, 0.0)),
             SpatialRigidBody("ball", 0.5, (0.002, 0.002, 0.002), position=(0.25, 0.1, 0.6), omega=(0.0, 0.0, 15.0),
                              shape={"type": "sphere", "radius": 0.1}),
             # the table's top face (z = 0.02 in its axes) moves and turns with it
             SpatialSphereOnBodyPlane("on_table", "ball", "table", radius=0.1, plane_point=(0.0, 0.0, 0.02), e_N=0.3,
                                      mu=0.4),
             SpatialGravity((0.0, 0.0, -9.81)))
    return mech


def spatial_pin_bushing():
    import femb
    from femb.elements.contact import pin_bushing
    from femb.elements.spatial_bodies import SpatialRigidBody
    from femb.elements.spatial_forces import SpatialGravity

    mech = femb.Mechanism("shaft_in_bushing")
    mech.add(SpatialRigidBody("shaft", 1.0, (2e-4, 3e-3, 3e-3), position=(0.0, 0.0, 0.0), velocity=(0.2, 0.05, 0.0),
                              omega=(15.0, 0.0, 0.5),
                              shape={"type": "cylinder", "radius": 0.02, "length": 0.3, "axis": (1.0, 0.0, 0.0)}),
             SpatialGravity((0.0, 0.0, -9.81)))
    # a bushing fixed in space along x, 0.2 m long, 2 mm of radial clearance: its two end contacts
    mech.add(*pin_bushing("bearing", "shaft", "ground", 0.022, 0.02, 0.2, axis=(1.0, 0.0, 0.0), e_N=0.3, mu=0.2))
    return mech


def penalty_contact():
    import femb
    from femb.elements import (FixedJoint, SpatialGravity, SpatialPenaltySphereOnBodyPlane, SpatialPenaltySpherePair,
                               SpatialPenaltySphereOnPlane, SpatialRigidBody)

    mech = femb.Mechanism("penalty_balls")
    mech.add(SpatialRigidBody("ball", 1.0, (0.004, 0.004, 0.004), position=(0.0, 0.0, 0.3), velocity=(0.5, 0.0, 0.0),
                              omega=(0.0, -20.0, 0.0), shape={"type": "sphere", "radius": 0.1}),
             SpatialRigidBody("ball2", 1.0, (0.004, 0.004, 0.004), position=(0.3, 0.02, 0.1),
                              shape={"type": "sphere", "radius": 0.1}),
             SpatialPenaltySphereOnPlane("floor", "ball", 0.1, 1e6, restitution=0.5, mu=0.3),
             SpatialPenaltySphereOnPlane("floor2", "ball2", 0.1, 1e6, restitution=0.5, mu=0.3),
             SpatialPenaltySpherePair("pair", "ball", "ball2", 0.1, 0.1, 1e6, restitution=0.5, mu=0.3),
             SpatialRigidBody("ramp", 5.0, (0.1, 0.1, 0.1), position=(-0.5, 0.0, 0.2), rotation=(0.9950042, 0.0, 0.0998334, 0.0),
                              shape={"type": "box", "size": (0.4, 0.3, 0.02)}),
             SpatialRigidBody("ball3", 1.0, (0.004, 0.004, 0.004), position=(-0.5, 0.0, 0.45),
                              shape={"type": "sphere", "radius": 0.1}),
             FixedJoint("weld", "ground", "ramp", at=(-0.5, 0.0, 0.2)),
             # ε_v and h: this ball's slip stops during its impact on the ramp, where the viscous branch of the
             # friction law is stiffest (h μ f_N/(m ε_v) with the impact force; docs/contact.md §9.5)
             SpatialPenaltySphereOnBodyPlane("on_ramp", "ramp", "ball3", 0.1, 1e6, plane_point=(0.0, 0.0, 0.01),
                                             restitution=0.5, mu=0.3, eps_v=0.05),
             SpatialGravity((0.0, 0.0, -9.81)))
    return mech


def planar_penalty_contact():
    import femb
    from femb.elements import Gravity, PenaltySphereOnPlane, RigidBody

    mech = femb.Mechanism("penalty_disc")
    mech.add(RigidBody("ball", 1.0, 0.004, (0.0, 0.3), velocity=(0.5, 0.0), omega=20.0,
                       shape={"type": "disc", "radius": 0.1}),
             PenaltySphereOnPlane("floor", "ball", 0.1, 1e6, restitution=0.5, mu=0.3),
             Gravity((0.0, -9.81)))
    return mech


@dataclass
class Entry:
    key: str
    title: str
    classes: tuple          # fully qualified names documented by the entry
    build: object
    text: str
    t_end: float = 0.3
    h: float = 1e-2
    run: str = "simulate"   # "simulate" (femb.simulate), "contact" (femb.contact.simulate), "initial" (no run)


ENTRIES = [
    Entry("rigid_body", "Rigid bodies", ("femb.elements.bodies.RigidBody",), rigid_body,
          "Planar rigid bodies (node at the centre of mass, coordinates x, y, θ) drawn with the four "
          "drawing shapes: bar, box, disc and polygon; flying freely."),
    Entry("point_mass", "Point masses", ("femb.elements.bodies.PointMass",), point_mass,
          "Point masses (x, y only) thrown under gravity."),
    Entry("ground", "Ground and its named points", ("femb.elements.bodies.Ground",), ground,
          "The ground (``mech.ground``) is the fixed frame; named ground points (drawn as dots) "
          "locate joints and spring ends. Here a bar turns about P0."),
    Entry("hinge", "Hinge (revolute joint)", ("femb.elements.joints.Hinge",), hinge,
          "A double pendulum: two hinges, one to the ground and one between the bars."),
    Entry("slider", "Slider (prismatic joint)", ("femb.elements.joints.Slider",), slider,
          "A block sliding along a turning arm: it keeps the arm's orientation and moves outwards."),
    Entry("point_on_line", "Point on a line", ("femb.elements.joints.PointOnLine",), point_on_line,
          "A point mass sliding down a frictionless incline under gravity."),
    Entry("driven_angle", "Driven angle (rheonomic)", ("femb.elements.joints.DrivenAngle",), driven_angle,
          "A crank turned at 3 rad/s by a driven relative angle together with its hinge."),
    Entry("driven_displacement", "Driven displacement (rheonomic)", ("femb.elements.joints.DrivenDisplacement",),
          driven_displacement, "A block on a slider moved harmonically by a driven displacement."),
    Entry("spring_damper", "Spring–damper", ("femb.elements.forces.SpringDamper",), spring_damper,
          "A mass hanging from a ground point on a linear spring–damper."),
    Entry("rotational_spring_damper", "Rotational spring–damper",
          ("femb.elements.forces.RotationalSpringDamper",), rotational_spring_damper,
          "A hinged bar held by a torsional spring–damper to the ground."),
    Entry("force", "Applied forces", ("femb.elements.forces.Force",), force,
          "A hinged bar with a force at its tip (inertial components) and a follower force that turns "
          "with the bar (``frame=\"body\"``)."),
    Entry("torque", "Applied torque", ("femb.elements.forces.Torque",), torque,
          "A wheel on an axle spun up by a constant torque."),
    Entry("gravity", "Gravity", ("femb.elements.forces.Gravity",), gravity,
          "Uniform gravity on every mass: the pendulum of the README."),
    Entry("beam", "Geometrically exact beam", ("femb.elements.beam.ReissnerBeam", "femb.elements.beam.BeamNode",
                                               "femb.elements.beam.Section"), beam,
          "A steel cantilever meshed by ``add_beam`` into eight Reissner beam elements between massless "
          "beam nodes, clamped to the ground and sagging under gravity.", t_end=0.05, h=1e-3),
    Entry("clamp", "Clamp (rigid connection)", ("femb.elements.beam.Clamp",), clamp,
          "Two bars welded into an L by a clamp, swinging on a hinge under gravity."),
    Entry("spatial_bodies", "Spatial rigid bodies and point masses",
          ("femb.elements.spatial_bodies.SpatialRigidBody", "femb.elements.spatial_bodies.SpatialPointMass",
           "femb.elements.spatial_bodies.SpatialBody", "femb.elements.spatial_bodies.FrameNode",
           "femb.elements.spatial_forces.SpatialGravity"), spatial_bodies,
          "Spatial rigid bodies (a frame node at the centre of mass: position and unit quaternion) drawn "
          "with the drawing shapes box, cylinder and sphere, and as the hull of their named points; a point "
          "mass (a ball); all thrown spinning under uniform gravity. Each body has its colour and its name "
          "in the legend; the faint floor is normal to gravity.", t_end=0.5, h=2e-3),
    Entry("spatial_pendulum", "Revolute and spherical joints; ground points",
          ("femb.elements.spatial_joints.RevoluteJoint", "femb.elements.spatial_joints.SphericalJoint",
           "femb.elements.spatial_joints.SpatialPairElement", "femb.elements.spatial_bodies.SpatialGround"),
          spatial_pendulum,
          "A bar hinged to a named ground point (revolute joint: a short cylinder along its axis; the "
          "ground base sits on the side away from the body) carries a second bar on a ball joint (a "
          "ball). The bars have no drawing shape: each is drawn as a bar through its joint points.", t_end=0.5, h=2e-3),
    Entry("spatial_line_joints", "Prismatic, cylindrical and universal joints",
          ("femb.elements.spatial_joints.PrismaticJoint", "femb.elements.spatial_joints.CylindricalJoint",
           "femb.elements.spatial_joints.UniversalJoint"), spatial_line_joints,
          "A block sliding down a tilted prismatic rail, a spinning sleeve dropping along a cylindrical "
          "post (rails drawn over the whole travel), and an arm hanging from a universal joint (a cross of "
          "its two pins).", t_end=0.5, h=2e-3),
    Entry("spatial_fixed_distance", "Fixed and distance joints",
          ("femb.elements.spatial_joints.FixedJoint", "femb.elements.spatial_joints.DistanceJoint"),
          spatial_fixed_distance,
          "A beam hung from a ground point by a distance joint (a massless link, drawn as a thin rod), "
          "with a post welded to it by a fixed joint (a cube).", t_end=0.5, h=2e-3),
    Entry("spatial_drives", "Driven revolute angle and driven displacement (rheonomic)",
          ("femb.elements.spatial_joints.DrivenRevoluteAngle",
           "femb.elements.spatial_joints.DrivenPrismaticDisplacement"), spatial_drives,
          "A crank turned at 2 rad/s by a driven angle on its revolute joint (a red ring), and a table "
          "lifted harmonically by a driven displacement on its prismatic guide (a red arrow).", t_end=0.5, h=2e-3),
    Entry("spatial_springs", "Spring–dampers, bushings and torsion springs",
          ("femb.elements.spatial_forces.PointSpringDamper", "femb.elements.spatial_forces.Bushing",
           "femb.elements.spatial_forces.RotationalSpringDamper"), spatial_springs,
          "A bob on a coil spring from a ground point, a pad on a six-component bushing (a ring) and a bar "
          "on a revolute joint held by a torsion spring–damper (a ring about the axis).", t_end=0.5, h=2e-3),
    Entry("spatial_loads", "Applied forces and torques",
          ("femb.elements.spatial_forces.SpatialForce", "femb.elements.spatial_forces.SpatialTorque"),
          spatial_loads,
          "A rod on a ball joint pushed at its tip by a follower force and twisted by a follower torque "
          "(red arrows; the torque's arrow has a second head).", t_end=0.5, h=2e-3),
    Entry("spatial_beam", "Spatial geometrically exact beam (SE(3))",
          ("femb.elements.spatial_beam.SpatialBeam", "femb.elements.spatial_beam.SpatialBeamNode",
           "femb.elements.spatial_beam.SpatialSection"), spatial_beam,
          "An L-shaped steel cantilever meshed by ``spatial_beam`` along a polyline (five and three "
          "two-node SE(3) elements of Sonneville, Cardona & Brüls 2014 on frame nodes; the corner is a "
          "rigid elbow), clamped at its start and welded to a tip mass, sagging and twisting under "
          "gravity. Beam nodes are frame nodes: every spatial joint attaches to them.", t_end=0.1, h=1e-3),
    Entry("rolling_disc", "Rolling disc and spin rate (non-holonomic)",
          ("femb.elements.rolling.RollingDisc", "femb.elements.rolling.SpinRate"), rolling_disc,
          "A coin rolling without slip on the plane z = 0 (one holonomic and two velocity constraints) "
          "and a spin-rate drive between a frame and the coin. Velocity constraints are for "
          ":func:`femb.analysis.linearize.linearize` (the Whipple bicycle); the time loop refuses them, so the "
          "picture shows the initial configuration.", run="initial"),
    Entry("planar_rolling", "Planar wheel and knife edge (non-holonomic)",
          ("femb.elements.rolling.PlanarWheel", "femb.elements.rolling.KnifeEdge"), planar_rolling,
          "A wheel rolling without slip on the line y = 0 and a sled on a knife edge (no velocity "
          "across the blade): planar velocity constraints, for linearization; initial configuration.",
          run="initial"),
    Entry("planar_contact", "Contact in the plane: sphere on plane, disc on disc, pin in hole",
          ("femb.elements.contact.SphereOnPlane", "femb.elements.contact.DiscOnDisc",
           "femb.elements.contact.PinInHole", "femb.elements.contact.ContactElement"), planar_contact,
          "Unilateral contact with restitution and Coulomb friction, integrated by "
          ":func:`femb.contact.simulate` (nonsmooth generalized-α): a ball bouncing on the floor, a puck "
          "falling on it (disc on disc) and a bar hanging from a ground pin through a hole with "
          "clearance (pin in hole).", t_end=0.4, h=2e-3, run="contact"),
    Entry("spatial_contact", "Contact in space: sphere on plane, sphere on sphere",
          ("femb.elements.contact.SpatialSphereOnPlane", "femb.elements.contact.SpatialSpherePair"), spatial_contact,
          "A spinning ball thrown onto the floor: impacts with restitution, sliding and rolling with "
          "Coulomb friction; a second ball dropped off-centre on a sphere fixed in space (a sphere pair "
          "with the ground) bounces on it, rolls and starts to slide off it. Integrated by "
          ":func:`femb.contact.simulate`.",
          t_end=0.5, h=2e-3, run="contact"),
    Entry("body_plane_contact", "Contact on a body's plane in the plane: a ball on a seesaw",
          ("femb.elements.contact.SphereOnBodyPlane",), body_plane_contact,
          "A ball dropped on a board that turns on a pivot: the contact line is fixed to the board and moves "
          "and turns with it; the impact and the friction act on the ball and, opposite, on the board at the "
          "contact point. Integrated by :func:`femb.contact.simulate`.", t_end=0.4, h=2e-3, run="contact"),
    Entry("spatial_body_plane_contact", "Contact on a body's plane in space: a ball on a tilting table",
          ("femb.elements.contact.SpatialSphereOnBodyPlane",), spatial_body_plane_contact,
          "A spinning ball dropped on a table that tilts about an axle: the contact plane and its friction "
          "directions are fixed to the table. Integrated by :func:`femb.contact.simulate`.",
          t_end=0.4, h=2e-3, run="contact"),
    Entry("spatial_pin_bushing", "Spatial pin in a bushing (revolute joint with clearance)",
          ("femb.elements.contact.SpatialPinInBushing",), spatial_pin_bushing,
          "A spinning shaft in a bushing fixed in space, with radial clearance: ``pin_bushing`` puts one "
          "contact at each end of the bushing; the shaft drops onto the hole's wall, bounces and slides "
          "along and around it with Coulomb friction. Integrated by :func:`femb.contact.simulate`.",
          t_end=0.3, h=1e-3, run="contact"),
    Entry("planar_penalty_contact", "Penalty (compliant) contact in the plane",
          ("femb.elements.penalty_contact.PenaltySphereOnPlane",), planar_penalty_contact,
          "A spinning disc dropped on a compliant floor: Hertz stiffness with Hunt–Crossley damping and "
          "regularized Coulomb friction, a force element of the compiled engine (:func:`femb.simulate`).",
          t_end=0.4, h=1e-3),
    Entry("penalty_contact", "Penalty (compliant) contact in space: sphere on plane, on sphere, on a body's plane",
          ("femb.elements.penalty_contact.SpatialPenaltySphereOnPlane",
           "femb.elements.penalty_contact.SpatialPenaltySpherePair",
           "femb.elements.penalty_contact.SpatialPenaltySphereOnBodyPlane"), penalty_contact,
          "A spinning ball dropped on a compliant floor rolls into a second ball, and a third ball lands "
          "on a tilted ramp welded to the ground (a plane fixed to a body): Hertz stiffness, "
          "Hunt–Crossley damping and regularized Coulomb friction, integrated by :func:`femb.simulate`.",
          t_end=0.5, h=5e-4),
]


# ---------------------------------------------------------------------------
# generation
# ---------------------------------------------------------------------------
def element_types():
    """Fully qualified names of the element types (and bodies) that femb.elements and its spatial modules export."""
    import inspect as _inspect

    import femb.elements as el
    import femb.elements.contact as ct
    import femb.elements.penalty_contact as pc
    import femb.elements.rolling as rl
    import femb.elements.spatial_beam as sbm
    import femb.elements.spatial_bodies as sb
    import femb.elements.spatial_forces as sf
    import femb.elements.spatial_joints as sj
    from femb.elements.bodies import Body
    from femb.system.element import Element

    out = set()
    for mod in (el, sb, sj, sf, sbm, rl, ct, pc):
        public = getattr(mod, "__all__", None) or [n for n, o in vars(mod).items() if not n.startswith("_")
                                                    and _inspect.isclass(o) and o.__module__ == mod.__name__]
        for name in public:
            obj = getattr(mod, name)
            if isinstance(obj, type) and (issubclass(obj, (Element, Body)) or obj in (sb.FrameNode, sb.SpatialBody)) \
                    and obj is not Body:
                out.add(f"{obj.__module__}.{obj.__qualname__}")
    return out


def render_entry(entry, png):
    """Simulate the entry's mechanism and render its last frame to ``png``."""
    import femb
    import femb.contact
    from femb.io.render import render_png

    model = entry.build().compile()
    with tempfile.TemporaryDirectory() as tmp:
        if entry.run == "initial":
            pvd = _initial_frame(model, Path(tmp) / "vtk")
        else:
            run = femb.contact.simulate if entry.run == "contact" else femb.simulate
            pvd = run(model, t_end=entry.t_end, h=entry.h, rho_inf=0.8).write_vtk(Path(tmp) / "vtk")
        render_png(pvd, png, window_size=PICTURE_SIZE)


def _initial_frame(model, directory):
    """A one-frame time series of the model's initial state (for elements the time loop refuses)."""
    import numpy as np

    from femb.io.frames import model_blocks, scene_field_data
    from femb.io.vtk import TimeSeriesWriter

    with TimeSeriesWriter(directory) as w:
        blocks = model_blocks(model, 0.0, model.q0, model.qd0, np.zeros(model.nc))
        w.write(0.0, blocks, field_data=scene_field_data(model, blocks))
    return w.path


def _is_spatial(entry):
    return any(".spatial_" in c or "Spatial" in c or c.endswith(("RollingDisc", "SpinRate")) for c in entry.classes)


def _rst(entry, png_rel):
    src = textwrap.dedent(inspect.getsource(entry.build))
    refs = ", ".join(f":class:`~{c}`" for c in entry.classes)
    lines = [entry.title, "-" * len(entry.title), "", entry.text, "", f"Reference: {refs}.", "",
             f".. image:: {png_rel}", f"   :alt: {entry.title}, rendered by femb", "", ".. code-block:: python", ""]
    lines += ["   " + ln if ln.strip() else "" for ln in src.rstrip().splitlines()]
    how = "a 3-D mechanism" if _is_spatial(entry) else "a planar mechanism"
    when = ("its initial configuration" if entry.run == "initial"
            else f"t = {entry.t_end:g} s (h = {entry.h:g} s)")
    files = sorted({f"``elements/{c.split('.')[2]}.py``" for c in entry.classes})
    lines += ["", f"Rendered at {when} with :func:`femb.io.render.render_png`: {how}, each body in its "
              f"colour with its name in the legend. Source: {', '.join(files)}.", ""]
    return "\n".join(lines)


def generate(srcdir):
    from femb.io.render import can_render

    ok, reason = can_render()
    if not ok:
        raise ExtensionError(f"femb_catalogue: no off-screen rendering on this machine ({reason})")
    out = Path(srcdir) / "_generated"
    pics = out / "catalogue"
    if pics.exists():
        shutil.rmtree(pics)
    pics.mkdir(parents=True)
    covered = set()
    parts = []
    t0 = time.perf_counter()
    for entry in ENTRIES:
        png = pics / f"{entry.key}.png"
        try:
            render_entry(entry, png)
        except Exception as exc:
            raise ExtensionError(f"femb_catalogue: entry '{entry.key}' failed: {type(exc).__name__}: {exc}") from exc
        covered.update(entry.classes)
        parts.append(_rst(entry, f"/_generated/catalogue/{png.name}"))
    missing = sorted(element_types() - covered)
    if missing:
        logger.warning("femb_catalogue: element types without a catalogue entry: %s "
                       "(add a mechanism to docs/_ext/femb_catalogue.py)", ", ".join(missing))
    (out / "catalogue.inc").write_text("\n".join(parts), encoding="utf-8")
    logger.info("femb_catalogue: %d pictures in %.1f s", len(ENTRIES), time.perf_counter() - t0)


def _on_builder_inited(app):
    generate(app.srcdir)


def setup(app):
    app.connect("builder-inited", _on_builder_inited)
    return {"version": "1.0", "parallel_read_safe": True, "parallel_write_safe": True}

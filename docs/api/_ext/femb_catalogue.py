"""Sphinx extension: the element catalogue, pictured by femb itself.

For every element type of :mod:`femb.elements` a tiny mechanism (a builder
function below) is compiled, simulated for a moment with
:func:`femb.simulate`, written as a VTK time series and rendered off-screen
with :func:`femb.io.render.render_png`. The pictures and the catalogue text
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
    arm = mech.add(RigidBody("arm", 1.0, 0.02, (0.15, 0.0), points={"O": (-0.15, 0.0)}, omega=1.0))
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
    from femb.elements import DrivenAngle, Hinge, RigidBody
    from femb.functions import Linear

    mech = femb.Mechanism("motor")
    crank = mech.add(RigidBody("crank", 1.0, 0.01, (0.15, 0.0), points={"O": (-0.15, 0.0)},
                               shape={"type": "bar", "width": 0.03}))
    mech.add(Hinge("O", "ground", crank, point_b="O"),
             DrivenAngle("motor", "ground", crank, Linear(3.0)))      # φ(t) = 3 t rad
    return mech


def driven_displacement():
    import femb
    from femb.elements import DrivenDisplacement, RigidBody, Slider
    from femb.functions import Harmonic

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


def spatial_bodies():
    import femb
    from femb.elements import SpatialGravity, SpatialPointMass, SpatialRigidBody

    mech = femb.Mechanism("spatial_bodies")
    mech.add(SpatialRigidBody("box", 2.0, (0.02, 0.03, 0.04), position=(0.0, 0.0, 0.5), velocity=(0.5, 0.0, 1.0),
                              omega=(3.0, 0.5, 1.0), shape={"type": "box", "size": (0.3, 0.2, 0.1)}))
    mech.add(SpatialPointMass("ball", 0.5, position=(0.5, 0.0, 0.5), velocity=(0.0, 0.5, 1.5),
                              shape={"type": "sphere", "radius": 0.04}))
    mech.add(SpatialGravity((0.0, 0.0, -9.81)))
    return mech


def spatial_joints():
    import femb
    from femb.elements import (CylindricalJoint, DistanceJoint, FixedJoint, PrismaticJoint, RevoluteJoint,
                               SpatialGravity, SpatialRigidBody, SphericalJoint, UniversalJoint)

    def link(name, x, z=-0.2, velocity=(0.0, 0.0, 0.0), omega=(0.0, 0.0, 0.0)):
        return SpatialRigidBody(name, 1.0, (0.004, 0.004, 0.002), position=(x, 0.0, z), velocity=velocity, omega=omega,
                                points={"top": (0.0, 0.0, 0.2)}, shape={"type": "box", "size": (0.05, 0.05, 0.4)})

    mech = femb.Mechanism("spatial_joints")
    s = mech.add(link("s", 0.0, velocity=(-0.2, 0.4, 0.0), omega=(2.0, 1.0, 0.0)))   # top at rest
    r, u, f = (mech.add(link(n, x)) for n, x in (("r", 0.5), ("u", 1.0), ("f", 1.5)))
    mech.add(SphericalJoint("ball", "ground", s, point_b="top"),
             RevoluteJoint("hinge", "ground", r, at=(0.5, 0.0, 0.0), axis=(1.0, 0.0, 0.0)),
             UniversalJoint("cardan", "ground", u, axis_a=(1.0, 0.0, 0.0), axis_b=(0.0, 1.0, 0.0), at=(1.0, 0.0, 0.0)),
             RevoluteJoint("f_hinge", "ground", f, at=(1.5, 0.0, 0.0), axis=(0.0, 1.0, 0.0)))
    g = mech.add(link("g", 1.5, -0.6))
    mech.add(FixedJoint("weld", f, g, at=(1.5, 0.0, -0.4)))
    c = mech.add(link("c", 2.0))
    mech.add(CylindricalJoint("sleeve", "ground", c, at=(2.0, 0.0, 0.0), axis=(1.0, 0.0, 1.0)))
    p = mech.add(link("p", 2.5))
    mech.add(PrismaticJoint("rail", "ground", p, at=(2.5, 0.0, 0.0), axis=(0.0, 1.0, 1.0)))
    d = mech.add(link("d", 3.0))
    mech.add(DistanceJoint("rod", "ground", d, point_a=(3.2, 0.0, 0.0), point_b="top"),
             SphericalJoint("d_ball", "ground", d, at=(3.0, 0.0, -0.4)))
    mech.add(SpatialGravity((0.0, 1.0, -9.81)))
    return mech


def spatial_drivers():
    import femb
    from femb.elements import (DrivenPrismaticDisplacement, DrivenRevoluteAngle, PrismaticJoint, RevoluteJoint,
                               SpatialRigidBody)
    from femb.functions import Harmonic, Linear

    mech = femb.Mechanism("spatial_drivers")
    crank = mech.add(SpatialRigidBody("crank", 1.0, (0.001, 0.01, 0.01), position=(0.15, 0.0, 0.0),
                                      shape={"type": "box", "size": (0.3, 0.04, 0.02)}))
    mech.add(RevoluteJoint("axle", "ground", crank, at=(0.0, 0.0, 0.0), axis=(0.0, 0.0, 1.0)),
             DrivenRevoluteAngle("motor", "ground", crank, Linear(3.0), at=(0.0, 0.0, 0.0), axis=(0.0, 0.0, 1.0)))
    block = mech.add(SpatialRigidBody("block", 1.0, (0.001, 0.001, 0.001), position=(0.6, 0.0, 0.0),
                                      shape={"type": "box", "size": (0.1, 0.1, 0.1)}))
    mech.add(PrismaticJoint("rail", "ground", block, at=(0.6, 0.0, 0.0), axis=(0.0, 1.0, 0.0)),
             DrivenPrismaticDisplacement("actuator", "ground", block, Harmonic(0.1, 10.0), at=(0.6, 0.0, 0.0),
                                         axis=(0.0, 1.0, 0.0)))
    return mech


def spatial_forces():
    import femb
    from femb.elements import (Bushing, PointSpringDamper, RevoluteJoint, SpatialForce, SpatialGravity,
                               SpatialRigidBody, SpatialRotationalSpringDamper, SpatialTorque)

    mech = femb.Mechanism("spatial_forces")
    bob = mech.add(SpatialRigidBody("bob", 1.0, (0.002, 0.002, 0.002), position=(0.0, 0.0, -0.4),
                                    points={"A": (0.0, 0.0, 0.05)}, shape={"type": "sphere", "radius": 0.05}))
    mech.add(PointSpringDamper("spring", "ground", bob, 200.0, 1.0, length=0.3, point_a=(0.0, 0.0, 0.0),
                               point_b="A"))
    plate = mech.add(SpatialRigidBody("plate", 2.0, (0.01, 0.02, 0.03), position=(0.6, 0.0, 0.0),
                                      shape={"type": "box", "size": (0.3, 0.2, 0.03)}))
    mech.add(Bushing("mount", "ground", plate, (2e3, 2e3, 4e3), (50.0, 50.0, 80.0), damping=(5.0, 5.0, 5.0),
                     at=(0.6, 0.0, 0.0)),
             SpatialForce("push", plate, (0.0, 0.0, 20.0), point=(0.15, 0.1, 0.0), follower=True))
    wheel = mech.add(SpatialRigidBody("wheel", 1.0, (0.005, 0.005, 0.01), position=(1.2, 0.0, 0.0),
                                      points={"rim": (0.1, 0.0, 0.0)},
                                      shape={"type": "cylinder", "radius": 0.1, "length": 0.02, "axis": (0.0, 0.0, 1.0)}))
    mech.add(RevoluteJoint("axle", "ground", wheel, at=(1.2, 0.0, 0.0), axis=(0.0, 0.0, 1.0)),
             SpatialRotationalSpringDamper("torsion", "ground", wheel, 2.0, 0.05, at=(1.2, 0.0, 0.0),
                                           axis=(0.0, 0.0, 1.0)),
             SpatialTorque("motor", wheel, (0.0, 0.0, 1.0)), SpatialGravity((0.0, 0.0, -9.81)))
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
          ("femb.elements.spatial_bodies.SpatialRigidBody", "femb.elements.spatial_bodies.SpatialPointMass"),
          spatial_bodies, "A box tumbling through the air (quaternion frame node at its centre of mass) and a "
          "point mass (rotation fixed) thrown under spatial gravity.", t_end=0.3, h=1e-3),
    Entry("spatial_joints", "Spatial joints",
          tuple(f"femb.elements.spatial_joints.{c}" for c in ("SphericalJoint", "RevoluteJoint", "UniversalJoint",
                                                              "FixedJoint", "CylindricalJoint", "PrismaticJoint",
                                                              "DistanceJoint")), spatial_joints,
          "Links hanging from the ground on a spherical joint, a revolute joint, a universal joint, a revolute "
          "joint with a second link welded to the first (fixed joint), a cylindrical joint and a prismatic "
          "joint on inclined axes, and a link held by a spherical joint and a distance joint; gravity "
          "tilted towards y.", t_end=0.3, h=1e-3),
    Entry("spatial_drivers", "Spatial drivers (rheonomic)",
          ("femb.elements.spatial_joints.DrivenRevoluteAngle", "femb.elements.spatial_joints.DrivenPrismaticDisplacement"),
          spatial_drivers, "A crank turned at 3 rad/s by a driven revolute angle with its revolute joint, and a "
          "block moved harmonically along a prismatic joint by a driven displacement.", t_end=0.3, h=1e-3),
    Entry("spatial_forces", "Spatial forces",
          tuple(f"femb.elements.spatial_forces.{c}" for c in ("PointSpringDamper", "Bushing", "RotationalSpringDamper",
                                                              "SpatialForce", "SpatialTorque", "SpatialGravity")),
          spatial_forces, "A ball on a point spring–damper, a plate on a six-component bushing pushed by a "
          "follower force, and a wheel on a revolute joint driven by a torque against a torsion "
          "spring–damper, under spatial gravity.", t_end=0.3, h=1e-3),
]


# ---------------------------------------------------------------------------
# generation
# ---------------------------------------------------------------------------
def element_types():
    """Fully qualified names of the element types (and bodies) that femb.elements exports."""
    import femb.elements as el
    from femb.element import Element
    from femb.elements.bodies import Body

    out = set()
    for name in el.__all__:
        obj = getattr(el, name)
        if isinstance(obj, type) and issubclass(obj, (Element, Body)) and obj is not Body:
            out.add(f"{obj.__module__}.{obj.__qualname__}")
    return out


def render_entry(entry, png):
    """Simulate the entry's mechanism and render its last frame to ``png``."""
    import femb
    from femb.io.render import render_png

    model = entry.build().compile()
    res = femb.simulate(model, t_end=entry.t_end, h=entry.h, rho_inf=0.8)
    with tempfile.TemporaryDirectory() as tmp:
        pvd = res.write_vtk(Path(tmp) / "vtk")
        render_png(pvd, png, window_size=PICTURE_SIZE)


def _rst(entry, png_rel):
    src = textwrap.dedent(inspect.getsource(entry.build))
    refs = ", ".join(f":class:`~{c}`" for c in entry.classes)
    lines = [entry.title, "-" * len(entry.title), "", entry.text, "", f"Reference: {refs}.", "",
             f".. image:: {png_rel}", f"   :alt: {entry.title}, rendered by femb", "", ".. code-block:: python", ""]
    lines += ["   " + ln if ln.strip() else "" for ln in src.rstrip().splitlines()]
    lines += ["", f"Rendered at t = {entry.t_end:g} s (h = {entry.h:g} s) with "
              ":func:`femb.io.render.render_png`, colours by element type.", ""]
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
                       "(add a mechanism to docs/api/_ext/femb_catalogue.py)", ", ".join(missing))
    (out / "catalogue.inc").write_text("\n".join(parts), encoding="utf-8")
    logger.info("femb_catalogue: %d pictures in %.1f s", len(ENTRIES), time.perf_counter() - t0)


def _on_builder_inited(app):
    generate(app.srcdir)


def setup(app):
    app.connect("builder-inited", _on_builder_inited)
    return {"version": "1.0", "parallel_read_safe": True, "parallel_write_safe": True}

"""Bad input to the beam meshers and sections is a ModelError naming the parameter and the value
(never a raw traceback, a hang, a machine out of memory, or a silently changed input); the spatial
mesher's frames must follow the centre line; initial velocities of beams and bodies from a rigid
velocity field (femb.system.motion)."""
import math
import time

import numpy as np
import pytest

from femb import Mechanism, ModelError
from femb.elements import RigidBody
from femb.elements.beam import Section, add_beam
from femb.elements.spatial_beam import SpatialSection, spatial_beam
from femb.elements.spatial_bodies import SpatialRigidBody
from femb.system.motion import set_rigid_velocity


def S():
    return SpatialSection.circle(2e11, 8e10, 0.01, 7800)


def PS():
    return Section.rectangle(2e11, 8e10, 0.01, 0.01, 7800)


LINE = [[0, 0, 0], [1, 0, 0]]
ELBOW = [[0, 0, 0], [1, 0, 0], [1, 1, 0]]


def curve(s):
    return (s, 0.0, 0.0)


def rotz(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


# (call, words the message must contain)
BAD = {
    "circle G=0": (lambda: SpatialSection.circle(2e11, 0.0, 0.01), ["G", "0"]),
    "circle E=0": (lambda: SpatialSection.circle(0.0, 8e10, 0.01), ["E must be positive", "0"]),
    "circle E='a'": (lambda: SpatialSection.circle("a", 8e10, 0.01), ["E", "'a'"]),
    "circle k=0": (lambda: SpatialSection.circle(2e11, 8e10, 0.01, shear_factor=0), ["shear_factor", "0"]),
    "circle k='x'": (lambda: SpatialSection.circle(2e11, 8e10, 0.01, shear_factor="x"), ["shear_factor", "'x'"]),
    "rect G<0": (lambda: SpatialSection.rectangle(2e11, -1.0, 0.01, 0.01), ["G", "-1.0"]),
    "rect k<0": (lambda: SpatialSection.rectangle(2e11, 8e10, 0.01, 0.01, shear_factor=-0.5), ["shear_factor"]),
    "tube G=0": (lambda: SpatialSection.tube(2e11, 0, 0.02, 0.01), ["G", "0"]),
    "tube inner 'a'": (lambda: SpatialSection.tube(2e11, 8e10, 0.02, "a"), ["inner_diameter", "'a'"]),
    "from_properties GJ=-1": (lambda: SpatialSection.from_properties(1, 1, 1, -1, 1, 1), ["GJ", "-1"]),
    "from_properties 'a'": (lambda: SpatialSection.from_properties("a", 1, 1, 1, 1, 1), ["EA", "'a'"]),
    "C negative diagonal": (lambda: SpatialSection(np.diag([1, 1, 1, 1, -2.0, 1])), ["EI2 = -2"]),
    "C string": (lambda: SpatialSection("abc"), ["C", "'abc'"]),
    "rhoJ string": (lambda: SpatialSection(np.eye(6), 1.0, "x"), ["rhoJ", "'x'"]),
    "n_elements nan": (lambda: spatial_beam(Mechanism(), "b", S(), LINE, float("nan")), ["n_elements", "nan"]),
    "n_elements 2.7": (lambda: spatial_beam(Mechanism(), "b", S(), LINE, 2.7), ["n_elements", "2.7"]),
    "curve n_elements 2.7": (lambda: spatial_beam(Mechanism(), "b", S(), curve, 2.7), ["n_elements", "2.7"]),
    "n_elements inf": (lambda: spatial_beam(Mechanism(), "b", S(), curve, float("inf")), ["n_elements", "inf"]),
    "n_elements 'a'": (lambda: spatial_beam(Mechanism(), "b", S(), LINE, "a"), ["n_elements", "'a'"]),
    "counts 2.5": (lambda: spatial_beam(Mechanism(), "b", S(), ELBOW, [2, 2.5]), ["n_elements[1]", "2.5"]),
    "path two coordinates": (lambda: spatial_beam(Mechanism(), "b", S(), lambda s: (s, 0.0), 4),
                             ["three coordinates", "path(0)"]),
    "path raises": (lambda: spatial_beam(Mechanism(), "b", S(), lambda s: 1 / 0, 4), ["path(0)", "ZeroDivision"]),
    "polyline string": (lambda: spatial_beam(Mechanism(), "b", S(), "abc", 4), ["path", "'abc'"]),
    "normal zero": (lambda: spatial_beam(Mechanism(), "b", S(), LINE, 4, normal=(0, 0, 0)), ["normal", "zero"]),
    "normal two numbers": (lambda: spatial_beam(Mechanism(), "b", S(), LINE, 4, normal=(0, 1)), ["normal"]),
    "normal 'up'": (lambda: spatial_beam(Mechanism(), "b", S(), LINE, 4, normal="up"), ["normal", "'up'"]),
    "frames on a polyline": (lambda: spatial_beam(Mechanism(), "b", S(), LINE, 4, frames=lambda s: np.eye(3)),
                             ["frames", "curve"]),
    "planar section": (lambda: spatial_beam(Mechanism(), "b", PS(), LINE, 4), ["section", "Section"]),
    "start 3": (lambda: spatial_beam(Mechanism(), "b", S(), LINE, 4, start=3), ["start", "3"]),
    "mech None": (lambda: spatial_beam(None, "b", S(), LINE, 4), ["mech", "None"]),
    "velocity shape": (lambda: spatial_beam(Mechanism(), "b", S(), LINE, 4, velocity=np.zeros((3, 3))),
                       ["velocity", "(3, 3)"]),
    "clamped node spinning": (lambda: spatial_beam(Mechanism(), "b", S(), LINE, 4, start="clamp", omega=(0, 0, 1)),
                              ["clamped", "node 0"]),
    "planar n 2.7": (lambda: add_beam(Mechanism(), "b", PS(), (0, 0), (1, 0), 2.7), ["n_elements", "2.7"]),
    "planar n nan": (lambda: add_beam(Mechanism(), "b", PS(), (0, 0), (1, 0), float("nan")), ["n_elements", "nan"]),
    "planar sweep 'a'": (lambda: add_beam(Mechanism(), "b", PS(), (0, 0), (1, 0), 4, sweep="a"), ["sweep", "'a'"]),
    "planar velocities shape": (lambda: add_beam(Mechanism(), "b", PS(), (0, 0), (1, 0), 4,
                                                 velocities=np.zeros((3, 3))), ["velocities", "(5, 3)"]),
    "planar velocities callable raises": (lambda: add_beam(Mechanism(), "b", PS(), (0, 0), (1, 0), 4,
                                                           velocities=lambda xy, th: 1 / 0),
                                          ["velocities", "ZeroDivision"]),
    "Section width 'a'": (lambda: Section.rectangle(2e11, 8e10, "a", 0.01, 7800), ["width", "'a'"]),
    "Section diameter -1": (lambda: Section.circle(2e11, 8e10, -1, 7800), ["diameter", "-1"]),
    "Section negative width and height": (lambda: Section.rectangle(2e11, 8e10, -0.01, -0.01, 7800),
                                          ["width", "-0.01"]),
}


@pytest.mark.parametrize("case", list(BAD))
def test_bad_input_is_a_model_error_naming_the_parameter_and_value(case):
    call, words = BAD[case]
    with pytest.raises(ModelError) as ei:
        call()
    for w in words:
        assert w in str(ei.value), str(ei.value)


@pytest.mark.parametrize("which", ["curve", "polyline", "planar"])
def test_a_mesh_too_large_for_memory_is_refused_at_once_with_the_memory_it_would_need(which):
    t0 = time.perf_counter()
    with pytest.raises(ModelError, match=r"10{9} elements would need at least [0-9.e+]+ GiB .* memory"):
        if which == "curve":
            spatial_beam(Mechanism(), "b", S(), curve, 10 ** 9)
        elif which == "polyline":
            spatial_beam(Mechanism(), "b", S(), LINE, 10 ** 9)
        else:
            add_beam(Mechanism(), "b", PS(), (0, 0), (1, 0), 10 ** 9)
    assert time.perf_counter() - t0 < 5.0          # nothing allocated, no loop over the elements


def test_integral_float_counts_are_accepted_and_nothing_is_added_on_error():
    m = Mechanism()
    assert len(spatial_beam(m, "b", S(), LINE, 4.0).elements) == 4
    assert len(add_beam(m, "p", PS(), (0, 0), (1, 0), np.int64(3)).elements) == 3
    before = len(m.elements)
    with pytest.raises(ModelError):
        spatial_beam(m, "c", PS(), LINE, 4)
    assert len(m.elements) == before


@pytest.mark.parametrize("deg", [10.0, 90.0, 1e-3])
def test_frames_whose_first_axis_is_not_the_tangent_are_refused_naming_the_node_and_angle(deg):
    a = math.radians(deg)
    m = Mechanism()
    with pytest.raises(ModelError) as ei:
        spatial_beam(m, "b", S(), curve, 4, frames=lambda s: rotz(a))
    msg = str(ei.value)
    assert "node 0" in msg and f"{deg:.4g}°" in msg and "tangent" in msg, msg
    # a frame off at one interior node only: that node is named
    with pytest.raises(ModelError, match="node 2"):
        spatial_beam(Mechanism(), "b", S(), curve, 4, frames=lambda s: rotz(a if s == 0.5 else 0.0))


def test_exact_tangent_frames_of_a_helix_are_accepted():
    r, c = 0.5, 0.2

    def path(s):
        t = 4 * math.pi * s
        return (r * math.cos(t), r * math.sin(t), c * t)

    def frames(s):
        t = 4 * math.pi * s
        e1 = np.array([-r * math.sin(t), r * math.cos(t), c]) / math.hypot(r, c)
        e2 = np.array([-math.cos(t), -math.sin(t), 0.0])
        return np.column_stack((e1, e2, np.cross(e1, e2)))

    mesh = spatial_beam(Mechanism(), "h", S(), path, 40, frames=frames)
    assert len(mesh.elements) == 40


def test_a_spinning_free_beam_has_its_angular_velocity_in_node_axes():
    """Rigid field about the beam's midpoint: ṙ = v₀ + ω × (r − p) in space axes, Ω = Rᵀω in node axes."""
    m = Mechanism()
    w = np.array([0.3, -1.2, 2.0])
    v0 = np.array([0.5, 0.0, -0.25])
    p = np.array([0.5, 0.0, 0.0])
    mesh = spatial_beam(m, "b", S(), [[0, 0, 0], [0.5, 0, 0], [0.5, 0.5, 0.5]], 3, velocity=v0, omega=w, about=p)
    for b in mesh.nodes:
        nd = b.node
        R = nd.rotation0
        assert np.allclose(nd.qd0[:3], v0 + np.cross(w, nd.q0[:3] - p), rtol=0, atol=1e-14)
        assert np.allclose(R @ nd.qd0[3:], w, rtol=0, atol=1e-14)
    # the elbow node's axes differ from the first node's: Ω differs, ω = R Ω does not
    assert not np.allclose(mesh.nodes[0].node.qd0[3:], mesh.nodes[-1].node.qd0[3:])
    # per-node values
    V = np.arange(21.0).reshape(7, 3)
    mesh2 = spatial_beam(Mechanism(), "c", S(), LINE, 6, velocity=V, omega=np.tile(w, (7, 1)))
    assert np.allclose([b.node.qd0[:3] for b in mesh2.nodes], V)


def test_set_rigid_velocity_gives_bodies_and_nodes_one_rigid_motion():
    w, v0, p = np.array([0.1, 0.2, 3.0]), np.array([1.0, -2.0, 0.5]), np.array([0.2, 0.1, -0.3])
    m = Mechanism()
    body = m.add(SpatialRigidBody("body", 2.0, (0.1, 0.2, 0.3), position=(1.0, 2.0, 0.5), rotation=rotz(0.7)))
    mesh = spatial_beam(m, "b", S(), LINE, 3)
    nodes = set_rigid_velocity(m, velocity=v0, omega=w, about=p)
    assert len(nodes) == 5
    r = body.node.q0[:3]
    assert np.allclose(body.node.qd0[:3], v0 + np.cross(w, r - p), atol=1e-14)
    assert np.allclose(body.node.qd0[3:], rotz(0.7).T @ w, atol=1e-14)
    for b in mesh.nodes:
        assert np.allclose(b.node.rotation0 @ b.node.qd0[3:], w, atol=1e-14)
    # planar: a rigid body and a beam's nodes
    pm = Mechanism()
    rb = pm.add(RigidBody("rb", 1.0, 0.1, (1.0, 2.0), 0.3))
    beam = add_beam(pm, "p", PS(), (0, 0), (1, 0), 2)
    set_rigid_velocity([rb, beam], velocity=(0.5, -1.0), omega=2.0, about=(0.5, 0.5))
    assert np.allclose(rb.node.qd0, [0.5 - 2.0 * 1.5, -1.0 + 2.0 * 0.5, 2.0])
    assert np.allclose(beam.nodes[1].node.qd0, [0.5 - 2.0 * (0.0 - 0.5), -1.0 + 2.0 * (0.5 - 0.5), 2.0])


def test_set_rigid_velocity_refuses_what_it_cannot_do():
    m = Mechanism()
    mesh = spatial_beam(m, "b", S(), LINE, 2, start="clamp")
    with pytest.raises(ModelError, match="b.n0"):
        set_rigid_velocity(mesh, omega=(0, 0, 1.0))
    assert np.all(mesh.nodes[1].node.qd0 == 0.0)          # nothing set when one node fails
    with pytest.raises(ModelError, match="three|3 finite"):
        set_rigid_velocity(mesh.nodes[1:], velocity=(1.0, 0.0))
    with pytest.raises(ModelError, match="planar and spatial"):
        set_rigid_velocity([mesh.nodes[1], RigidBody("rb", 1.0, 0.1, (0, 0), 0.0)])
    with pytest.raises(ModelError, match="not a body"):
        set_rigid_velocity(42)


def test_velocity_arguments_that_are_not_numbers_are_named():
    # before: a raw ValueError from numpy ("could not convert string to float")
    sec = SpatialSection.circle(2e11, 8e10, 0.01, density=7850.0)
    for kw in (dict(omega="fast"), dict(velocity=[1.0, "a", 0.0]), dict(velocity={"x": 1.0})):
        what = next(iter(kw))
        with pytest.raises(ModelError, match=rf"spatial_beam 'b': {what} must be three finite numbers"):
            spatial_beam(Mechanism("m"), "b", sec, [(0, 0, 0), (1, 0, 0)], 4, **kw)


def test_set_rigid_velocity_of_nothing_is_an_error():
    # before: [] (or an empty mechanism) was accepted and set nothing
    with pytest.raises(ModelError, match="holds no body or node"):
        set_rigid_velocity([], velocity=(1.0, 0.0, 0.0))
    with pytest.raises(ModelError, match="holds no body or node"):
        set_rigid_velocity(Mechanism("empty"), omega=(0.0, 0.0, 1.0))

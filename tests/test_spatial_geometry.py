"""Output geometry of the spatial elements, and the 3-D camera of the renderer.

Each element class is packed with ``cls.pack(elements)`` and its ``geometry``
called directly on synthetic configurations (the model compiler is not needed):
body vertices turn with R(p) exactly, vertex velocities match finite
differences along x ∘ exp(εv), joint reactions follow the table of
docs/spatial.md (and the exact −B_bᵀλ, B by finite differences of Φ), and the
blocks merge into a readable .vtu file.
"""
import math
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from spatial_fd import oplus, random_quat  # noqa: E402

from femb import Mechanism  # noqa: E402
from femb.base import rotations as rt  # noqa: E402
from femb.base.functions import Harmonic, Linear, Polynomial  # noqa: E402
from femb.elements import _spatial_geometry as sg  # noqa: E402
from femb.elements import spatial_forces as sf  # noqa: E402
from femb.elements import spatial_joints as sj  # noqa: E402
from femb.errors import ModelError, OutputError  # noqa: E402
from femb.elements.spatial_bodies import (SpatialPointMass, SpatialRigidBody, box_inertia,  # noqa: E402
                                          spatial_ground)
from femb.io.frames import model_blocks  # noqa: E402
from femb.io.render import _check_view, camera_3d  # noqa: E402
from femb.io.vtk import merge_blocks, read_frame, write_vtu  # noqa: E402


# ---------------------------------------------------------------------------
# helpers
# ---------------------------------------------------------------------------
def _lookup(mech):
    return lambda ref, role: mech[ref] if isinstance(ref, str) else ref


def _ready(mech, *elements):
    """Resolve and validate elements as the model compiler does."""
    for e in elements:
        e.resolve(_lookup(mech))
        e.validate()
    return elements


def _geometry(elements, qe, qde=None, lam=None, t=0.0):
    cls = type(elements[0])
    p = cls.pack(list(elements))
    qe = np.atleast_2d(np.asarray(qe, dtype=float))
    nv = 6 * (qe.shape[1] // 7)
    qde = np.zeros((qe.shape[0], nv)) if qde is None else np.atleast_2d(qde)
    nc = getattr(cls, "n_constraints", 0)
    lam = np.zeros((qe.shape[0], nc)) if lam is None else np.atleast_2d(np.asarray(lam, dtype=float))
    return cls.geometry(p, t, qe, qde, lam, [e.name for e in elements])


def _initial(elements):
    """qe, qde of elements at t0 (their nodes' initial values)."""
    qe = np.array([np.concatenate([n.q0 for n in e.nodes()]) for e in elements])
    qde = np.array([np.concatenate([n.qd0 for n in e.nodes()]) for e in elements])
    return qe, qde


def _R(q):
    return rt.quat_to_matrix(np.ascontiguousarray(q / np.linalg.norm(q)))


def _bodies(rng):
    """Rigid bodies with every kind of drawing (and degenerate point sets)."""
    mass = 2.0
    return [
        SpatialRigidBody("box", mass, box_inertia(mass, 0.4, 0.2, 0.1),
                         shape={"type": "box", "size": (0.4, 0.2, 0.1)}),
        SpatialRigidBody("disc", mass, (0.3, 0.6, 0.3),
                         shape={"type": "cylinder", "radius": 0.25, "length": 0.1, "axis": (0, 1, 0)}),
        SpatialRigidBody("ball", mass, (0.1, 0.1, 0.1), shape={"type": "sphere", "radius": 0.3}),
        SpatialRigidBody("hull", mass, (0.1, 0.2, 0.25),
                         points={k: rng.standard_normal(3) for k in "abcde"}),
        SpatialRigidBody("bare", mass, (0.1, 0.2, 0.25)),
        SpatialRigidBody("flat", mass, (0.1, 0.2, 0.25),
                         points={"a": (1, 0, 0), "b": (0, 1, 0), "c": (1, 1, 0), "d": (0.5, 0.5, 0)}),
        SpatialRigidBody("stick", mass, (0.01, 0.2, 0.2), points={"a": (0.5, 0, 0), "b": (-0.5, 0, 0)}),
        SpatialRigidBody("twin", mass, (0.1, 0.2, 0.25), points={"a": (0, 0, 0), "b": (0, 0, 0)}),
    ]


def _random_states(rng, n):
    qe = np.zeros((n, 7))
    for e in range(n):
        qe[e, 0:3] = rng.standard_normal(3)
        qe[e, 3:7] = random_quat(rng)
    return qe, rng.standard_normal((n, 6))


# ---------------------------------------------------------------------------
# bodies
# ---------------------------------------------------------------------------
def test_rigid_body_vertices_turn_with_the_body():
    rng = np.random.default_rng(1)
    bodies = _bodies(rng)
    p = SpatialRigidBody.pack(bodies)
    qe, qde = _random_states(rng, len(bodies))
    surf, frames = SpatialRigidBody.geometry(p, 0.0, qe, qde, np.zeros((len(bodies), 0)),
                                             [b.name for b in bodies])
    own = p["outline_owner"]
    X = p["outline_local"]
    expected = np.array([qe[k, 0:3] + _R(qe[k, 3:7]) @ x for k, x in zip(own, X)])
    np.testing.assert_allclose(surf.points, expected, rtol=0, atol=1e-14)
    # the frames block: one vertex per body at r, axes = scaled columns of R, omega = RΩ
    np.testing.assert_array_equal(frames.points, qe[:, 0:3])
    for k in range(len(bodies)):
        R = _R(qe[k, 3:7])
        s = p["frame_scale"][k]
        assert s > 0
        for i in range(3):
            np.testing.assert_allclose(frames.point_data[f"e{i + 1}"][k], s * R[:, i], atol=1e-14)
        np.testing.assert_allclose(frames.point_data["omega"][k], R @ qde[k, 3:6], atol=1e-14)
    # every body is drawn, cell data per cell block
    kinds = [c[0] for c in surf.cells]
    assert kinds == ["triangle", "line"]
    drawn = set(np.concatenate([p["outline_triangle_body"], p["outline_line_body"]]))
    assert drawn == set(range(len(bodies)))
    for ids, mass, (_, conn) in zip(surf.cell_data["body_id"], surf.cell_data["mass"], surf.cells):
        assert ids.shape == mass.shape == (len(conn),)
        np.testing.assert_array_equal(mass, 2.0)


def _volume(verts, tri):
    a, b, c = verts[tri[:, 0]], verts[tri[:, 1]], verts[tri[:, 2]]
    return float(np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6.0)


def test_shapes_in_body_axes():
    rng = np.random.default_rng(2)
    bodies = {b.name: b for b in _bodies(rng)}

    def out(name):
        b = bodies[name]
        return sg.outline(b.shape, b.points, b.m, b.J)

    v, t, ln = out("box")
    np.testing.assert_allclose(np.abs(v), np.tile([0.2, 0.1, 0.05], (8, 1)))
    assert len(t) == 12 and len(ln) == 0
    assert _volume(v, t) == pytest.approx(0.4 * 0.2 * 0.1, rel=1e-12)     # closed, outward
    v, t, _ = out("disc")
    np.testing.assert_allclose(np.hypot(v[:, 0], v[:, 2]), 0.25)
    np.testing.assert_allclose(np.abs(v[:, 1]), 0.05)
    assert _volume(v, t) > 0.9 * math.pi * 0.25 ** 2 * 0.1
    v, t, _ = out("ball")
    np.testing.assert_allclose(np.linalg.norm(v, axis=1), 0.3)
    assert 0.8 * 4 / 3 * math.pi * 0.3 ** 3 < _volume(v, t) < 4 / 3 * math.pi * 0.3 ** 3
    v, t, _ = out("hull")
    assert _volume(v, t) > 0
    # no point but the node: the box with the body's mass and principal moments
    v, t, _ = out("bare")
    b = bodies["bare"]
    edges = 2.0 * np.sort(np.linalg.svd(v - v.mean(0), compute_uv=False)) / np.sqrt(8.0)
    np.testing.assert_allclose(np.sort(box_inertia(b.m, *edges)), np.sort(np.diag(b.J)), rtol=1e-12)
    # coplanar points: a flat polygon fan; collinear points: one segment; repeated points: a box
    v, t, ln = out("flat")
    assert len(t) >= 2 and len(ln) == 0 and np.allclose(v[:, 2], 0.0)
    v, t, ln = out("stick")
    assert len(t) == 0 and ln.tolist() == [[0, 1]]
    np.testing.assert_allclose(np.sort(v[:, 0]), [-0.5, 0.5])
    v, t, ln = out("twin")
    assert len(t) == 12


def test_degenerate_point_sets_never_fail():
    for pts in ([], [(0, 0, 0)], [(1, 2, 3)] * 5, [(0, 0, 0), (1e-20, 0, 0)],
                [(0, 0, 0), (1, 0, 0), (2, 0, 0), (3, 0, 1e-13)], [(0, 0, 0), (1, 0, 0), (0, 1, 0)],
                [(0, 0, 0), (1, 0, 0), (0, 1, 0), (1, 1, 1e-12)]):
        v, t, ln = sg.outline(None, np.asarray(pts, dtype=float).reshape(-1, 3))
        assert len(v) >= 2 and (len(t) or len(ln))
        assert np.all(np.isfinite(v))


def test_rigid_body_vertex_velocity_matches_finite_differences():
    rng = np.random.default_rng(3)
    bodies = _bodies(rng)[:4]
    p = SpatialRigidBody.pack(bodies)
    qe, qde = _random_states(rng, len(bodies))
    lam = np.zeros((len(bodies), 0))
    surf = SpatialRigidBody.geometry(p, 0.0, qe, qde, lam, None)[0]
    eps = 1e-6

    def points(x):
        return SpatialRigidBody.geometry(p, 0.0, x, qde, lam, None)[0].points

    fd = (points(oplus(qe, eps * qde)) - points(oplus(qe, -eps * qde))) / (2 * eps)
    np.testing.assert_allclose(surf.point_data["velocity"], fd, rtol=0, atol=1e-8)


def test_point_mass_vertex():
    pm = SpatialPointMass("pm", 0.5, position=(1.0, 2.0, 3.0), velocity=(0.1, 0.2, 0.3))
    qe, qde = _initial([pm])
    (blk,) = _geometry([pm], qe, qde)
    np.testing.assert_array_equal(blk.points, [[1.0, 2.0, 3.0]])
    np.testing.assert_array_equal(blk.point_data["velocity"], [[0.1, 0.2, 0.3]])
    assert blk.cells[0][0] == "vertex" and blk.cell_data["mass"][0].tolist() == [0.5]


@pytest.mark.parametrize("shape, words", [
    ({"type": "bar", "width": 0.1}, "unknown spatial shape type 'bar'"),
    ({"type": "box", "size": (1, 2)}, "three edge lengths"),
    ({"type": "cylinder", "radius": -1, "length": 1}, "radius must be positive"),
    ({"type": "cylinder", "radius": 1, "length": 1, "axis": (0, 0, 0)}, "non-zero 3-vector"),
    ({"type": "sphere"}, "needs 'radius'"),
    ("box", "must be a dict"),
])
def test_shape_errors_name_the_body(shape, words):
    with pytest.raises(ModelError, match="SpatialRigidBody 'crank'") as exc:
        SpatialRigidBody("crank", 1.0, (1, 1, 1), shape=shape)
    assert words in str(exc.value)


# ---------------------------------------------------------------------------
# joints
# ---------------------------------------------------------------------------
def _two_bodies(rng, mech):
    a = mech.add(SpatialRigidBody("A", 1.0, (1.0, 2.0, 2.5), position=rng.standard_normal(3),
                                  rotation=random_quat(rng)))
    b = mech.add(SpatialRigidBody("B", 2.0, (1.0, 1.5, 2.0), position=rng.standard_normal(3),
                                  rotation=random_quat(rng)))
    return a, b


def test_spherical_joint_reaction_is_lambda_with_no_moment():
    rng = np.random.default_rng(4)
    mech = Mechanism("sph")
    a, b = _two_bodies(rng, mech)
    at = rng.standard_normal(3)
    (j,) = _ready(mech, sj.SphericalJoint("ball", a, b, at=at))
    lam = np.array([[3.0, -2.0, 5.0]])
    qe, qde = _initial([j])
    vert, line = _geometry([j], qe, qde, lam)
    np.testing.assert_allclose(vert.points, [at], atol=1e-14)
    np.testing.assert_allclose(vert.point_data["reaction_force"], lam, atol=1e-14)   # +λ on b
    np.testing.assert_allclose(vert.point_data["reaction_moment"], 0.0, atol=1e-13)
    np.testing.assert_allclose(line.points, [at, at], atol=1e-14)
    assert line.cells[0][0] == "line" and line.cell_data["gap"][0][0] < 1e-14
    # the ground as body a: same reaction
    (g,) = _ready(mech, sj.SphericalJoint("support", "ground", b, at=at))
    qe, _ = _initial([g])
    vert, _ = _geometry([g], qe, None, lam)
    np.testing.assert_allclose(vert.point_data["reaction_force"], lam, atol=1e-14)


def test_revolute_joint_lock_rows_give_the_tabulated_moment():
    rng = np.random.default_rng(5)
    mech = Mechanism("rev")
    a, b = _two_bodies(rng, mech)
    at = rng.standard_normal(3)
    (j,) = _ready(mech, sj.RevoluteJoint("hinge", a, b, at=at, axis=rng.standard_normal(3)))
    E = j.E                                   # columns ē1, ē2, ē3 in space at t0
    lam = np.array([[1.0, -4.0, 2.0, 0.7, -1.3]])
    qe, qde = _initial([j])
    vert, _ = _geometry([j], qe, qde, lam)
    np.testing.assert_allclose(vert.point_data["reaction_force"][0], lam[0, :3], atol=1e-13)
    # at the reference orientation the moment on b is −λ[3] ē1 − λ[4] ē2 (exactly)
    np.testing.assert_allclose(vert.point_data["reaction_moment"][0], -0.7 * E[:, 0] + 1.3 * E[:, 1],
                               atol=1e-13)


def test_distance_joint_tension_pulls_b_towards_a():
    rng = np.random.default_rng(6)
    mech = Mechanism("dist")
    a, b = _two_bodies(rng, mech)
    (j,) = _ready(mech, sj.DistanceJoint("link", a, b, point_a=(0.1, 0.2, 0.0), point_b=(0.0, -0.3, 0.2)))
    qe, _ = _initial([j])
    vert, line = _geometry([j], qe, None, [[4.0]])
    pa, pb = line.points
    n = (pb - pa) / np.linalg.norm(pb - pa)
    np.testing.assert_allclose(vert.point_data["reaction_force"][0], -4.0 * n, atol=1e-13)
    np.testing.assert_allclose(vert.point_data["reaction_moment"][0], 0.0, atol=1e-12)
    assert line.cell_data["gap"][0][0] == pytest.approx(j.L)


def test_driven_revolute_angle_torque_at_the_driven_angle():
    rng = np.random.default_rng(7)
    mech = Mechanism("drive")
    a, b = _two_bodies(rng, mech)
    at = rng.standard_normal(3)
    (j,) = _ready(mech, sj.DrivenRevoluteAngle("motor", a, b, Linear(2.0), at=at,
                                               axis=rng.standard_normal(3)))
    t = 0.3
    e3 = j.E[:, 2]
    qe, _ = _initial([j])
    # turn b about the joint axis through the joint point by the driven angle φ(t) = 0.6
    Q = rt.expm(np.ascontiguousarray(0.6 * e3))
    qe[0, 7:10] = at + Q @ (qe[0, 7:10] - at)
    qe[0, 10:14] = rt.matrix_to_quat(np.ascontiguousarray(Q @ _R(qe[0, 10:14])))
    vert, _ = _geometry([j], qe, None, [[2.5]], t=t)
    np.testing.assert_allclose(vert.point_data["reaction_force"][0], 0.0, atol=1e-13)
    np.testing.assert_allclose(vert.point_data["reaction_moment"][0], -2.5 * e3, atol=1e-12)


def _every_joint(rng, a, b):
    at = rng.standard_normal(3)
    ax = rng.standard_normal(3)
    n1 = np.cross(ax, rng.standard_normal(3))
    return [
        sj.SphericalJoint("sph", a, b, at=at),
        sj.RevoluteJoint("rev", a, b, at=at, axis=ax),
        sj.UniversalJoint("uni", a, b, axis_a=ax, axis_b=n1, at=at),
        sj.CylindricalJoint("cyl", a, b, point_a=rng.standard_normal(3), point_b=rng.standard_normal(3), axis=ax),
        sj.PrismaticJoint("pri", a, b, at=at, axis=ax, axis1=n1),
        sj.FixedJoint("fix", a, b, at=at, axis=ax),
        sj.DistanceJoint("dist", a, b, point_a=rng.standard_normal(3), point_b=rng.standard_normal(3)),
        sj.DrivenRevoluteAngle("drv", a, b, Harmonic(0.7, 3.0, 0.2, offset=0.1), at=at, axis=ax, angle0=0.4),
        sj.DrivenPrismaticDisplacement("drd", a, b, Polynomial([0.1, -0.5, 0.8, 0.3]), at=at, axis=ax),
    ]


def _phi(j, x, t):
    nc = j.n_constraints
    fns = type(j).time_functions(j)
    tf = np.array([[[fn.f(t), fn.df(t), fn.ddf(t)] for fn in fns]]).reshape(1, len(fns), 3)
    Phi = np.zeros((1, nc))
    j.kernels["constraint"](type(j).pack([j])["P"], t, tf, np.ascontiguousarray(x), np.zeros((1, nc)),
                            False, Phi, np.zeros((1, nc, 12)), np.zeros((1, 12, 12)))
    return Phi[0]


@pytest.mark.parametrize("k", range(9))
def test_joint_reaction_is_minus_B_b_transpose_lambda(k):
    """F and M about p_a reproduce −B_bᵀλ, B_b from central differences of Φ (driven rows at t)."""
    rng = np.random.default_rng(8)
    mech = Mechanism("every")
    a, b = _two_bodies(rng, mech)
    j = _ready(mech, _every_joint(rng, a, b)[k])[0]
    qe, _ = _initial([j])
    d = 0.1 * rng.standard_normal((1, 12))
    x = oplus(qe, d)                                       # off the constraint manifold
    t = 0.37
    lam = rng.standard_normal((1, j.n_constraints))
    vert, line = _geometry([j], x, None, lam, t=t)
    eps = 1e-6
    Bb = np.zeros((j.n_constraints, 6))
    for c in range(6):
        dd = np.zeros((1, 12))
        dd[0, 6 + c] = eps
        Bb[:, c] = (_phi(j, oplus(x, dd), t) - _phi(j, oplus(x, -dd), t)) / (2 * eps)
    fb = -Bb.T @ lam[0]
    F, M = vert.point_data["reaction_force"][0], vert.point_data["reaction_moment"][0]
    pa = vert.points[0]
    xb, Rb = x[0, 7:10], _R(x[0, 10:14])
    np.testing.assert_allclose(F, fb[:3], atol=1e-7)
    np.testing.assert_allclose(Rb.T @ (M + np.cross(pa - xb, F)), fb[3:], atol=1e-7)
    np.testing.assert_allclose(pa, x[0, 0:3] + _R(x[0, 3:7]) @ j.Xa, atol=1e-13)
    np.testing.assert_allclose(line.points[1], xb + Rb @ j.Xb, atol=1e-13)


def test_joint_geometry_rejects_wrong_multipliers():
    rng = np.random.default_rng(9)
    mech = Mechanism("bad")
    a, b = _two_bodies(rng, mech)
    (j,) = _ready(mech, sj.RevoluteJoint("hinge", a, b, at=(0, 0, 0)))
    qe, _ = _initial([j])
    with pytest.raises(ModelError, match="RevoluteJoint: geometry needs 5 multipliers"):
        sj.RevoluteJoint.geometry(sj.RevoluteJoint.pack([j]), 0.0, qe, np.zeros((1, 12)),
                                  np.zeros((1, 3)), ["hinge"])


# ---------------------------------------------------------------------------
# forces
# ---------------------------------------------------------------------------
def test_point_spring_tension_and_rate():
    rng = np.random.default_rng(10)
    mech = Mechanism("spring")
    a, b = _two_bodies(rng, mech)
    (s,) = _ready(mech, sf.PointSpringDamper("spring", a, b, 100.0, 3.0, length=0.5,
                                             point_a=(0.1, 0, 0), point_b=(0, 0.2, 0)))
    qe, _ = _initial([s])
    qde = rng.standard_normal((1, 12))
    (blk,) = _geometry([s], qe, qde)
    pa, pb = blk.points
    L = np.linalg.norm(pb - pa)
    eps = 1e-6

    def length(x):
        q = _geometry([s], x, qde)[0].points
        return np.linalg.norm(q[1] - q[0])

    Ld = (length(oplus(qe, eps * qde)) - length(oplus(qe, -eps * qde))) / (2 * eps)
    assert blk.cell_data["length"][0][0] == pytest.approx(L, rel=1e-14)
    assert blk.cell_data["tension"][0][0] == pytest.approx(100.0 * (L - 0.5) + 3.0 * Ld, rel=1e-8)


def test_rotational_spring_moment_and_bushing_force():
    rng = np.random.default_rng(11)
    mech = Mechanism("springs")
    a, b = _two_bodies(rng, mech)
    at = rng.standard_normal(3)
    ax = rng.standard_normal(3)
    rs, bu = _ready(mech, sf.RotationalSpringDamper("torsion", a, b, 40.0, at=at, axis=ax),
                    sf.Bushing("mount", a, b, (100.0, 200.0, 300.0), (1.0, 2.0, 3.0), at=at, axis=ax))
    E = rs.E
    qe, _ = _initial([rs])
    Q = rt.expm(np.ascontiguousarray(0.3 * E[:, 2]))
    x = qe.copy()
    x[0, 7:10] = at + Q @ (qe[0, 7:10] - at)
    x[0, 10:14] = rt.matrix_to_quat(np.ascontiguousarray(Q @ _R(qe[0, 10:14])))
    (blk,) = _geometry([rs], x)
    np.testing.assert_allclose(blk.points[0], at, atol=1e-13)
    assert blk.point_data["angle"][0] == pytest.approx(0.3, rel=1e-12)
    np.testing.assert_allclose(blk.point_data["moment"][0], -40.0 * 0.3 * E[:, 2], atol=1e-11)
    np.testing.assert_allclose(blk.point_data["force"][0], 0.0, atol=1e-12)
    # bushing: b moved by δ along ē1 -> force −K1 δ ē1 on b, no moment about the joint point
    x = qe.copy()
    x[0, 7:10] += 0.01 * E[:, 0]
    (blk,) = _geometry([bu], x)
    np.testing.assert_allclose(blk.point_data["force"][0], -100.0 * 0.01 * E[:, 0], atol=1e-11)
    np.testing.assert_allclose(blk.point_data["moment"][0], 0.0, atol=1e-11)


def test_loads_in_space_axes():
    rng = np.random.default_rng(12)
    mech = Mechanism("loads")
    a, _ = _two_bodies(rng, mech)
    X = np.array([0.1, 0.2, 0.3])
    F = np.array([1.0, -2.0, 0.5])
    dead, follower = _ready(mech, sf.SpatialForce("dead", a, F, point=X, function=Linear(2.0)),
                            sf.SpatialForce("follower", a, F, point=X, follower=True))
    torque, = _ready(mech, sf.SpatialTorque("torque", a, F, follower=True, function=3.0))
    qe, _ = _initial([dead])
    R = _R(qe[0, 3:7])
    (blk,) = _geometry([dead, follower], np.vstack((qe, qe)), t=0.25)
    np.testing.assert_allclose(blk.points, [qe[0, :3] + R @ X] * 2, atol=1e-14)
    np.testing.assert_allclose(blk.point_data["force"], [0.5 * F, R @ F], atol=1e-14)
    (blk,) = _geometry([torque], qe)
    np.testing.assert_allclose(blk.points, qe[:, :3])
    np.testing.assert_allclose(blk.point_data["torque"], [3.0 * R @ F], atol=1e-14)


# ---------------------------------------------------------------------------
# files
# ---------------------------------------------------------------------------
def _scene_blocks(rng):
    """Blocks of every spatial element type on one scene at t0 with random λ."""
    mech = Mechanism("scene")
    bodies = _bodies(rng)[:3]
    for body in bodies:
        mech.add(body)
    a, b = bodies[0], bodies[1]
    pm = mech.add(SpatialPointMass("pm", 0.3, position=(1.0, 1.0, 1.0)))
    others = [sf.PointSpringDamper("spring", a, b, 10.0, 0.5, point_a=(0.2, 0, 0)),
              sf.Bushing("mount", a, b, (1.0, 1.0, 1.0), (1.0, 1.0, 1.0), at=(0, 0, 0)),
              sf.RotationalSpringDamper("torsion", a, b, 1.0, at=(0, 0, 0)),
              sf.SpatialForce("push", a, (1.0, 0, 0), point=(0.2, 0, 0)),
              sf.SpatialTorque("twist", b, (0, 0, 1.0)),
              sj.SphericalJoint("ground_ball", "ground", pm, at=(1.0, 1.0, 1.0))]
    groups = [bodies, [pm]] + [[e] for e in _ready(mech, *_every_joint(rng, a, b))]
    groups += [[e] for e in _ready(mech, *others)]
    blocks = []
    for els in groups:
        qe, qde = _initial(els)
        nc = getattr(type(els[0]), "n_constraints", 0)
        blocks += _geometry(els, qe, qde, rng.standard_normal((len(els), nc)))
    return blocks


def test_blocks_merge_into_a_vtu(tmp_path):
    rng = np.random.default_rng(13)
    blocks = _scene_blocks(rng)
    names = {b.name for b in blocks}
    assert {"SpatialRigidBody", "SpatialRigidBodyFrame", "SpatialPointMass", "FixedJoint",
            "DrivenRevoluteAngle", "PointSpringDamper", "Bushing", "SpatialTorque"} <= names
    mesh = merge_blocks(blocks, field_data={"TimeValue": 0.0})
    path = tmp_path / "spatial.vtu"
    write_vtu(path, mesh)
    back = read_frame(path)
    np.testing.assert_allclose(back.points, mesh.points)
    for key in ("velocity", "e1", "omega", "reaction_force", "reaction_moment", "force", "torque"):
        np.testing.assert_allclose(back.point_data[key], mesh.point_data[key])
    assert back.point_data["reaction_force"].shape == (len(mesh.points), 3)
    got = {c.type: 0 for c in back.cells}
    for c in back.cells:
        got[c.type] += len(c.data)
    assert got["triangle"] == sum(len(conn) for b in blocks for kind, conn in b.cells if kind == "triangle")
    assert got["vertex"] > 0 and got["line"] > 0
    tension = np.concatenate(back.cell_data["tension"])
    assert tension.size == sum(len(c.data) for c in back.cells) and np.all(np.isfinite(tension))


def test_model_blocks_writes_the_spatial_ground_points():
    mech = Mechanism("ground")
    g = spatial_ground(mech)
    g.add_point("A", (1.0, 2.0, 3.0))
    g.add_point("B", (0.0, 0.0, -1.0))
    model = SimpleNamespace(bodies={"ground": mech.ground}, groups=[],
                            ext=lambda q: q, ext_velocity=lambda v: v)
    blocks = model_blocks(model, 0.0, np.zeros(0), np.zeros(0), np.zeros(0))
    (blk,) = [b for b in blocks if b.name == "SpatialGround"]
    np.testing.assert_array_equal(blk.points, [[1.0, 2.0, 3.0], [0.0, 0.0, -1.0]])


# ---------------------------------------------------------------------------
# the 3-D camera
# ---------------------------------------------------------------------------
def test_camera_3d_frames_every_corner():
    lo, hi = np.array([-1.0, 0.5, -0.2]), np.array([2.0, 1.5, 3.0])
    aspect, angle = 4.0 / 3.0, 30.0
    focal, pos, up = camera_3d(lo, hi, (1.0, -1.0, 0.7), aspect, angle, margin=1.08)
    np.testing.assert_allclose(focal, 0.5 * (lo + hi))
    d = (pos - focal) / np.linalg.norm(pos - focal)
    np.testing.assert_allclose(d, np.array([1.0, -1.0, 0.7]) / np.linalg.norm([1.0, -1.0, 0.7]))
    assert abs(up @ d) < 1e-14 and up[2] > 0 and np.linalg.norm(up) == pytest.approx(1.0)
    rgt = np.cross(up, d)
    assert rgt[0] > 0 and rgt[1] > 0          # x and y both run to the right of the picture
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])])
    depth = (pos - corners) @ d
    assert np.all(depth > 0)
    half = math.tan(math.radians(angle / 2))
    sx = np.abs((corners - pos) @ rgt) / (depth * half * aspect)
    sy = np.abs((corners - pos) @ up) / (depth * half)
    used = np.maximum(sx, sy)
    assert used.max() <= 1 / 1.08 + 1e-12                   # all in view with the margin
    assert used.max() == pytest.approx(1 / 1.08, rel=1e-9)  # and tight
    with pytest.raises(OutputError, match="parallel to the z axis"):
        camera_3d(lo, hi, (0.0, 0.0, 1.0))


def test_default_view_follows_planarity():
    assert _check_view(None, SimpleNamespace(planar=True)) == "xy"
    assert _check_view(None, SimpleNamespace(planar=False)) == "3d"
    assert _check_view("iso", SimpleNamespace(planar=False)) == "iso"
    assert _check_view("top", SimpleNamespace(planar=False)) == "top"
    assert _check_view(" 30, 20 ", SimpleNamespace(planar=False)) == "30, 20"
    with pytest.raises(OutputError, match="3d"):
        _check_view("above", SimpleNamespace(planar=False))
    with pytest.raises(OutputError, match="elevation in"):
        _check_view("30,120", SimpleNamespace(planar=False))


def test_render_spatial_motion(tmp_path, renderer):
    from femb.io import TimeSeriesWriter
    from femb.io.render import render_png

    rng = np.random.default_rng(14)
    body = SpatialRigidBody("box", 1.0, box_inertia(1.0, 1.0, 0.3, 0.2),
                            shape={"type": "box", "size": (1.0, 0.3, 0.2)})
    p = SpatialRigidBody.pack([body])
    with TimeSeriesWriter(tmp_path, "box") as w:
        for i in range(4):
            qe = np.array([[0.5 * i, 0.0, 0.3 * i, *rt.quat_exp(np.array([0.0, 0.4 * i, 0.8 * i]))]])
            w.write(0.1 * i, SpatialRigidBody.geometry(p, 0.1 * i, qe, rng.standard_normal((1, 6)),
                                                       np.zeros((1, 0)), ["box"]))
    out = render_png(w.path, tmp_path / "box.png", time=0.0, window_size=(320, 240))
    from PIL import Image

    with Image.open(out) as im:
        img = np.asarray(im.convert("RGB")).astype(int)
    ink = np.any(img < 200, axis=2)
    ink[:40, :] = False                         # the time label
    rows, cols = np.nonzero(ink)
    assert rows.size > 50                       # the box is drawn
    assert rows.min() > 0 and cols.min() > 0 and rows.max() < 239 and cols.max() < 319

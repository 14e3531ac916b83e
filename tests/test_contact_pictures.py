"""Contacts in VTK and in pictures (femb.io.frames, femb.io.mechanism; ``geometry`` of the contact types).

Every contact type writes one vertex per contact at its contact point c with point data
``contact_normal``, ``contact_force`` F (N, on the body; on pairs on body b, −F on a), ``gap`` and
``contact_state``. The check is independent of how c and F are computed: F applied at c (and −F on
the first body of a pair) must do the same work as the element's generalized contact force on
any velocity, i.e. equal it component by component: W_Nᵀλ_N + W_Fᵀλ_F of the nonsmooth types
(femb.contact.assemble) and the compiled force of the penalty types. The gap must equal the
kernels' g_N. Then a whole run: the bouncing ball's VTK frames carry its contact force m g at rest
and no closed contact in flight, and the picture draws the contact (an item ``contact``).
"""
import numpy as np
import pytest

import femb
from femb.contact import assemble, simulate
from femb.elements import (PenaltySphereOnPlane, RigidBody, SpatialPenaltySphereOnBodyPlane,
                           SpatialPenaltySpherePair, SpatialPenaltySphereOnPlane, SpatialRigidBody)
from femb.elements.contact import DiscOnDisc, PinInHole, SphereOnPlane, SpatialSphereOnPlane, SpatialSpherePair
from femb.io.frames import model_blocks
from femb.system import kernels as K

ROT = [np.array((0.9, 0.3, -0.4, 0.1)), np.array((0.2, -0.5, 0.7, 0.3))]


def _quat(k):
    return ROT[k] / np.linalg.norm(ROT[k])


def _R(p):
    from femb.base.rotations import quat_to_matrix
    return quat_to_matrix(p)


def _expected(spatial, bodies, c, F):
    """The generalized force of F at c on body b (last) and −F at c on body a (first of a pair)."""
    out = []
    for k, (r, R) in enumerate(bodies):
        sign = 1.0 if k == len(bodies) - 1 else -1.0
        m = np.cross(c - r, F)
        out.append(sign * (np.concatenate((F, R.T @ m)) if spatial else np.array((F[0], F[1], m[2]))))
    return np.concatenate(out)


def _bodies(model, st, spatial, n):
    q = st.q
    if spatial:
        return [(q[7 * k:7 * k + 3], _R(q[7 * k + 3:7 * k + 7])) for k in range(n)]
    return [(np.array((q[3 * k], q[3 * k + 1], 0.0)), None) for k in range(n)]


def _block(model, st, contact=None):
    blocks = model_blocks(model, st.t, st.q, st.qd, np.zeros(model.nc), contact=contact)
    return next(b for b in blocks if "contact_force" in b.point_data)


# --------------------------------------------------------------- the nonsmooth contact types
def _nonsmooth(kind):
    m = femb.Mechanism(kind)
    if kind == "sphere_plane":
        m.add(RigidBody("b", 1.0, 0.01, position=(0.1, 0.05), angle=0.3))
        m.add(SphereOnPlane("c", "b", 0.08, point=(0.01, 0.02), plane_point=(0.0, -0.01), normal=(0.2, 1.0), mu=0.3))
        return m, False, 1
    if kind in ("disc_disc", "pin_hole"):
        m.add(RigidBody("a", 1.0, 0.01, position=(0.0, 0.0), angle=0.2))
        m.add(RigidBody("b", 2.0, 0.02, position=(0.17, 0.05) if kind == "disc_disc" else (0.004, -0.002),
                        angle=-0.7))
        if kind == "disc_disc":
            m.add(DiscOnDisc("c", "a", "b", 0.1, 0.08, point_a=(0.01, -0.02), point_b=(0.0, 0.01), mu=0.3))
        else:
            m.add(PinInHole("c", "a", "b", 0.05, 0.045, point_a=(0.002, 0.001), point_b=(-0.001, 0.002), mu=0.3))
        return m, False, 2
    if kind == "spatial_sphere_pair":
        m.add(SpatialRigidBody("a", 1.0, (0.004, 0.005, 0.006), position=(0.0, 0.0, 0.0), rotation=_quat(1)))
        m.add(SpatialRigidBody("b", 2.0, (0.006, 0.005, 0.004), position=(0.15, 0.1, -0.05), rotation=_quat(0)))
        m.add(SpatialSpherePair("c", "a", "b", 0.1, 0.08, point_a=(0.01, -0.02, 0.005), point_b=(0.0, 0.01, -0.01),
                                mu=0.3))
        return m, True, 2
    m.add(SpatialRigidBody("b", 1.0, (0.004, 0.005, 0.006), position=(0.1, 0.2, 0.05), rotation=_quat(0)))
    m.add(SpatialSphereOnPlane("c", "b", 0.08, point=(0.01, 0.02, -0.015), plane_point=(0.0, 0.0, -0.01),
                               normal=(0.1, -0.2, 1.0), mu=0.3))
    return m, True, 1


@pytest.mark.parametrize("kind", ["sphere_plane", "disc_disc", "pin_hole", "spatial_sphere_plane",
                                  "spatial_sphere_pair"])
def test_nonsmooth_contact_block_does_the_work_of_the_contact_force(kind):
    mech, spatial, nb = _nonsmooth(kind)
    model = mech.compile()
    st = model.initial_state()
    if nb == 2 and spatial:     # close the pair: move b along n by −g_N
        ev = assemble.evaluate(model, st.t, st.q, st.qd)
        n = _block(model, st).point_data["contact_normal"][0]
        st.q[7:10] -= ev["gN"][0] * n
        assert abs(assemble.evaluate(model, st.t, st.q, st.qd)["gN"][0]) < 1e-15
    elif nb == 2:       # close the pair (g_N = 0): the contact points of a and b coincide, as in a closed contact
        ev = assemble.evaluate(model, st.t, st.q, st.qd)
        e = st.q[3:5] - st.q[0:2]
        sN = 1.0 if kind == "disc_disc" else -1.0
        blk0 = _block(model, st)
        n = blk0.point_data["contact_normal"][0][:2] * sN          # from the first centre to the second
        st.q[3:5] -= sN * ev["gN"][0] * n
        assert abs(assemble.evaluate(model, st.t, st.q, st.qd)["gN"][0]) < 1e-15 and e.any()
    rng = np.random.default_rng(3)
    lam_N, lam_F = rng.uniform(0.5, 2.0, model.n_contacts), rng.uniform(-1.0, 1.0, model.n_friction)
    ev = assemble.evaluate(model, st.t, st.q, st.qd, dense=True)
    gen = ev["WN"].T @ lam_N + ev["WF"].T @ lam_F
    blk = _block(model, st, contact=(np.ones(model.n_contacts), lam_N, lam_F))
    c, F = blk.points[0], blk.point_data["contact_force"][0]
    np.testing.assert_allclose(_expected(spatial, _bodies(model, st, spatial, nb), c, F), gen, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(blk.point_data["gap"], ev["gN"], rtol=0, atol=1e-15)
    assert blk.point_data["contact_state"][0] == 1.0
    n = blk.point_data["contact_normal"][0]
    np.testing.assert_allclose(F @ n, lam_N[0], rtol=1e-12)            # the normal part is λ_N along n
    # without a contact result: the geometry and the gap, no force, state not known
    bare = _block(model, st)
    np.testing.assert_allclose(bare.points, blk.points)
    assert not bare.point_data["contact_force"].any() and bare.point_data["contact_state"][0] == -1.0


# --------------------------------------------------------------- the penalty contact types
def _penalty(kind):
    m = femb.Mechanism(kind)
    law = dict(restitution=0.5, mu=0.3, eps_v=0.1)
    if kind == "planar":
        m.add(RigidBody("b", 1.0, 0.004, position=(0.1, 0.04), angle=0.3))
        m.add(PenaltySphereOnPlane("c", "b", 0.1, 1e5, point=(0.01, 0.02), plane_point=(0.0, -0.01),
                                   normal=(0.2, 1.0), **law))
        return m, False, 1
    if kind == "spatial":
        m.add(SpatialRigidBody("b", 1.0, (0.004, 0.005, 0.006), position=(0.1, 0.2, 0.07), rotation=_quat(0)))
        m.add(SpatialPenaltySphereOnPlane("c", "b", 0.1, 1e5, point=(0.01, 0.02, -0.015),
                                          plane_point=(0.0, 0.0, -0.01), normal=(0.1, -0.2, 1.0), **law))
        return m, True, 1
    m.add(SpatialRigidBody("a", 1.0, (0.004, 0.005, 0.006), rotation=_quat(0)))
    if kind == "pair":
        m.add(SpatialRigidBody("b", 2.0, (0.007, 0.005, 0.006), position=(0.15, 0.05, -0.03), rotation=_quat(1)))
        m.add(SpatialPenaltySpherePair("c", "a", "b", 0.1, 0.08, 1e5, point_a=(0.01, -0.02, 0.005),
                                       point_b=(-0.01, 0.01, 0.02), **law))
    else:
        m.add(SpatialRigidBody("b", 2.0, (0.007, 0.005, 0.006), position=(0.03, -0.02, 0.06), rotation=_quat(1)))
        m.add(SpatialPenaltySphereOnBodyPlane("c", "a", "b", 0.08, 1e5, plane_point=(0.02, 0.01, -0.03),
                                              normal=(0.1, -0.2, 1.0), point=(-0.01, 0.01, 0.02), **law))
    return m, True, 2


@pytest.mark.parametrize("kind", ["planar", "spatial", "pair", "body_plane"])
def test_penalty_contact_block_does_the_work_of_the_contact_force(kind):
    mech, spatial, nb = _penalty(kind)
    model = mech.compile()
    st = model.initial_state()
    st.qd[:] = np.random.default_rng(1).uniform(-0.5, 0.5, st.qd.size)
    g = next(g for g in model.force_groups if "Penalty" in g.name)
    v = np.concatenate((st.qd, np.zeros(model.nfix_v)))
    f = K.ForceValues(g)(st.t, model.ext(st.q)[g.xdofs], v[g.dofs])[0]
    blk = _block(model, st)
    c, F = blk.points[0], blk.point_data["contact_force"][0]
    r = femb.Result(model=model, t=np.array([st.t]), q=st.q[None], qd=st.qd[None], qdd=np.zeros((1, model.nq)),
                    lam=np.zeros((1, model.nc)), newton_iterations=np.zeros(0, dtype=np.int32))
    assert r.series("c.gN")[0][0] < 0.0 and r.series("c.lambda_N")[0][0] > 0.0     # the contact is pressed
    np.testing.assert_allclose(_expected(spatial, _bodies(model, st, spatial, nb), c, F), f, rtol=1e-10, atol=1e-10)
    assert blk.point_data["gap"][0] == pytest.approx(r.series("c.gN")[0][0], abs=1e-15)
    assert blk.point_data["contact_state"][0] == r.series("c.state")[0][0]
    n = blk.point_data["contact_normal"][0]
    assert F @ n == pytest.approx(r.series("c.lambda_N")[0][0], rel=1e-12)


# --------------------------------------------------------------- a run: VTK frames and the picture
def test_bouncing_ball_frames_and_picture_show_the_contact(tmp_path):
    from femb.benchmarks.scenes.contact import contact_ball

    pv = pytest.importorskip("pyvista")
    from femb.io.mechanism import frame_items, read_frame, scan_motion

    res = simulate(contact_ball.build(e_N=0.5, mass=2.0).compile(), 1.5, 2e-3)
    res.write_vtk(tmp_path / "vtk", every=50)
    files = sorted((tmp_path / "vtk").glob("*.vtu"))
    assert len(files) == 16 and res.t.size == 751
    assert res.contact["state"][250, 0] == 0 and res.contact["state"][-1, 0] == 1   # t = 0.5 in flight, 1.5 at rest
    frames = [read_frame(pv.read(f), t) for f, t in zip(files, res.t[::50])]
    fly, rest = frames[5], frames[-1]
    assert fly.contacts == []
    (p, F, n), = rest.contacts
    np.testing.assert_allclose(F, (0.0, 2.0 * 9.81, 0.0), atol=1e-9)          # m g, on the ball
    np.testing.assert_allclose(n, (0.0, 1.0, 0.0))
    assert abs(p[1]) < 1e-9                                                      # on the floor
    motion = scan_motion(frames, ())
    assert "contact" in {it.kind for it in frame_items(pv, rest, motion)}
    assert "contact" not in {it.kind for it in frame_items(pv, fly, motion)}


def test_frames_every_dt_are_the_stored_steps_nearest_each(tmp_path):
    """Result.write_vtk(dt=...) (femb run --dt on a contact scene): the stored step nearest each multiple of dt,
    each once, and the last; with adaptive steps longer than dt the frames are the steps there are (before
    2026-11-29 the command line wrote every k-th stored step, k from the median step: 10 uneven frames of the
    adaptive ball for dt = 0.05 s)."""
    import re

    from femb.benchmarks.scenes.contact import contact_ball
    from femb.errors import ModelError

    def times(pvd):
        return np.array([float(x) for x in re.findall(r'timestep="([^"]+)"', pvd.read_text())])

    model = contact_ball.build().compile()
    fixed = simulate(model, 1.5, 2e-3)
    np.testing.assert_allclose(times(fixed.write_vtk(tmp_path / "f", dt=0.1)), np.linspace(0.0, 1.5, 16), atol=1e-12)
    ada = simulate(model, 1.5, 2e-3, rtol=1e-5)
    got = times(ada.write_vtk(tmp_path / "a", dt=0.05))
    want = sorted({float(ada.t[np.argmin(np.abs(ada.t - m))]) for m in np.arange(31) * 0.05} | {float(ada.t[-1])})
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)            # (the .pvd holds the times to 15 digits)
    assert 15 < got.size < 31 and np.all(np.diff(got) > 0)
    for bad in (0.0, -1.0, "x", float("nan")):
        with pytest.raises(ModelError, match="dt must be a positive number"):
            fixed.write_vtk(tmp_path / "b", dt=bad)


def test_a_contact_type_that_does_not_describe_its_points_is_not_drawn():
    """A user's contact type without ``contact_frames`` writes no contact block (and no error)."""
    class MySphereOnPlane(SphereOnPlane):
        contact_frames = classmethod(lambda cls, P, qe: None)

    m = femb.Mechanism("own")
    m.add(RigidBody("b", 1.0, 0.01, position=(0.1, 0.05)))
    m.add(MySphereOnPlane("c", "b", 0.08))
    model = m.compile()
    st = model.initial_state()
    blocks = model_blocks(model, st.t, st.q, st.qd, np.zeros(model.nc))
    assert not any("contact_force" in b.point_data for b in blocks)

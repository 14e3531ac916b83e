"""SphereOnBodyPlane and SpatialSphereOnBodyPlane: a sphere against a plane fixed to another body, in the
nonsmooth contact scheme (docs/contact.md §2).

1. The kernels against finite differences (W_N, ζ, H) at open and penetrated states with rotated bodies
   and points off the nodes; W_F v and W_N v against the velocity of the sphere's material point at the
   contact point relative to the plane body's material point there, computed here from the rigid-body
   motions; with the ground as the plane body, the outputs of SphereOnPlane / SpatialSphereOnPlane.
2. Equivalence: the bouncing ball on a plane of a body welded to the ground (rotated, the plane given in
   its axes) follows the run on the fixed-plane element: the same impacts, the same trajectory.
3. Impact of a free sphere on a free body carrying the plane (no gravity, μ = 0, e_N = 1 and 0): the
   closed form of the impact of a rigid body at a point with effective mass m* along n, linear and
   angular momentum, Newton's law, the energy; in space the plate is rotated and spins.
4. Coulomb friction on a moving plate: a block set on a plate that slides on a frictionless support; the
   slip stops at t* = Δv/(μ g (1 + m/M)) and both move on with the common velocity.
5. Bad inputs: ModelErrors that name the element and the parameter.
6. The compiled loop and the Python loop give the same run.

Closed forms: the impact of two rigid bodies at a point, with the effective mass along the normal
1/m* = 1/m_b + 1/m_a + (a × n)·I_a⁻¹(a × n) (a the plane body's arm to the contact point), Newton's
law v_N⁺ = −e_N v_N⁻ and the impulse Λ = −(1 + e_N) m* v_N⁻ (W. J. Stronge, Impact Mechanics,
Cambridge University Press 2000, Ch. 3 and 4; W. Goldsmith, Impact, Arnold 1960, Ch. 2; F. Pfeiffer,
C. Glocker, Multibody Dynamics with Unilateral Contacts, Wiley 1996, Ch. 4); Coulomb's law of sliding
friction, F = μN against the slip, and sticking while |F| ≤ μN (Pfeiffer & Glocker 1996, Ch. 5;
C. Glocker, Set-Valued Force Laws, Springer 2001).
"""
import math
import sys

import numpy as np
import pytest

import femb
from femb.base.rotations import expm, quat_to_matrix
from femb.benchmarks.scenes.contact import contact_ball
from femb.contact import assemble, check_contact_kernels, simulate
from femb.elements import (Clamp, FixedJoint, Gravity, RigidBody, Slider, SpatialGravity, SpatialRigidBody,
                           SpringDamper)
from femb.elements.contact import (SphereOnBodyPlane, SphereOnPlane, SpatialSphereOnBodyPlane, SpatialSphereOnPlane)
from femb.errors import ModelError

ROT = [np.array((0.9, 0.3, -0.4, 0.1)), np.array((0.2, -0.5, 0.7, 0.3))]


def _quat(k):
    return ROT[k] / np.linalg.norm(ROT[k])


def _rot2(th):
    c, s = math.cos(th), math.sin(th)
    return np.array(((c, -s), (s, c)))


def _cross2(a, b):
    return a[0] * b[1] - a[1] * b[0]


# --------------------------------------------------------------- 1. the kernels
def _planar(offset, plane_body="plate"):
    m = femb.Mechanism("body_plane")
    m.add(RigidBody("plate", 1.0, 0.1, position=(0.1, 0.3), angle=0.3))
    m.add(RigidBody("ball", 2.0, 0.2, position=np.array((0.1, 0.3)) + offset, angle=-0.2))
    m.add(SphereOnBodyPlane("c", "ball", plane_body, radius=0.1, point=(0.05, -0.02), plane_point=(0.03, 0.04),
                            normal=(0.2, 1.0), mu=0.3))
    return m.compile()


def _spatial(offset, plane_body="plate"):
    m = femb.Mechanism("body_plane_3d")
    m.add(SpatialRigidBody("plate", 1.0, (0.1, 0.2, 0.3), position=(0.1, 0.3, 0.5), rotation=_quat(0)))
    m.add(SpatialRigidBody("ball", 2.0, (0.2, 0.1, 0.3), position=np.array((0.1, 0.3, 0.5)) + offset,
                           rotation=_quat(1)))
    m.add(SpatialSphereOnBodyPlane("c", "ball", plane_body, radius=0.1, point=(0.05, -0.02, 0.03),
                                   plane_point=(0.02, 0.03, -0.04), normal=(0.2, 0.3, 1.0), tangent=(1.0, -0.5, 0.2),
                                   mu=0.2))
    return m.compile()


OFFSETS = {"planar": {"open": np.array((0.1, 0.4)), "penetrated": np.array((0.05, 0.1))},
           "spatial": {"open": np.array((0.1, 0.2, 0.4)), "penetrated": np.array((0.02, 0.03, 0.05))}}
BUILD = {"planar": _planar, "spatial": _spatial}


@pytest.mark.parametrize("kind", ["planar", "spatial"])
@pytest.mark.parametrize("state", ["open", "penetrated"])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_kernel_matches_finite_differences(kind, state, seed):
    """W_N = ∂g_N/∂q, ζ = (W v)_q v and H = ∂(Wᵀλ)/∂q at random moved states, open and penetrated."""
    model = BUILD[kind](OFFSETS[kind][state])
    gN = assemble.evaluate(model, 0.0, model.q0, np.zeros(model.nq))["gN"][0]
    assert (gN > 0.0) == (state == "open")
    report = check_contact_kernels(model, seed=seed, move=0.1)
    assert report.ok, str(report)
    assert len(report.checks) == 3


def _material_velocities(kind, model, el, q, u):
    """Velocities of the sphere's and the plane body's material points at the contact point c = C − R n,
    the unit normal n, the tangents and the gap, from the rigid-body motions (v + ω × arm)."""
    ia, ib = model.node_index["plate"], model.node_index["ball"]
    ja, jb = model.node_vindex["plate"], model.node_vindex["ball"]
    if kind == "planar":
        Ra, Rb = _rot2(q[ia[2]]), _rot2(q[ib[2]])
        n = Ra @ el.nbar
        T = [np.array((n[1], -n[0]))]
        P = q[ia[:2]] + Ra @ el.pbar
        C = q[ib[:2]] + Rb @ el.s
        c = C - el.radius * n

        def vel(j, i, x):
            return u[j[:2]] + u[j[2]] * np.array((-(x - q[i[:2]])[1], (x - q[i[:2]])[0]))
    else:
        Ra, Rb = quat_to_matrix(q[ia[3:7]]), quat_to_matrix(q[ib[3:7]])
        n = Ra @ el.nbar
        T = [Ra @ el.t1bar, Ra @ el.t2bar]
        P = q[ia[:3]] + Ra @ el.pbar
        C = q[ib[:3]] + Rb @ el.s
        c = C - el.radius * n
        Rs = {"plate": Ra, "ball": Rb}

        def vel(j, i, x):
            body = "plate" if i is ia else "ball"
            return u[j[:3]] + np.cross(Rs[body] @ u[j[3:6]], x - q[i[:3]])
    return vel(jb, ib, c), vel(ja, ia, c), n, T, n @ (C - P) - el.radius, c


@pytest.mark.parametrize("kind", ["planar", "spatial"])
def test_rows_are_the_relative_velocity_of_the_material_points(kind):
    """γ_F = W_F v = t·(v_b(c) − v_a(c)) and ġ_N = W_N v = n·(v_b(c) − v_a(c)), the two material points at
    the contact point c computed from the rigid-body motions; contact_frames gives c, n, t and g_N."""
    model = BUILD[kind](OFFSETS[kind]["open"])
    g = next(iter(model.contact_groups))
    el, cls = g.elements[0], g.cls
    rng = np.random.default_rng(11)
    for _ in range(4):
        q = model.compose(model.q0, 0.3 * rng.standard_normal(model.nq))
        u = rng.standard_normal(model.nq)
        ev = assemble.evaluate(model, 0.0, q, u, dense=True)
        vb, va, n, T, gap, c = _material_velocities(kind, model, el, q, u)
        np.testing.assert_allclose(ev["WN"] @ u, [n @ (vb - va)], rtol=1e-13, atol=1e-13)
        np.testing.assert_allclose(ev["WF"] @ u, [t @ (vb - va) for t in T], rtol=1e-13, atol=1e-13)
        np.testing.assert_allclose(ev["gN"], [gap], rtol=0, atol=1e-15)
        c2, n2, T2, g2 = cls.contact_frames(g.P, model.ext(q)[g.xdofs])
        dim = 2 if kind == "planar" else 3
        np.testing.assert_allclose(c2[0, :dim], c, atol=1e-15)
        np.testing.assert_allclose(n2[0, :dim], n, atol=1e-15)
        np.testing.assert_allclose(T2[0, :, :dim], np.array(T), atol=1e-15)
        np.testing.assert_allclose(g2, [gap], atol=1e-15)
        if kind == "spatial":     # (t₁, t₂, n) right-handed and orthonormal
            np.testing.assert_allclose(np.cross(T[0], T[1]), n, atol=1e-14)


@pytest.mark.parametrize("kind", ["planar", "spatial"])
def test_ground_as_the_plane_body_is_the_fixed_plane_element(kind):
    """plane_body = "ground" (a fixed node): g_N, W, ζ and H are those of SphereOnPlane / SpatialSphereOnPlane
    with the same plane, at random states."""
    off = OFFSETS[kind]["penetrated"]
    body_plane = BUILD[kind](off, plane_body="ground")
    el = next(iter(body_plane.contact_groups)).elements[0]
    m = femb.Mechanism("fixed_plane")
    if kind == "planar":
        m.add(RigidBody("plate", 1.0, 0.1, position=(0.1, 0.3), angle=0.3))
        m.add(RigidBody("ball", 2.0, 0.2, position=np.array((0.1, 0.3)) + off, angle=-0.2))
        m.add(SphereOnPlane("c", "ball", radius=0.1, point=(0.05, -0.02), plane_point=(0.03, 0.04),
                            normal=(0.2, 1.0), mu=0.3))
    else:
        m.add(SpatialRigidBody("plate", 1.0, (0.1, 0.2, 0.3), position=(0.1, 0.3, 0.5), rotation=_quat(0)))
        m.add(SpatialRigidBody("ball", 2.0, (0.2, 0.1, 0.3), position=np.array((0.1, 0.3, 0.5)) + off,
                               rotation=_quat(1)))
        m.add(SpatialSphereOnPlane("c", "ball", radius=0.1, point=(0.05, -0.02, 0.03), plane_point=(0.02, 0.03, -0.04),
                                   normal=(0.2, 0.3, 1.0), tangent=(1.0, -0.5, 0.2), mu=0.2))
    fixed = m.compile()
    el2 = next(iter(fixed.contact_groups)).elements[0]
    if kind == "spatial":
        np.testing.assert_allclose((el.t1bar, el.t2bar), (el2.t1, el2.t2), atol=1e-15)
    rng = np.random.default_rng(5)
    for _ in range(3):
        q = fixed.compose(fixed.q0, 0.2 * rng.standard_normal(fixed.nq))
        u = rng.standard_normal(fixed.nq)
        lN, lF = rng.standard_normal(1), rng.standard_normal(fixed.n_friction)
        a = assemble.evaluate(body_plane, 0.0, q, u, lN, lF, jac=True, dense=True)
        b = assemble.evaluate(fixed, 0.0, q, u, lN, lF, jac=True, dense=True)
        for key in ("gN", "WN", "WF", "zN", "zF", "H"):
            A, B = (np.asarray(x.toarray() if hasattr(x, "toarray") else x) for x in (a[key], b[key]))
            np.testing.assert_allclose(A, B, rtol=0, atol=1e-14, err_msg=key)


# --------------------------------------------------------------- 2. the ball on a welded plate
E_N, H_BALL, T_BALL = 0.5, 2e-3, 1.5


def _ball(kind, plane):
    """contact_ball's scene (m = 1, R = 0.1, centre at 1 m, e_N = 0.5, floor y = 0 or z = 0) with the floor
    ``plane``: "fixed" (SphereOnPlane), "ground" (the body-plane element on the ground) or "weld" (the
    body-plane element on a plate welded to the ground, turned, its plane given in the plate's axes)."""
    m = femb.Mechanism(f"ball_{plane}")
    R, mb = 0.1, 1.0
    if kind == "planar":
        m.add(RigidBody("ball", mb, 0.4 * mb * R * R, position=(0.0, 1.0)))
        m.add(Gravity((0.0, -9.81)))
        if plane == "fixed":
            m.add(SphereOnPlane("floor", "ball", radius=R, e_N=E_N))
            return m.compile()
        th, r = (0.4, np.array((0.3, -0.05))) if plane == "weld" else (0.0, np.zeros(2))
        if plane == "weld":
            m.add(RigidBody("plate", 5.0, 0.1, position=r, angle=th))
            m.add(Clamp("weld", "ground", "plate", at=r))
        Rt = _rot2(th).T
        m.add(SphereOnBodyPlane("floor", "ball", "plate" if plane == "weld" else "ground", radius=R,
                                plane_point=Rt @ -r, normal=Rt @ (0.0, 1.0), e_N=E_N))
        return m.compile()
    th = 0.4 * mb * R * R
    m.add(SpatialRigidBody("ball", mb, (th, th, th), position=(0.0, 0.0, 1.0)))
    m.add(SpatialGravity((0.0, 0.0, -9.81)))
    if plane == "fixed":
        m.add(SpatialSphereOnPlane("floor", "ball", radius=R, e_N=E_N))
        return m.compile()
    Ra, r = (quat_to_matrix(_quat(0)), np.array((0.3, -0.05, 0.02))) if plane == "weld" else (np.eye(3), np.zeros(3))
    if plane == "weld":
        m.add(SpatialRigidBody("plate", 5.0, (0.1, 0.2, 0.3), position=r, rotation=_quat(0)))
        m.add(FixedJoint("weld", "ground", "plate", at=r))
    m.add(SpatialSphereOnBodyPlane("floor", "ball", "plate" if plane == "weld" else "ground", radius=R,
                                   plane_point=Ra.T @ -r, normal=Ra.T @ (0.0, 0.0, 1.0), e_N=E_N))
    return m.compile()


def _ball_series(kind, res):
    names = ("x", "y", "theta") if kind == "planar" else ("x", "y", "z")
    return np.column_stack([res.series(f"ball.{a}")[0] for a in names]
                           + [res.series(f"ball.{a}_d")[0] for a in names])


def ball_runs(kind, compiled=None):
    """Runs of the three floors; returns {plane: result}."""
    return {p: simulate(_ball(kind, p), T_BALL, H_BALL, compiled=compiled) for p in ("fixed", "ground", "weld")}


@pytest.mark.parametrize("kind", ["planar", "spatial"])
def test_ball_on_a_welded_plate_bounces_as_on_the_fixed_plane(kind):
    """The bouncing ball of docs/contact.md §5: on the ground's plane the body-plane element gives the fixed-plane
    run to round-off; on a turned plate welded to the ground the same impacts and trajectory to the Newton
    tolerance.

    The weld adds the plate's coordinates and three (six) joint rows to each step's system, so its Newton
    iterations stop elsewhere within the tolerance tol = 1e-12 L (L = model length scale): the Newton test
    weighs the acceleration rows by h², which leaves an acceleration error up to tol/h² in a step. Over n
    steps that is n tol/h in the velocities and n² tol in the positions (n = 600 steps to t = 1.2 s: 3.3e-7 m/s,
    3.8e-7 m); measured 1.4e-8 s on the impact times, 2.2e-8 m (planar). After t = 1.2 s the ball's flights
    are shorter than the tolerances resolve (t∞ = 1.285 s), and the step of each later impact may differ.
    """
    runs = ball_runs(kind)
    ref, gnd, weld = runs["fixed"], runs["ground"], runs["weld"]
    exact = contact_ball.impact_times(10)
    for res in (ref, gnd, weld):
        assert res.status == "success"
        t_ev = np.array([e["t"] for e in res.events])
        assert t_ev.size >= 12
        assert np.abs(t_ev[:10] - exact).max() < 2e-6          # §5: within 2e-6 s of the closed form
        assert res.contact["gN"].min() >= -1e-10 * 0.1
    # ground: the same run
    np.testing.assert_allclose(_ball_series(kind, gnd), _ball_series(kind, ref), rtol=0, atol=1e-12)
    assert [e["t"] for e in gnd.events] == pytest.approx([e["t"] for e in ref.events], abs=1e-12)
    # welded plate: the same to the Newton tolerance, up to the tenth impact
    L = _ball(kind, "weld").length_scale
    n = int(np.ceil(exact[-1] / H_BALL))
    tol = 1e-12 * L
    dv, dq = n * tol / H_BALL, n * n * tol
    a, b = _ball_series(kind, ref)[:n + 1], _ball_series(kind, weld)[:n + 1]
    assert np.abs(a[:, :3] - b[:, :3]).max() <= dq
    assert np.abs(a[:, 3:] - b[:, 3:]).max() <= dv
    t_ref = np.array([e["t"] for e in ref.events[:10]])
    t_weld = np.array([e["t"] for e in weld.events[:10]])
    assert np.abs(t_ref - t_weld).max() <= dv / 9.81           # a velocity error dv shifts an impact by dv/g
    # the plate does not move; at the end the ball rests on it
    plate = ("plate.x", "plate.y", "plate.theta") if kind == "planar" else ("plate.x", "plate.y", "plate.z")
    for s in plate:
        v = weld.series(s)[0]
        assert np.abs(v - v[0]).max() < 1e-12
    assert abs(_ball_series(kind, weld)[-1, 1 if kind == "planar" else 2] - 0.1) < 1e-9


# --------------------------------------------------------------- 3. a free sphere hits a free plate
M_B, R_B, M_A, V_N0, GAP0, H_IMP = 1.0, 0.1, 3.0, -1.5, 0.0317, 1e-3
T_IMP = GAP0 / -V_N0


def _impact_scene(kind, e_N):
    """Ball (centred sphere, m = 1, R = 0.1) flying at the plate along −n with V_N0 relative to it; plate free,
    turned, its plane off its node (the contact point 0.12 m (and 0.07 m) off the plate's node along the
    plane, so the impulse turns it). In space the plate is turned and spins at 2 rad/s about its normal
    (n stays fixed before the impact); its inertia is isotropic, so that its free spin after the impact is
    exact in the scheme and the angular momentum is checked to round-off at every step. No gravity, μ = 0.
    Returns (mechanism, data)."""
    m = femb.Mechanism(f"impact_{kind}")
    if kind == "planar":
        th, Ja, va = 0.35, 0.05, np.array((0.2, -0.1))
        n = _rot2(th) @ (0.0, 1.0)
        t = np.array((n[1], -n[0]))
        pbar = np.array((0.05, 0.02))
        C0 = _rot2(th) @ pbar + 0.12 * t + (R_B + GAP0) * n
        vb = va + V_N0 * n
        m.add(RigidBody("plate", M_A, Ja, position=(0.0, 0.0), angle=th, velocity=va))
        m.add(RigidBody("ball", M_B, 0.4 * M_B * R_B ** 2, position=C0, velocity=vb, omega=3.0))
        m.add(SphereOnBodyPlane("hit", "ball", "plate", R_B, plane_point=pbar, normal=(0.0, 1.0), e_N=e_N))
        return m, dict(n=n, C0=C0, va=va, vb=vb, wa=0.0, Ja=Ja)
    Ra0, Ja, va = quat_to_matrix(_quat(0)), 0.05 * np.eye(3), np.array((0.2, -0.1, 0.05))
    n, t1, t2 = Ra0[:, 2], Ra0[:, 0], Ra0[:, 1]
    pbar = np.array((0.02, -0.01, 0.01))
    C0 = Ra0 @ pbar + 0.12 * t1 - 0.07 * t2 + (R_B + GAP0) * n
    vb, wa, wb = va + V_N0 * n, 2.0 * n, np.array((1.0, -2.0, 0.5))
    jb = 0.4 * M_B * R_B ** 2
    m.add(SpatialRigidBody("plate", M_A, np.diag(Ja), position=(0.0, 0.0, 0.0), rotation=_quat(0), velocity=va,
                           omega=Ra0.T @ wa))
    m.add(SpatialRigidBody("ball", M_B, (jb, jb, jb), position=C0, velocity=vb, omega=wb))
    m.add(SpatialSphereOnBodyPlane("hit", "ball", "plate", R_B, plane_point=pbar, normal=(0.0, 0.0, 1.0), e_N=e_N))
    return m, dict(n=n, C0=C0, va=va, vb=vb, wa=wa, wb=wb, Ja=Ja, Ra0=Ra0, jb=jb)


def _impact_closed_form(kind, d, e_N):
    """Velocities after the impact: at t* = GAP0/|V_N0| the plate's arm to the contact point is
    a = c − r_a (c = C − R n), with K = a × n the impulse's moment per unit along n:
        1/m* = 1/m_b + 1/m_a + K·I_a⁻¹K,   Λ = −(1 + e_N) m* V_N0   (V_N0 the normal relative velocity:
    the ball is centred, and in space ω_a ∥ n adds no normal velocity at c), and
        v_b' = v_b + Λn/m_b,  v_a' = v_a − Λn/m_a,  ω_a' = ω_a − Λ I_a⁻¹K  (ω_b unchanged: μ = 0 and the
    normal passes through the ball's centre); Stronge 2000, Ch. 3–4."""
    n = d["n"]
    C, ra = d["C0"] + d["vb"] * T_IMP, d["va"] * T_IMP
    a = C - R_B * n - ra
    if kind == "planar":
        K = _cross2(a, n)
        Iinv_K = K / d["Ja"]
        ms = 1.0 / (1.0 / M_B + 1.0 / M_A + K * Iinv_K)
    else:
        Ra = expm(d["wa"] * T_IMP) @ d["Ra0"]
        Ia = Ra @ d["Ja"] @ Ra.T
        K = np.cross(a, n)
        Iinv_K = np.linalg.solve(Ia, K)
        ms = 1.0 / (1.0 / M_B + 1.0 / M_A + K @ Iinv_K)
        d = dict(d, Ia=Ia)
    Lam = -(1.0 + e_N) * ms * V_N0
    return dict(vb=d["vb"] + Lam * n / M_B, va=d["va"] - Lam * n / M_A, wa=d["wa"] - Lam * Iinv_K, Lam=Lam, ms=ms,
                lost=0.5 * ms * (1.0 - e_N ** 2) * V_N0 ** 2, a=a)


def _momenta(kind, model, res, d):
    """Linear momentum, angular momentum about the origin and kinetic energy at every stored step."""
    ia, ib = model.node_index["plate"], model.node_index["ball"]
    ja, jb = model.node_vindex["plate"], model.node_vindex["ball"]
    P, L, E = [], [], []
    for q, u in zip(res.q, res.qd):
        if kind == "planar":
            ra, rb, va, vb = q[ia[:2]], q[ib[:2]], u[ja[:2]], u[jb[:2]]
            wa, wb = u[ja[2]], u[jb[2]]
            P.append(M_A * va + M_B * vb)
            L.append(M_A * _cross2(ra, va) + M_B * _cross2(rb, vb) + d["Ja"] * wa + 0.4 * M_B * R_B ** 2 * wb)
            E.append(0.5 * (M_A * va @ va + M_B * vb @ vb + d["Ja"] * wa ** 2 + 0.4 * M_B * R_B ** 2 * wb ** 2))
        else:
            ra, rb, va, vb = q[ia[:3]], q[ib[:3]], u[ja[:3]], u[jb[:3]]
            Oa, Ob = u[ja[3:6]], u[jb[3:6]]                     # body axes
            Ra = quat_to_matrix(q[ia[3:7]])
            Rb = quat_to_matrix(q[ib[3:7]])
            P.append(M_A * va + M_B * vb)
            L.append(M_A * np.cross(ra, va) + M_B * np.cross(rb, vb) + Ra @ (d["Ja"] @ Oa) + Rb @ (d["jb"] * Ob))
            E.append(0.5 * (M_A * va @ va + M_B * vb @ vb + Oa @ d["Ja"] @ Oa + d["jb"] * Ob @ Ob))
    return np.array(P), np.array(L), np.array(E)


def impact_run(kind, e_N, compiled=None):
    mech, d = _impact_scene(kind, e_N)
    model = mech.compile()
    res = simulate(model, T_IMP + 5 * H_IMP, H_IMP, compiled=compiled)
    return model, res, d


def impact_errors(kind, e_N):
    """The measured figures of :func:`test_impact_on_a_free_plate` and their scales."""
    model, res, d = impact_run(kind, e_N)
    ref = _impact_closed_form(kind, d, e_N)
    ia, ib = model.node_index["plate"], model.node_index["ball"]
    ja, jb = model.node_vindex["plate"], model.node_vindex["ball"]
    ev = [e for e in res.events if e["contact"] == "hit"]
    got, vN = {}, []
    for when in ("u_before", "u_after"):            # the velocities around the impact (its substep)
        u = ev[0][when]
        if kind == "planar":
            got[when] = dict(vb=u[jb[:2]], va=u[ja[:2]], wa=u[ja[2]], wb=u[jb[2]])
        else:                                       # ω in space axes (isotropic inertia: J ω, whatever R)
            Ra = expm(d["wa"] * T_IMP) @ d["Ra0"]
            got[when] = dict(vb=u[jb[:3]], va=u[ja[:3]], wa=Ra @ u[ja[3:6]], wb=u[jb[3:6]])
        g = got[when]
        vel_a = g["va"] + (g["wa"] * np.array((-ref["a"][1], ref["a"][0])) if kind == "planar"
                           else np.cross(g["wa"], ref["a"]))
        vN.append(d["n"] @ (g["vb"] - vel_a))       # the ball is centred: its material point at c moves with v_b
    P, L, E = _momenta(kind, model, res, d)
    kin = [_kinetic(kind, d, got[w]) for w in ("u_before", "u_after")]
    # The impact substep ends 1e-4 h after the impact; Newton's law and the impulse act along the normal
    # and arm of a state near it, where the plate has turned by at most φ = |ω_a'| 1e-4 h since the impact
    # (before it the normal does not turn and the contact point moves along n only).
    phi = float(np.linalg.norm(np.atleast_1d(ref["wa"]))) * 1e-4 * H_IMP
    a = got["u_after"]
    return dict(res=res, ref=ref, got=a, P=P, L=L, E=E, kin=kin, vN=vN, phi=phi, ev=ev,
                err=dict(vb=np.abs(a["vb"] - ref["vb"]).max(), va=np.abs(a["va"] - ref["va"]).max(),
                         wa=np.abs(np.atleast_1d(a["wa"] - ref["wa"])).max(),
                         wb=np.abs(np.atleast_1d(a["wb"] - got["u_before"]["wb"])).max()))


def _kinetic(kind, d, g):
    jb = 0.4 * M_B * R_B ** 2
    if kind == "planar":
        return 0.5 * (M_A * g["va"] @ g["va"] + M_B * g["vb"] @ g["vb"] + d["Ja"] * g["wa"] ** 2 + jb * g["wb"] ** 2)
    return 0.5 * (M_A * g["va"] @ g["va"] + M_B * g["vb"] @ g["vb"] + g["wa"] @ d["Ja"] @ g["wa"]
                  + jb * g["wb"] @ g["wb"])


@pytest.mark.parametrize("kind", ["planar", "spatial"])
@pytest.mark.parametrize("e_N", [0.0, 1.0])
def test_impact_exactly_at_the_end_of_a_step(kind, e_N, monkeypatch):
    """The same impact with the gap closing exactly at t = 20 h (0.02 s): found there, no error, the
    momentum kept through it. (While the elements were written, a first version of the impact test with
    this gap was seen to stop with "no consistent contact forces found" in space; not reproduced with the
    stepper as it is now, this keeps it so.)"""
    mod = sys.modules[__name__]
    monkeypatch.setattr(mod, "GAP0", 0.03)
    monkeypatch.setattr(mod, "T_IMP", 0.03 / -V_N0)
    assert T_IMP == pytest.approx(20 * H_IMP, abs=1e-15)
    model, res, d = impact_run(kind, e_N)
    ev = [e for e in res.events if e["contact"] == "hit"]
    assert ev and ev[0]["t"] == pytest.approx(0.02, abs=1e-12)
    assert ev[0]["v_after"] == pytest.approx(-e_N * V_N0, abs=1e-9)
    P, _, _ = _momenta(kind, model, res, d)
    assert np.abs(P - P[0]).max() < 1e-12
    assert res.contact["gN"].min() >= -1e-10 * model.length_scale


@pytest.mark.parametrize("kind", ["planar", "spatial"])
@pytest.mark.parametrize("e_N", [0.0, 1.0])
def test_impact_on_a_free_plate(kind, e_N):
    """A free ball hits a free body that carries the plane (no gravity, μ = 0): one impact at t* = GAP0/|V_N0|;
    linear momentum and angular momentum about the origin kept through the impact to round-off (the impulse
    acts on both bodies at the same point c, ±Λn); the velocities after it as the closed form
    (:func:`_impact_closed_form`) to 5 φ |Λ| (1 + |a|²m_b/I_a) / m_b, φ the plate's turn over the impact
    substep; Newton's law for the normal relative velocity of the material points at c; the kinetic energy
    kept (e_N = 1) or reduced by ½ m* V_N0² (e_N = 0)."""
    out = impact_errors(kind, e_N)
    res, ref, ev, phi = out["res"], out["ref"], out["ev"], out["phi"]
    assert ev[0]["t"] == pytest.approx(T_IMP, abs=1e-12)
    assert len(ev) == 1 or e_N == 0.0                       # e_N = 0: the closed contact may touch again
    assert ev[0]["v_before"] == pytest.approx(V_N0, abs=1e-12)
    P, L, E = out["P"], out["L"], out["E"]
    assert np.abs(P - P[0]).max() < 1e-12
    scale = 5.0 * phi * ref["Lam"] * 10.0 / M_B            # |a|² m_b / I_a < 9 for both plates
    k = int(np.searchsorted(res.t, T_IMP))                  # the step with the impact ends at res.t[k]
    assert np.abs(L[:k] - L[0]).max() < 1e-12               # free flight before
    if e_N == 1.0:                                           # free flight after (isotropic spatial plate: exact)
        assert np.abs(L[k:] - L[k]).max() < 1e-12
    # (e_N = 0: the contact stays closed and its force, internal, keeps L to the scheme's accuracy: 8e-10)
    assert np.abs(L[k] - L[0]).max() <= scale * M_B * 0.5    # the impulse: ±Λn at one point, lever < 0.5 m
    for key in ("vb", "va", "wa"):
        assert out["err"][key] <= scale, (key, out["err"][key], scale)
    assert out["err"]["wb"] < 1e-12                          # μ = 0, normal through the ball's centre
    assert ev[0]["P_N"] == pytest.approx(ref["Lam"], abs=scale * M_B)
    vm, vp = out["vN"]                                       # Newton's law, from the material points at c
    assert vm == pytest.approx(V_N0, abs=1e-12)
    assert vp == pytest.approx(-e_N * vm, abs=scale)
    lost = out["kin"][0] - out["kin"][1]
    assert lost == pytest.approx(ref["lost"], abs=scale * ref["Lam"])
    if e_N == 1.0:                                           # elastic and frictionless: energy kept at every step
        assert np.abs(E - E[0]).max() <= scale * ref["Lam"]
    assert res.contact["gN"].min() >= -1e-10 * R_B


# --------------------------------------------------------------- 4. Coulomb friction on a moving plate
MU_S, G_S, M_BLK, M_PLT, V_P0, W_BLK, H_BLK, H_S, T_S = 0.3, 9.81, 1.0, 2.0, 1.0, 0.2, 0.1, 1e-3, 0.4
T_STICK = V_P0 / (MU_S * G_S * (1.0 + M_BLK / M_PLT))
V_COMMON = M_PLT * V_P0 / (M_BLK + M_PLT)


def _sliding(kind):
    """A block (m = 1, 0.2 × 0.1 m, at rest) set on a plate (M = 2) that slides at 1 m/s on a frictionless
    support (a slider / prismatic joint to the ground along x); its two (four) bottom corners are contacts on
    the plate's plane with μ = 0.3."""
    m = femb.Mechanism(f"sliding_{kind}")
    w, hb = 0.5 * W_BLK, 0.5 * H_BLK
    if kind == "planar":
        m.add(RigidBody("plate", M_PLT, 0.1, position=(0.0, 0.0), velocity=(V_P0, 0.0)))
        m.add(Slider("support", "ground", "plate", axis=(1.0, 0.0), at=(0.0, 0.0)))
        m.add(RigidBody("block", M_BLK, M_BLK * (W_BLK ** 2 + H_BLK ** 2) / 12.0, position=(0.0, hb)))
        m.add(Gravity((0.0, -G_S)))
        for k, x in enumerate((-w, w)):
            m.add(SphereOnBodyPlane(f"c{k}", "block", "plate", 0.0, point=(x, -hb), mu=MU_S))
        return m
    from femb.elements import PrismaticJoint
    m.add(SpatialRigidBody("plate", M_PLT, (0.1, 0.1, 0.2), position=(0.0, 0.0, 0.0), velocity=(V_P0, 0.0, 0.0)))
    m.add(PrismaticJoint("support", "ground", "plate", at=(0.0, 0.0, 0.0), axis=(1.0, 0.0, 0.0)))
    jb = M_BLK * (W_BLK ** 2 + H_BLK ** 2) / 12.0
    m.add(SpatialRigidBody("block", M_BLK, (jb, jb, M_BLK * W_BLK ** 2 / 6.0), position=(0.0, 0.0, hb)))
    m.add(SpatialGravity((0.0, 0.0, -G_S)))
    for k, (x, y) in enumerate(((-w, -w), (w, -w), (w, w), (-w, w))):
        m.add(SpatialSphereOnBodyPlane(f"c{k}", "block", "plate", 0.0, point=(x, y, -hb), mu=MU_S))
    return m


def sliding_figures(kind, compiled=None):
    """The block's and the plate's velocities and positions along x against Coulomb's closed form."""
    model = _sliding(kind).compile()
    res = simulate(model, T_S, H_S, compiled=compiled)
    xb, vb = res.series("block.x")[0], res.series("block.x_d")[0]
    xp, vp = res.series("plate.x")[0], res.series("plate.x_d")[0]
    t = res.t
    a_b, a_p = MU_S * G_S, -MU_S * G_S * M_BLK / M_PLT
    slide = t <= T_STICK - H_S
    stick = t >= T_STICK + H_S
    out = dict(res=res, t=t, slide=slide, stick=stick, length_scale=model.length_scale,
               vb_slide=np.abs(vb[slide] - a_b * t[slide]).max(),
               vp_slide=np.abs(vp[slide] - V_P0 - a_p * t[slide]).max(),
               xb_slide=np.abs(xb[slide] - 0.5 * a_b * t[slide] ** 2).max(),
               xp_slide=np.abs(xp[slide] - V_P0 * t[slide] - 0.5 * a_p * t[slide] ** 2).max(),
               v_stick=max(np.abs(vb[stick] - V_COMMON).max(), np.abs(vp[stick] - V_COMMON).max()),
               # relative displacement while sliding: ∫ Δv dt = ½ V_P0 T_STICK
               dx_stick=np.abs(xp[stick] - xb[stick] - 0.5 * V_P0 * T_STICK).max(),
               momentum=np.abs(M_BLK * vb + M_PLT * vp - M_PLT * V_P0).max())
    return out


@pytest.mark.parametrize("kind", ["planar", "spatial"])
def test_block_on_a_moving_plate_slides_then_sticks(kind):
    """Coulomb friction on a body-fixed plane that moves. While the block slips, the friction force μ m g drives
    it forward and the plate back (the support has no friction along x): a_b = μ g, a_p = −μ g m/M, so the
    relative velocity falls from V_P0 at μ g (1 + m/M) and vanishes at t* = V_P0/(μ g (1 + m/M)) = 0.2265 s;
    from then on both move at V_c = M V_P0/(m + M) (momentum; no force is needed to keep them together), and
    the block has slid ½ V_P0 t* along the plate. Sliding phase to 1e-12 (constant forces: the scheme is exact);
    after t* the velocities to the Newton tolerance tol/h (measured 2.9e-11 m/s); the slid distance to
    μ g (1 + m/M) h², the error of the step in which the slip stops (slip–stick transitions are not located,
    docs/contact.md §8); momentum along x to 1e-12."""
    f = sliding_figures(kind)
    res = f["res"]
    assert res.status == "success" and f["slide"].sum() > 200 and f["stick"].sum() > 150
    for key in ("vb_slide", "vp_slide", "xb_slide", "xp_slide", "momentum"):
        assert f[key] < 1e-12, (key, f[key])
    assert f["v_stick"] <= 1e-12 * f["length_scale"] / H_S        # the stick law ξ_F = 0 to the Newton tolerance
    assert f["dx_stick"] <= MU_S * G_S * (1.0 + M_BLK / M_PLT) * H_S ** 2
    names = ("c0", "c1") if kind == "planar" else ("c0", "c1", "c2", "c3")
    for c in names:
        st = np.asarray(res.contact_state(c))
        assert set(st[1:][f["slide"][1:]]) == {"slip"} and set(st[f["stick"]]) == {"stick"}
    # the friction forces on the block while it slides: μ times the normal forces, forward (+x)
    lam_N = sum(res.series(f"{c}.lambda_N")[0] for c in names)
    s = f["slide"] & (f["t"] > 0.0)
    np.testing.assert_allclose(lam_N[s], M_BLK * G_S, rtol=1e-12)
    if kind == "planar":            # t = (n_y, −n_x) = +x
        fx = sum(res.series(f"{c}.lambda_F")[0] for c in names)
    else:                           # t₁, t₂ of tangents(e_z), fixed in the plate (not turning here)
        from femb.elements.contact import tangents
        t1, t2 = tangents(np.array((0.0, 0.0, 1.0)))
        fx = sum(t1[0] * res.series(f"{c}.lambda_F1")[0] + t2[0] * res.series(f"{c}.lambda_F2")[0] for c in names)
    np.testing.assert_allclose(fx[s], MU_S * M_BLK * G_S, rtol=1e-12)
    assert res.contact["gN"].min() >= -1e-10 * H_BLK


# --------------------------------------------------------------- 5. bad inputs
def _mech(kind):
    m = femb.Mechanism("bad")
    if kind == "planar":
        m.add(RigidBody("plate", 1.0, 0.1, position=(0.0, 0.0)))
        m.add(RigidBody("ball", 1.0, 0.1, position=(0.0, 0.5), points={"tip": (0.0, -0.1)}))
        m.add(SpringDamper("spring", "plate", "ball", 10.0, 0.0))
    else:
        m.add(SpatialRigidBody("plate", 1.0, (0.1, 0.1, 0.1), position=(0.0, 0.0, 0.0)))
        m.add(SpatialRigidBody("ball", 1.0, (0.1, 0.1, 0.1), position=(0.0, 0.0, 0.5), points={"tip": (0.0, 0.0, -0.1)}))
    return m


PLANAR_BAD = [(dict(normal=(0.0, 0.0)), "normal"), (dict(radius=-0.1), "radius"), (dict(radius=float("nan")), "radius"),
              (dict(e_N=1.5), "e_N"), (dict(mu=-0.2), "mu"), (dict(e_F=2.0), "e_F"), (dict(point=(0.0, 1.0, 2.0)), "point"),
              (dict(plane_point=(1.0,)), "plane_point"), (dict(point="nope"), "point"),
              (dict(plane_point="nope"), "plane_point"), (dict(normal=(0.0, 1.0, 0.0)), "normal")]
SPATIAL_BAD = [(dict(normal=(0.0, 0.0, 0.0)), "normal"), (dict(radius=-0.1), "radius"), (dict(e_N=-0.5), "e_N"),
               (dict(mu=float("inf")), "mu"), (dict(point=(0.0, 1.0)), "point"), (dict(plane_point="nope"), "plane_point"),
               (dict(tangent=(0.0, 0.0, 2.0)), "tangent"), (dict(tangent=(1.0, 0.0)), "tangent")]


@pytest.mark.parametrize("kind, kw, what", [("planar",) + c for c in PLANAR_BAD] + [("spatial",) + c for c in SPATIAL_BAD])
def test_bad_parameters_are_model_errors(kind, kw, what):
    cls = SphereOnBodyPlane if kind == "planar" else SpatialSphereOnBodyPlane
    with pytest.raises(ModelError, match=f"{cls.__name__} 'cX'.*{what}"):
        m = _mech(kind)
        m.add(cls("cX", "ball", "plate", **dict(dict(radius=0.1), **kw)))
        m.compile()


@pytest.mark.parametrize("body, plane_body, what", [
    ("ball", "ball", "body and plane_body are the same"),
    ("ball", "nobody", "plane_body refers to 'nobody'"),
    ("nobody", "plate", "body refers to 'nobody'"),
    ("ball", "spring", "plane_body must be a body"),        # an element that is not a body (no node)
])
def test_bad_bodies_are_model_errors(body, plane_body, what):
    m = _mech("planar")
    m.add(SphereOnBodyPlane("cX", body, plane_body, 0.1))
    with pytest.raises(ModelError, match=f"SphereOnBodyPlane 'cX'.*{what}"):
        m.compile()


def test_planar_and_spatial_bodies_are_not_mixed():
    """The planar element on a spatial body, the spatial one on a planar body: ModelErrors naming the element,
    the role and the type to use."""
    m = _mech("spatial")
    m.add(SphereOnBodyPlane("cX", "ball", "plate", 0.1))
    with pytest.raises(ModelError, match="SphereOnBodyPlane 'cX'.*'ball' is a spatial body"):
        m.compile()
    m = _mech("planar")
    m.add(SpatialSphereOnBodyPlane("cX", "ball", "plate", 0.1))
    with pytest.raises(ModelError, match="SpatialSphereOnBodyPlane 'cX'.*body = 'ball' is a planar body.*SphereOnBodyPlane"):
        m.compile()
    m = _mech("spatial")
    m.add(SpatialSphereOnBodyPlane("cX", "plate", "plate", 0.1))
    with pytest.raises(ModelError, match="SpatialSphereOnBodyPlane 'cX'.*same"):
        m.compile()


# --------------------------------------------------------------- 6. both loops
def _same_run(a, b):
    """Every stored output and every event of the two runs equal to 1e-12 (relative to the largest value, at
    least 1), as tests/test_contact_loop.py compares them."""
    def close(x, y, what):
        x, y = np.atleast_1d(np.asarray(x, dtype=float)), np.atleast_1d(np.asarray(y, dtype=float))
        assert x.shape == y.shape, what
        scale = max(1.0, float(np.max(np.abs(x), initial=0.0)))
        assert float(np.max(np.abs(x - y), initial=0.0)) <= 1e-12 * scale, what
    for key in ("t", "q", "qd", "qdd", "lam"):
        close(getattr(a, key), getattr(b, key), key)
    for key, v in a.contact.items():
        close(v, b.contact[key], key)
    assert len(a.events) == len(b.events)
    for e, f in zip(a.events, b.events):
        assert e["contact"] == f["contact"] and e["step"] == f["step"]
        for key in ("t", "v_before", "v_after", "Lambda_N", "P_N", "u_before", "u_after"):
            close(e[key], f[key], f"event {key}")
    np.testing.assert_array_equal(a.newton_iterations, b.newton_iterations)
    assert a.stats == b.stats


@pytest.mark.parametrize("kind", ["planar", "spatial"])
def test_compiled_and_python_loops_agree(kind):
    """The impact on a free plate (e_N = 0: impact, then a closed contact) and the block on the moving plate
    through the compiled loop and the Python loop."""
    _, a, _ = impact_run(kind, 0.0, compiled=True)
    _, b, _ = impact_run(kind, 0.0, compiled=False)
    _same_run(a, b)
    model = _sliding(kind).compile()
    a = simulate(model, 0.3, 2e-3, compiled=True)
    b = simulate(model, 0.3, 2e-3, compiled=False)
    _same_run(a, b)


# --------------------------------------------------------------- 7. in VTK and pictures
@pytest.mark.parametrize("kind", ["planar", "spatial"])
def test_contact_block_does_the_work_of_the_contact_force(kind):
    """The output block (femb.io.frames): the force F written at the contact point c, applied there to the ball
    and −F to the plate, equals the generalized contact force W_Nᵀλ_N + W_Fᵀλ_F component by component; its
    normal part is λ_N; the gap is the kernel's (as tests/test_contact_pictures.py for the other types)."""
    from femb.io.frames import model_blocks
    model = BUILD[kind](OFFSETS[kind]["penetrated"])
    st = model.initial_state()
    rng = np.random.default_rng(3)
    lam_N, lam_F = rng.uniform(0.5, 2.0, model.n_contacts), rng.uniform(-1.0, 1.0, model.n_friction)
    ev = assemble.evaluate(model, st.t, st.q, st.qd, dense=True)
    gen = ev["WN"].T @ lam_N + ev["WF"].T @ lam_F
    blocks = model_blocks(model, st.t, st.q, st.qd, np.zeros(model.nc), contact=(np.ones(1), lam_N, lam_F))
    blk = next(b for b in blocks if "contact_force" in b.point_data)
    c, F, n = blk.points[0], blk.point_data["contact_force"][0], blk.point_data["contact_normal"][0]
    want = np.zeros(model.nq)
    for body, sign in (("ball", 1.0), ("plate", -1.0)):
        i, j = model.node_index[body], model.node_vindex[body]
        if kind == "planar":
            r = np.array((st.q[i[0]], st.q[i[1]], 0.0))
            want[j] = sign * np.array((F[0], F[1], np.cross(c - r, F)[2]))
        else:
            r, R = st.q[i[:3]], quat_to_matrix(st.q[i[3:7]])
            want[j] = sign * np.concatenate((F, R.T @ np.cross(c - r, F)))
    np.testing.assert_allclose(want, gen, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(F @ n, lam_N[0], rtol=1e-12)
    np.testing.assert_allclose(blk.point_data["gap"], ev["gN"], rtol=0, atol=1e-15)

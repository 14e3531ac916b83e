"""SpatialSpherePair: two spheres on spatial bodies in the nonsmooth contact scheme (docs/contact.md §2).

1. The kernel against finite differences (W_N, ζ, H) at open and penetrated states with rotated
   bodies and sphere centres off the nodes, and W_F against the slip velocity computed here from the
   rigid-body velocities of the two surface points.
2. Head-on impact of two free spheres: Newton's impact law with conservation of momentum, and the
   energy the impact takes out, compiled loop and Python loop.
3. Oblique impact with Coulomb friction (plastic, e_N = 0): sliding through the impact (small μ) and
   sticking at it (large μ), against the closed forms derived below.
4. A sphere resting on a sphere fixed in space under gravity.
5. Bad inputs: ModelErrors that name the element and the parameter; undefined geometry.

Closed forms: Newton's law for the collision of two spheres and the plastic oblique impact with
Coulomb friction (W. Goldsmith, Impact, Arnold 1960, Ch. 2 and Ch. 4; W. J. Stronge, Impact
Mechanics, Cambridge University Press 2000, Ch. 3 and Ch. 5: for two spheres the slip direction
does not change during the impact, so the impulse-level Coulomb law of the scheme and the
incremental one of the textbooks agree).
"""
import numpy as np
import pytest

import femb
from femb.base.rotations import quat_to_matrix
from femb.contact import assemble, check_contact_kernels, simulate
from femb.elements import RigidBody, SpatialGravity, SpatialRigidBody
from femb.elements.contact import SpatialSpherePair
from femb.errors import ContactError, ModelError, ParameterError

ROT = [np.array((0.9, 0.3, -0.4, 0.1)), np.array((0.2, -0.5, 0.7, 0.3))]


def _quat(k):
    return ROT[k] / np.linalg.norm(ROT[k])


# --------------------------------------------------------------- 1. the kernel
def _general(offset):
    """Two rotated bodies with spheres off their nodes; ``offset`` moves b (open: gap > 0, or penetrated)."""
    m = femb.Mechanism("sphere_pair")
    m.add(SpatialRigidBody("a", 1.0, (0.1, 0.2, 0.3), position=(0.1, 0.3, 0.5), rotation=_quat(0)))
    m.add(SpatialRigidBody("b", 2.0, (0.2, 0.1, 0.3), position=np.array((0.1, 0.3, 0.5)) + offset,
                           rotation=_quat(1)))
    m.add(SpatialSpherePair("pair", "a", "b", 0.1, 0.15, point_a=(0.05, -0.02, 0.03), point_b=(-0.03, 0.04, 0.01),
                            mu=0.2))
    return m.compile()


OFFSETS = {"open": (0.3, 0.2, -0.1), "penetrated": (0.12, 0.08, -0.05)}


@pytest.mark.parametrize("state", sorted(OFFSETS))
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_kernel_matches_finite_differences(state, seed):
    """W_N = ∂g_N/∂q, ζ = (W v)_q v and H = ∂(Wᵀλ)/∂q at random moved states, open and penetrated."""
    model = _general(OFFSETS[state])
    gN = assemble.evaluate(model, 0.0, model.q0, np.zeros(model.nq))["gN"][0]
    assert (gN > 0.0) == (state == "open")
    report = check_contact_kernels(model, seed=seed, move=0.1)
    assert report.ok, str(report)
    assert len(report.checks) == 3


def _surface_velocities(model, q, u):
    """Velocities of b's material point at c_b − R_b n and of a's at c_a + R_a n, computed from the
    rigid-body motions (v + ω × arm, ω = R Ω), and the unit normal n."""
    pair = next(g for g in model.contact_groups).elements[0]
    ra, Ra = q[0:3], quat_to_matrix(q[3:7])
    rb, Rb = q[7:10], quat_to_matrix(q[10:14])
    ca, cb = ra + Ra @ pair.sa, rb + Rb @ pair.sb
    n = (cb - ca) / np.linalg.norm(cb - ca)
    va = u[0:3] + np.cross(Ra @ u[3:6], Ra @ pair.sa + pair.Ra * n)
    vb = u[6:9] + np.cross(Rb @ u[9:12], Rb @ pair.sb - pair.Rb * n)
    return va, vb, n


def test_slip_rows_are_the_relative_velocity_of_the_surface_points():
    """γ_F = W_F v = (t₁, t₂)·(v_b − v_a) at the surface points, ġ_N = n·(v_b − v_a); (t₁, t₂, n)
    right-handed."""
    model = _general(OFFSETS["open"])
    rng = np.random.default_rng(7)
    from femb.elements.contact import SpatialSpherePair as T
    for _ in range(3):
        q = model.compose(model.q0, 0.3 * rng.standard_normal(model.nq))
        u = rng.standard_normal(model.nq)
        ev = assemble.evaluate(model, 0.0, q, u, dense=True)
        va, vb, n = _surface_velocities(model, q, u)
        g = next(iter(model.contact_groups))
        _, n2, Tt, gap = T.contact_frames(g.P, model.ext(q)[g.xdofs])
        t1, t2 = Tt[0]
        np.testing.assert_allclose(n2[0], n, rtol=0, atol=1e-14)
        np.testing.assert_allclose(np.cross(t1, t2), n, rtol=0, atol=1e-14)
        assert abs(t1 @ n) < 1e-14 and abs(t2 @ n) < 1e-14 and abs(t1 @ t2) < 1e-14
        np.testing.assert_allclose(ev["WF"] @ u, [t1 @ (vb - va), t2 @ (vb - va)], rtol=1e-13, atol=1e-13)
        np.testing.assert_allclose(ev["WN"] @ u, [n @ (vb - va)], rtol=1e-13, atol=1e-13)
        np.testing.assert_allclose(gap, ev["gN"], rtol=0, atol=1e-15)


def test_tangents_turn_with_the_normal():
    """The tangent basis is the initial one rotated with n: at the initial state t₁, t₂ are the fixed f₁, f₂."""
    model = _general(OFFSETS["open"])
    g = next(iter(model.contact_groups))
    _, n, Tt, _ = SpatialSpherePair.contact_frames(g.P, model.ext(model.q0)[g.xdofs])
    np.testing.assert_allclose(n[0], g.P[0, 14:17], atol=1e-15)
    np.testing.assert_allclose(Tt[0, 0], g.P[0, 8:11], atol=1e-15)
    np.testing.assert_allclose(Tt[0, 1], g.P[0, 11:14], atol=1e-15)


# --------------------------------------------------------------- 2. head-on impact
M_A, M_B, R_A, R_B = 1.0, 2.5, 0.1, 0.15
N_HEAD = np.array((1.0, 2.0, 2.0)) / 3.0            # line of centres (from a to b), not along an axis


def _inertia(m, R):
    th = 0.4 * m * R * R                            # homogeneous sphere: (2/5) m R²
    return (th, th, th)


def _two_spheres(name, pos_b, v_a, v_b, w_a=(0.0, 0.0, 0.0), w_b=(0.0, 0.0, 0.0), e_N=0.0, mu=0.0):
    m = femb.Mechanism(name)
    m.add(SpatialRigidBody("a", M_A, _inertia(M_A, R_A), position=(0.0, 0.0, 0.0), velocity=v_a, omega=w_a))
    m.add(SpatialRigidBody("b", M_B, _inertia(M_B, R_B), position=pos_b, velocity=v_b, omega=w_b,
                           rotation=_quat(1)))
    m.add(SpatialGravity((0.0, 0.0, 0.0)))          # no gravity (the same element types as test 4: one compile)
    m.add(SpatialSpherePair("pair", "a", "b", R_A, R_B, e_N=e_N, mu=mu))
    return m


def _omega_space(res, k, body):
    q, u = res.q[k], res.qd[k]
    j = 0 if body == "a" else 7
    i = 0 if body == "a" else 6
    return quat_to_matrix(q[j + 3:j + 7]) @ u[i + 3:i + 6]


@pytest.mark.parametrize("e_N", [0.5, 1.0])
def test_head_on_impact_follows_newtons_law(e_N):
    """Velocities after the impact and the energy it takes out, against the closed form:

    the impulse Λ on b along n (−Λ on a), with 1/m* = 1/m_a + 1/m_b and v_rel = (v_b − v_a)·n < 0:
    Newton's law v_rel⁺ = −e_N v_rel and momentum give Λ = −(1 + e_N) m* v_rel,
    v_a' = v_a − Λ n / m_a, v_b' = v_b + Λ n / m_b, and the kinetic energy lost is
    ½ m* (1 − e_N²) v_rel² (Goldsmith 1960, Ch. 2; Stronge 2000, §3.1).
    """
    v_a, v_b = 1.2 * N_HEAD, -0.8 * N_HEAD
    gap0, h, t_end = 0.05, 1e-3, 0.06
    pos_b = (R_A + R_B + gap0) * N_HEAD
    mech = _two_spheres("head_on", pos_b, v_a, v_b, e_N=e_N)
    runs = {c: simulate(mech.compile(), t_end, h, compiled=c) for c in (None, False)}
    vrel = (v_b - v_a) @ N_HEAD
    ms = M_A * M_B / (M_A + M_B)
    Lam = -(1.0 + e_N) * ms * vrel
    va1, vb1 = v_a - Lam * N_HEAD / M_A, v_b + Lam * N_HEAD / M_B
    t_impact = gap0 / -vrel
    for c, res in runs.items():
        ev = [e for e in res.events if e["contact"] == "pair"]
        assert len(ev) == 1, (c, ev)
        assert ev[0]["t"] == pytest.approx(t_impact, abs=1e-12)
        np.testing.assert_allclose(res.qd[-1, 0:3], va1, rtol=0, atol=1e-12)
        np.testing.assert_allclose(res.qd[-1, 6:9], vb1, rtol=0, atol=1e-12)
        assert np.abs(res.qd[-1, 3:6]).max() < 1e-12 and np.abs(res.qd[-1, 9:12]).max() < 1e-12   # no spin
        assert ev[0]["v_after"] == pytest.approx(-e_N * vrel, abs=1e-12)
        lost = 0.5 * ms * (1.0 - e_N ** 2) * vrel ** 2
        E = res.energy()
        assert E["contact_normal"][-1] == pytest.approx(lost, abs=1e-12)
        assert abs(E["contact_friction"][-1]) < 1e-15           # μ = 0: no friction work (to round-off)
        ke = [0.5 * (M_A * res.qd[k, 0:3] @ res.qd[k, 0:3] + M_B * res.qd[k, 6:9] @ res.qd[k, 6:9]) for k in (0, -1)]
        assert ke[0] - ke[1] == pytest.approx(lost, abs=1e-12)
        assert res.contact["gN"].min() >= -1e-10 * R_A
    a, b = runs[None], runs[False]
    assert a.t.shape == b.t.shape
    np.testing.assert_allclose(a.q, b.q, rtol=0, atol=1e-12)
    np.testing.assert_allclose(a.qd, b.qd, rtol=0, atol=1e-12)
    np.testing.assert_allclose(a.contact["P_N"], b.contact["P_N"], rtol=0, atol=1e-12)


# --------------------------------------------------------------- 3. oblique impact with friction
OBL = dict(pos_b=(0.42, 0.09, 0.05), v_a=(0.3, 0.1, 0.0), v_b=(-1.5, 0.0, 0.1), w_a=(1.0, -2.0, 3.0),
           w_b=(0.0, 4.0, -1.0))


def _oblique_before():
    """Impact time, normal and pre-impact slip of the oblique case (straight free flights).

    The centres move on straight lines (no forces, isotropic inertia: ω constant), so the impact is
    at the first root of |d₀ + V t| = R_a + R_b, d₀ = c_b − c_a, V = v_b − v_a."""
    d0 = np.array(OBL["pos_b"])
    V = np.array(OBL["v_b"]) - np.array(OBL["v_a"])
    L = R_A + R_B
    a, b, c = V @ V, 2.0 * d0 @ V, d0 @ d0 - L * L
    t = (-b - np.sqrt(b * b - 4.0 * a * c)) / (2.0 * a)
    n = (d0 + V * t) / L
    return t, n


def _relative_surface_velocity(n, va, vb, wa, wb):
    """Velocity of b's surface point (arm −R_b n) relative to a's (arm +R_a n), ω in space axes."""
    return vb + np.cross(wb, -R_B * n) - va - np.cross(wa, R_A * n)


def _oblique_closed_form(mu):
    """Velocities after the plastic (e_N = 0) impact with Coulomb friction, and whether it sticks.

    Impulse Λ = Λ_N n + Λ_T on b at its contact point, −Λ on a; J = (2/5) m R² for each sphere:
      Δv_b = Λ/m_b,  Δω_b = (−R_b n × Λ)/J_b,   Δv_a = −Λ/m_a,  Δω_a = −(R_a n × Λ)/J_a.
    The relative velocity of the contact points V = v_b − ω_b × R_b n − v_a − ω_a × R_a n changes by
      ΔV = Λ(1/m_a + 1/m_b) + Λ_T (R_a²/J_a + R_b²/J_b)   [(n × Λ) × n = Λ_T]
         = Λ_N n / m* + (7/2) Λ_T / m*,   1/m* = 1/m_a + 1/m_b   [R²/J = 5/(2m)],
    so the normal and tangential problems decouple. e_N = 0: V_N⁺ = 0, Λ_N = −m* V_N⁻.
    Sticking (V_T⁺ = 0, e_F = 0) needs Λ_T = −(2/7) m* V_T⁻ inside the cone, (2/7)|V_T⁻| ≤ μ|V_N⁻|;
    otherwise it slides with Λ_T = −μ Λ_N V_T⁻/|V_T⁻| (ΔV_T ∥ Λ_T: the slip keeps its direction),
    V_T⁺ = V_T⁻ (1 − (7/2) μ Λ_N /(m* |V_T⁻|)) (Stronge 2000, §5.1; Goldsmith 1960, Ch. 4).
    """
    _, n = _oblique_before()
    va, vb = np.array(OBL["v_a"]), np.array(OBL["v_b"])
    wa, wb = np.array(OBL["w_a"]), np.array(OBL["w_b"])      # body = space axes for a; ω_b = R_b Ω_b
    wb = quat_to_matrix(_quat(1)) @ wb
    V = _relative_surface_velocity(n, va, vb, wa, wb)
    VN = V @ n
    VT = V - VN * n
    ms = M_A * M_B / (M_A + M_B)
    LN = -ms * VN
    stick = 2.0 / 7.0 * np.linalg.norm(VT) <= mu * LN / ms
    LT = -2.0 / 7.0 * ms * VT if stick else -mu * LN * VT / np.linalg.norm(VT)
    Lam = LN * n + LT
    Ja, Jb = 0.4 * M_A * R_A ** 2, 0.4 * M_B * R_B ** 2
    out = dict(va=va - Lam / M_A, vb=vb + Lam / M_B, wa=wa - np.cross(R_A * n, Lam) / Ja,
               wb=wb + np.cross(-R_B * n, Lam) / Jb, LN=LN, LT=LT, VT=VT, VN=VN, n=n)
    return out, bool(stick)


@pytest.mark.parametrize("mu, sticks", [(0.05, False), (1.0, True)])
def test_oblique_impact_obeys_coulomb(mu, sticks):
    """Plastic oblique impact of two spinning spheres: sliding through it (μ = 0.05) or sticking (μ = 1)."""
    ref, stick = _oblique_closed_form(mu)
    assert stick == sticks                          # the two cases are what they claim to be
    t_imp, n = _oblique_before()
    mech = _two_spheres("oblique", OBL["pos_b"], OBL["v_a"], OBL["v_b"], OBL["w_a"], OBL["w_b"], e_N=0.0, mu=mu)
    h = 1e-4
    res = simulate(mech.compile(), t_imp + 5 * h, h)
    ev = [e for e in res.events if e["contact"] == "pair"]
    assert len(ev) == 1 and ev[0]["t"] == pytest.approx(t_imp, abs=1e-12)
    k = int(np.searchsorted(res.t, t_imp))          # the step with the impact ends at res.t[k]
    va, vb = res.qd[k, 0:3], res.qd[k, 6:9]
    wa, wb = _omega_space(res, k, "a"), _omega_space(res, k, "b")
    # The impact substep ends d = 1e-4 h after the impact, where the line of centres has turned by
    # φ = |V_T| d / (R_a + R_b) ≈ 2e-8 rad; Newton's law and Coulomb act along that normal, so each
    # velocity differs from the closed form by O(φ |Λ|) / m (ω: O(φ R |Λ|) / J), the normal impulse by
    # O(φ) relative, the tangential one (of size μ Λ_N, projected here on the closed form's n) by
    # O(φ/μ) relative. Measured at h = 1e-4 s: at most 3.1 times these scales; allowed: 5.
    Lam = np.hypot(ref["LN"], np.linalg.norm(ref["LT"]))
    phi = np.linalg.norm(ref["VT"]) * 1e-4 * h / (R_A + R_B)
    scales = (phi * Lam / M_A, phi * Lam / M_B, phi * R_A * Lam / (0.4 * M_A * R_A ** 2),
              phi * R_B * Lam / (0.4 * M_B * R_B ** 2))
    for got, want, sc in zip((va, vb, wa, wb), (ref["va"], ref["vb"], ref["wa"], ref["wb"]), scales):
        np.testing.assert_allclose(got, want, rtol=0, atol=5.0 * sc)
    assert ev[0]["P_N"] == pytest.approx(ref["LN"], rel=5.0 * phi)
    # Coulomb at impulse level, from the momentum b gained at the impact (no other force acts)
    P = M_B * (vb - res.qd[k - 1, 6:9])
    PN = P @ n
    PT = P - PN * n
    assert PN == pytest.approx(ref["LN"], rel=5.0 * phi)
    if sticks:
        assert np.linalg.norm(PT) < mu * PN
        # after the impact: no relative velocity of the contact points, spin terms ω × R n included
        Vp = _relative_surface_velocity(n, va, vb, wa, wb)
        assert np.linalg.norm(Vp - (Vp @ n) * n) < 5.0 * phi * abs(ref["VN"])
    else:
        assert np.linalg.norm(PT) == pytest.approx(mu * PN, rel=5.0 * phi / mu)
        # the friction impulse on b opposes the slip before the impact
        np.testing.assert_allclose(PT / np.linalg.norm(PT), -ref["VT"] / np.linalg.norm(ref["VT"]),
                                   atol=5.0 * phi / mu)
        Vp = _relative_surface_velocity(n, va, vb, wa, wb)     # still slipping, the same way, slower
        VTp = Vp - (Vp @ n) * n
        assert VTp @ ref["VT"] > 0.0 and np.linalg.norm(VTp) < np.linalg.norm(ref["VT"])
    assert res.contact["gN"].min() >= -1e-10 * R_A


# --------------------------------------------------------------- 4. a sphere resting on a fixed sphere
def test_sphere_rests_on_a_fixed_sphere():
    """A sphere on top of a sphere fixed in space (the ground's): at rest, gap ≥ −1e-10 R, λ_N = m g."""
    m, R, R0, g = 0.7, 0.1, 0.2, 9.81
    mech = femb.Mechanism("stack")
    mech.add(SpatialRigidBody("ball", m, _inertia(m, R), position=(0.3, -0.1, 0.5 + R0 + R)))
    mech.add(SpatialGravity((0.0, 0.0, -g)))
    mech.add(SpatialSpherePair("stack", "ground", "ball", R0, R, point_a=(0.3, -0.1, 0.5), mu=0.3))
    model = mech.compile()
    res = simulate(model, 0.5, 1e-3)
    gN = res.contact["gN"][:, 0]
    assert gN.min() >= -1e-10 * R and np.abs(gN).max() < 1e-12
    np.testing.assert_allclose(res.contact["lam_N"][1:, 0], m * g, rtol=1e-12)
    np.testing.assert_allclose(res.q[:, :3], np.tile(model.q0[:3], (res.t.size, 1)), rtol=0, atol=1e-12)
    assert np.abs(res.qd).max() < 1e-12
    assert set(res.contact_state("stack")[1:]) == {"stick"}


# --------------------------------------------------------------- 5. bad inputs
@pytest.mark.parametrize("kw, what", [
    (dict(radius_a=-0.1), "radius_a"), (dict(radius_b=float("nan")), "radius_b"),
    (dict(radius_a=0.0, radius_b=0.0), "radius_a"), (dict(e_N=1.5), "e_N"), (dict(mu=-0.2), "mu"),
    (dict(e_F=-1.0), "e_F"), (dict(point_a=(0.0, 1.0)), "point_a"), (dict(point_b="abc"), "point_b"),
])
def test_bad_parameters_are_model_errors(kw, what):
    args = dict(radius_a=0.1, radius_b=0.1)
    args.update(kw)
    with pytest.raises(ModelError, match=what) as err:
        m = femb.Mechanism("bad")
        m.add(SpatialRigidBody("a", 1.0, (0.1, 0.1, 0.1), position=(0.0, 0.0, 0.0)))
        m.add(SpatialRigidBody("b", 1.0, (0.1, 0.1, 0.1), position=(0.5, 0.0, 0.0)))
        m.add(SpatialSpherePair("pairX", "a", "b", **args))
        m.compile()
    assert "pairX" in str(err.value)


def test_bad_bodies_are_model_errors():
    m = femb.Mechanism("planar")
    m.add(RigidBody("disc", 1.0, 0.01, position=(0.0, 0.0)))
    m.add(SpatialRigidBody("b", 1.0, (0.1, 0.1, 0.1), position=(0.5, 0.0, 0.0)))
    m.add(SpatialSpherePair("pairX", "disc", "b", 0.1, 0.1))
    with pytest.raises(ModelError, match="pairX.*a = 'disc' is a planar body"):
        m.compile()
    m = femb.Mechanism("same")
    m.add(SpatialRigidBody("b", 1.0, (0.1, 0.1, 0.1), position=(0.5, 0.0, 0.0)))
    m.add(SpatialSpherePair("pairX", "b", "b", 0.1, 0.1, point_b=(0.3, 0.0, 0.0)))
    with pytest.raises(ModelError, match="pairX.*same"):
        m.compile()
    m = femb.Mechanism("missing")
    m.add(SpatialRigidBody("b", 1.0, (0.1, 0.1, 0.1), position=(0.5, 0.0, 0.0)))
    m.add(SpatialSpherePair("pairX", "nobody", "b", 0.1, 0.1))
    with pytest.raises(ModelError, match="pairX.*nobody"):
        m.compile()


def test_coincident_centres_are_refused_and_never_a_silent_nan():
    """Centres that coincide: a ModelError at compile time; at a later state the kernel gives NaN
    (no normal), and the diagnosis of a failed step names the pair."""
    m = femb.Mechanism("coincide")
    m.add(SpatialRigidBody("a", 1.0, (0.1, 0.1, 0.1), position=(0.0, 0.0, 0.0)))
    m.add(SpatialRigidBody("b", 1.0, (0.1, 0.1, 0.1), position=(0.2, 0.0, 0.0)))
    m.add(SpatialSpherePair("pairX", "a", "b", 0.1, 0.1, point_b=(-0.2, 0.0, 0.0)))
    with pytest.raises(ModelError, match="pairX.*coincide"):
        m.compile()
    model = _general(OFFSETS["open"])
    g = next(iter(model.contact_groups))
    el = g.elements[0]
    q = model.q0.copy()
    Ra, Rb = quat_to_matrix(q[3:7]), quat_to_matrix(q[10:14])
    q[7:10] = q[0:3] + Ra @ el.sa - Rb @ el.sb                   # b's centre on a's
    ev = assemble.evaluate(model, 0.0, q, np.zeros(model.nq), jac=True)
    assert np.isnan(ev["gN"]).all() and np.isnan(ev["WN"].toarray()).all() and np.isnan(ev["zF"]).all()
    from femb.contact.simulate import geometry_problems
    (name, why), = geometry_problems(model, q)
    assert name == "pair" and "coincide" in why


def _carried_round(gap, omega=np.pi):
    """A sphere (R 0.05) on an arm spinning about z at ``omega`` carried round a sphere fixed in space
    (R 0.1) at a constant ``gap``: open all the way; its normal reaches the opposite of its initial
    direction at t = π/ω."""
    mech = femb.Mechanism("round")
    mech.add(SpatialRigidBody("arm", 1.0, (0.1, 0.1, 0.1), omega=(0.0, 0.0, omega)))
    mech.add(SpatialGravity((0.0, 0.0, 0.0)))
    mech.add(SpatialSpherePair("pairX", "ground", "arm", 0.1, 0.05, point_b=(0.15 + gap, 0.0, 0.0), mu=0.3))
    return mech


def test_open_pair_carried_round_through_the_opposite_direction_runs_on():
    """A sphere carried round a fixed one at 0.85 m, far from touching, through the opposite of its
    initial normal (t = 1 s) and once more round (t = 3 s): the pair takes its tangents from the other
    chart there (PAIR_CHART_GAP), so both loops run to the end; no force acts (the arm spins on at π
    rad/s, its coordinates the free rotation's), and every contact output is finite."""
    for compiled in (None, False):
        res = simulate(_carried_round(0.85).compile(), 3.5, 1e-2, compiled=compiled)
        assert res.t[-1] == pytest.approx(3.5) and not res.events
        for k in (100, 250, 350):                      # half, one and a quarter, one and three quarter turns
            ang = np.pi * res.t[k]
            want = np.array([[np.cos(ang), -np.sin(ang), 0.0], [np.sin(ang), np.cos(ang), 0.0], [0.0, 0.0, 1.0]])
            np.testing.assert_allclose(quat_to_matrix(res.q[k, 3:7]), want, rtol=0, atol=1e-12)
        np.testing.assert_allclose(res.qd[:, 5], np.pi, rtol=0, atol=1e-12)
        for key in ("gN", "lam_N", "lam_F", "gam_F", "P_N", "P_F"):
            assert np.all(np.isfinite(res.contact[key])), key
        np.testing.assert_allclose(res.contact["gN"][:, 0], 0.85, rtol=0, atol=1e-12)
        assert np.abs(res.contact["lam_F"]).max() == 0.0 and np.abs(res.contact["P_N"]).max() == 0.0


def test_other_chart_kernel_matches_finite_differences_and_is_right_handed():
    """At states where an open pair uses the other chart (f₁, −f₂, −p) (n·p < −1/2, gap above
    PAIR_CHART_GAP (R_a + R_b)): W_N, ζ, H against central differences, and (t₁, t₂, n) of the output
    frames right-handed and equal to W_F's direction rows."""
    from femb.elements.contact import PAIR_CHART_GAP
    model = _carried_round(0.85).compile()
    q = model.q0.copy()
    q[3:7] = (np.cos(0.45 * np.pi), 0.0, 0.0, np.sin(0.45 * np.pi))   # turned by 0.9 π about z
    g = next(iter(model.contact_groups))
    p = g.elements[0].p
    for seed in range(3):
        report = check_contact_kernels(model, seed=seed, move=0.05, q=q)
        assert report.ok, str(report)
    ev = assemble.evaluate(model, 0.0, q, np.zeros(model.nq), jac=True)
    c, n, T, gN = type(g.elements[0]).contact_frames(g.P, model.ext(q)[g.xdofs])
    assert n[0] @ p < -0.5 and gN[0] > PAIR_CHART_GAP * 0.15
    np.testing.assert_allclose(np.cross(T[0, 0], T[0, 1]), n[0], rtol=0, atol=1e-14)
    np.testing.assert_allclose(ev["WF"].toarray()[:, 0:3], T[0], rtol=0, atol=1e-14)   # a is the ground
    with pytest.raises(ParameterError, match="q must be"):
        check_contact_kernels(model, q=q[:3])


def test_near_pair_opposite_its_initial_direction_stops_the_run_with_a_contact_error():
    """Within PAIR_CHART_GAP (R_a + R_b) of touching the pair keeps its first chart, whose tangent basis is
    singular where n = −p: a sphere carried round a fixed one at a gap of 1e-4 m reaches the opposite
    side at t = 1 s; the run stops there with a ContactError naming the pair and why, not with NaN in
    the result."""
    mech = _carried_round(1e-4)
    for compiled in (None, False):
        with pytest.raises(ContactError, match="pairX.*opposite of its initial direction.*of touching") as err:
            simulate(mech.compile(), 1.5, 1e-2, compiled=compiled)
        assert err.value.contact == "pairX" and err.value.t == pytest.approx(1.0)
        assert np.all(np.isfinite(err.value.result.q)) and err.value.result.t[-1] == pytest.approx(0.99)

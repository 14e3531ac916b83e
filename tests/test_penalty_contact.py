"""Penalty (compliant) contact (elements/penalty_contact.py): Jacobians, parameters, outputs, energy,
and the closed forms of docs/contact.md ("Penalty (compliant) contact").

* ∂f/∂x (along x ∘ exp(εw)) and ∂f/∂v against central differences (femb.check_jacobians), planar and
  spatial, at random states, just after the contact closes (δ → 0⁺), at slip speeds far below ε_v,
  with the damping term clamped, and open (all zero);
* bad parameters are ModelErrors naming the element and the parameter;
* the named outputs (gap, forces, slip, state) in Result.series/outputs/to_pandas, against hand values;
* the "energy" kernel is the potential of the force at v = 0;
* dynamics: the Hunt–Crossley restitution at v_ref, the undamped Hertz contact time (Johnson §11.4),
  a resting sphere's force m g and its Hertz penetration, sticking (the regularization's creep speed)
  and sliding on an incline (Coulomb acceleration), the backspin ball rolling at −10/7 m/s, fixed and
  adaptive steps, planar and spatial;
* sphere pairs and spheres on a body's plane: Jacobians, potential, a head-on impact (momentum,
  restitution, Hertz time for the reduced mass), momentum through a frictional impact on a free plate.
"""
import math

import numpy as np
import pytest

import femb
from femb.elements import (Gravity, PenaltySphereOnPlane, RigidBody, SpatialPenaltySphereOnBodyPlane,
                           SpatialPenaltySpherePair, SpatialPenaltySphereOnPlane,
                           SpatialRigidBody)
from femb.elements.penalty_contact import hunt_crossley_damping, restitution_of
from femb.elements.spatial_forces import SpatialGravity
from femb.errors import ModelError
from femb.system.model import State


def _planar(y, qd, **kw):
    m = femb.Mechanism("pen_planar")
    b = m.add(RigidBody("ball", 1.0, 0.004, position=(0.1, y), angle=0.3))
    kw.setdefault("restitution", 0.5)
    kw.setdefault("mu", 0.3)
    kw.setdefault("eps_v", 0.1)
    m.add(PenaltySphereOnPlane("floor", b, 0.1, 1e5, point=(0.01, 0.02), plane_point=(0.0, -0.01),
                               normal=(0.2, 1.0), **kw))
    model = m.compile()
    st = model.initial_state()
    st.qd[:] = qd
    return model, st


def _spatial(z, qd, **kw):
    p = np.array((0.9, 0.3, -0.4, 0.1))
    m = femb.Mechanism("pen_spatial")
    b = m.add(SpatialRigidBody("ball", 1.0, (0.004, 0.005, 0.006), position=(0.1, 0.2, z),
                               rotation=p / np.linalg.norm(p)))
    kw.setdefault("restitution", 0.5)
    kw.setdefault("mu", 0.3)
    kw.setdefault("eps_v", 0.1)
    m.add(SpatialPenaltySphereOnPlane("floor", b, 0.1, 1e5, point=(0.01, 0.02, -0.015),
                                      plane_point=(0.0, 0.0, -0.01), normal=(0.1, -0.2, 1.0), **kw))
    model = m.compile()
    st = model.initial_state()
    st.qd[:] = qd
    return model, st


def _force(model, st):
    from femb.system import kernels as K
    g = next(g for g in model.force_groups if "Penalty" in g.name)
    v = np.concatenate((st.qd, np.zeros(model.nfix_v)))
    return K.ForceValues(g)(st.t, model.ext(st.q)[g.xdofs], v[g.dofs])[0]


def _gap(model, st):
    from femb.results.result import Result
    r = Result(model=model, t=np.array([st.t]), q=st.q[None], qd=st.qd[None], qdd=np.zeros((1, model.nq)),
               lam=np.zeros((1, model.nc)), newton_iterations=np.zeros(0, dtype=np.int32))
    return {k: r.series(f"floor.{k}")[0][0] for k in ("gN", "gN_d", "lambda_N", "slip", "state")}


# ---------------------------------------------------------------------------- Jacobians
CASES = {
    "pressed": dict(),
    "just_closed": dict(depth=2e-6),           # δ → 0⁺: f ~ δ^1.5, ∂f/∂δ ~ δ^0.5
    "slow_slip": dict(slow=True),              # |v_T| ≪ ε_v: the viscous branch of the friction law
    "no_friction": dict(mu=0.0),
    "undamped": dict(restitution=1.0),
}


def _state_for(build, case):
    kw = {k: v for k, v in case.items() if k in ("mu", "restitution")}
    planar = build is _planar
    pos = 0.09 if planar else 0.075
    model, st = build(pos, np.zeros(3 if planar else 6), **kw)
    # move along the normal to the requested penetration (g = gN at the state)
    if True:
        g0 = _gap(model, st)["gN"]
        n = model.groups[-1].P[0, 7:10]
        d = np.zeros(model.nq)
        d[:2 if planar else 3] = -(g0 + case.get("depth", 1e-3)) * n[:2 if planar else 3]
        st = State(0.0, model.compose(st.q, d), st.qd, st.qdd, st.lam)
    rng = np.random.default_rng(3)
    qd = rng.uniform(-0.3, 0.3, model.nq)
    if case.get("slow"):
        qd *= 1e-4
    st.qd[:] = qd
    return model, st


@pytest.mark.parametrize("build", [_planar, _spatial], ids=["planar", "spatial"])
@pytest.mark.parametrize("case", list(CASES), ids=list(CASES))
def test_jacobians_match_finite_differences(build, case):
    """∂f/∂x along x ∘ exp(εw) and ∂f/∂v of the penalty kernel against central differences."""
    model, st = _state_for(build, CASES[case])
    out = _gap(model, st)
    assert out["gN"] < 0.0 and out["lambda_N"] > 0.0          # the contact is closed: a real check
    if case == "just_closed":
        assert -out["gN"] < 1e-5
    if case == "slow_slip":
        assert out["slip"] < 0.1 * 0.1                          # ≪ ε_v = 0.1
    eps = 1e-9 if case == "just_closed" else None       # steps far below δ, so that none crosses δ = 0
    report = femb.check_jacobians(model, state=st, perturb=False, rtol=1e-6, eps=eps)
    assert report.ok, str(report)


@pytest.mark.parametrize("build", [_planar, _spatial], ids=["planar", "spatial"])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_jacobians_at_random_states(build, seed):
    model, st = _state_for(build, {})
    report = femb.check_jacobians(model, state=st, seed=seed)
    assert report.ok, str(report)


def test_jacobian_comparison_can_fail():
    """The comparison is not vacuous: the kernel's ∂f/∂v matches central differences of its force, and the
    same kernel with the friction left out of the Jacobian only (μ = 0 there) does not."""
    import femb.elements.penalty_contact as pc
    model, st = _state_for(_planar, {})
    g = next(g for g in model.force_groups if "Penalty" in g.name)
    xe = model.ext(st.q)[g.xdofs]
    ve = np.concatenate((st.qd, np.zeros(model.nfix_v)))[g.dofs]
    tf = np.zeros((1, 0, 3))

    def kernel(P, v, jac):
        fe, fq, fv = np.zeros((1, 3)), np.zeros((1, 3, 3)), np.zeros((1, 3, 3))
        pc.planar_penalty_force(P, 0.0, tf, xe, v, jac, fe, fq, fv)
        return fe[0], fv[0]
    h = 1e-7
    J = np.column_stack([(kernel(g.P, ve + h * np.eye(3)[j], False)[0] - kernel(g.P, ve - h * np.eye(3)[j], False)[0])
                         / (2 * h) for j in range(3)])
    scale = np.abs(J).max()
    assert np.allclose(J, kernel(g.P, ve, True)[1], rtol=1e-5, atol=1e-6 * scale)
    P0 = g.P.copy()
    P0[0, 13] = 0.0
    assert not np.allclose(J, kernel(P0, ve, True)[1], rtol=1e-3, atol=1e-6 * scale)


@pytest.mark.parametrize("build", [_planar, _spatial], ids=["planar", "spatial"])
def test_open_contact_has_no_force(build):
    model, st = build(0.5, np.ones(3 if build is _planar else 6))
    assert _gap(model, st)["gN"] > 0 and _gap(model, st)["state"] == 0
    assert np.all(_force(model, st) == 0.0)


def test_damping_clamped_no_tension():
    """Separating fast (1 + α δ̇ < 0): f_N = 0, never a pull; the Jacobians are zero there too."""
    model, st = _state_for(_planar, dict(restitution=0.2))
    st.qd[:] = (0.0, 50.0, 0.0)
    assert _gap(model, st)["gN"] < 0
    assert _gap(model, st)["lambda_N"] == 0.0
    assert np.all(_force(model, st) == 0.0)
    assert femb.check_jacobians(model, state=st, perturb=False).ok


# ---------------------------------------------------------------------------- parameters
@pytest.mark.parametrize("kw, what", [
    (dict(stiffness=-1.0), "stiffness"),
    (dict(stiffness=0.0), "stiffness"),
    (dict(radius=-0.1), "radius"),
    (dict(restitution=1.5), "restitution"),
    (dict(restitution=-0.1), "restitution"),
    (dict(restitution=0.0), "restitution 0"),
    (dict(mu=-0.2), "mu"),
    (dict(eps_v=0.0), "eps_v"),
    (dict(eps_v=-1e-3), "eps_v"),
    (dict(v_ref=0.0), "v_ref"),
    (dict(exponent=0.5), "exponent"),
    (dict(normal=(0.0, 0.0)), "normal"),
    (dict(normal=(1.0, 2.0, 3.0)), "normal"),
    (dict(damping=-1.0), "damping"),
    (dict(damping=1.0, restitution=0.5), "not both"),
    (dict(stiffness=float("nan")), "stiffness"),
    (dict(plane_point="floor"), "plane_point"),
])
def test_bad_parameters_name_element_and_parameter(kw, what):
    args = dict(radius=0.1, stiffness=1e5)
    args.update(kw)
    with pytest.raises(ModelError, match=f"PenaltySphereOnPlane 'c'.*{what}"):
        PenaltySphereOnPlane("c", "ball", args.pop("radius"), args.pop("stiffness"), **args)


def test_wrong_body_kind():
    m = femb.Mechanism("wrong")
    m.add(SpatialRigidBody("s", 1.0, (1.0, 1.0, 1.0)))
    m.add(PenaltySphereOnPlane("c", "s", 0.1, 1e5))
    with pytest.raises(ModelError, match="PenaltySphereOnPlane 'c'.*spatial body"):
        m.compile()
    m = femb.Mechanism("wrong2")
    m.add(RigidBody("p", 1.0, 1.0))
    m.add(SpatialPenaltySphereOnPlane("c", "p", 0.1, 1e5))
    with pytest.raises(ModelError, match="SpatialPenaltySphereOnPlane 'c'.*planar"):
        m.compile()


def test_unknown_output_is_a_model_error():
    model, st = _planar(0.09, np.zeros(3))
    r = femb.simulate(model, t_end=1e-3, h=1e-4)
    with pytest.raises(ModelError, match="'floor' has the outputs"):
        r.series("floor.lambda_Q")


# ---------------------------------------------------------------------------- outputs and energy
def test_outputs_against_hand_values():
    """A disc on the floor y = 0 at depth δ, sliding at v: g = −δ, f_N = k δ^1.5 (1 + α δ̇), f_T = −μ f_N v/√(v² + ε²)."""
    m = femb.Mechanism("hand")
    b = m.add(RigidBody("ball", 1.0, 0.004, position=(0.0, 0.099)))
    m.add(PenaltySphereOnPlane("floor", b, 0.1, 1e5, damping=0.3, mu=0.4, eps_v=0.01))
    model = m.compile()
    st = model.initial_state()
    st.qd[:] = (0.5, -0.2, 2.0)              # contact point: v_T = 0.5 + 0.1·2 = 0.7, δ̇ = 0.2
    from femb.results.result import Result
    r = Result(model=model, t=np.zeros(1), q=st.q[None], qd=st.qd[None], qdd=np.zeros((1, 3)),
               lam=np.zeros((1, 0)), newton_iterations=np.zeros(0, dtype=np.int32))
    d = 0.001
    fN = 1e5 * d ** 1.5 * (1 + 0.3 * 0.2)
    fT = -0.4 * fN * 0.7 / math.hypot(0.7, 0.01)
    assert r.series("floor.gN")[0][0] == pytest.approx(-d, abs=1e-15)
    assert r.series("floor.gN_d") == (pytest.approx([-0.2]), "m/s")
    assert r.series("floor.lambda_N")[0][0] == pytest.approx(fN, rel=1e-12)
    assert r.series("floor.lambda_F")[0][0] == pytest.approx(fT, rel=1e-12)   # t = (n_y, −n_x) = +x
    assert r.series("floor.gamma_F")[0][0] == pytest.approx(0.7, rel=1e-12)
    assert r.series("floor.lambda_F_norm")[0][0] == pytest.approx(abs(fT), rel=1e-12)
    assert r.series("floor.slip")[0][0] == pytest.approx(0.7, rel=1e-12)
    assert r.series("floor.state")[0][0] == 2
    f = _force(model, st)
    assert f == pytest.approx([fT, fN, 0.1 * fT], rel=1e-12)    # moment (0, −R) × (f_T, f_N) of f_T at the contact point
    names = r.outputs()
    assert {"floor.gN", "floor.lambda_N", "floor.lambda_F", "floor.slip", "floor.state"} <= set(names)
    pytest.importorskip("pandas")
    df = r.to_pandas()
    assert df["floor.lambda_N"].iloc[0] == pytest.approx(fN)
    assert df.attrs["units"]["floor.lambda_N"] == "N"


@pytest.mark.parametrize("build", [_planar, _spatial], ids=["planar", "spatial"])
def test_energy_kernel_is_the_potential(build):
    """f(q, 0)·w = −dV/ds along x ∘ exp(s w) (central differences), V = k δ^{n+1}/(n + 1)."""
    from femb.system import kernels as K
    model, st = _state_for(build, {})
    st.qd[:] = 0.0
    g = next(g for g in model.force_groups if "Penalty" in g.name)
    rng = np.random.default_rng(1)
    for _ in range(3):
        w = rng.uniform(-1, 1, model.nq)
        h = 1e-7
        V = [K.energy(g, 0.0, model.ext(model.compose(st.q, s * h * w))[g.xdofs]).sum() for s in (1, -1)]
        assert -(V[0] - V[1]) / (2 * h) == pytest.approx(_force(model, st) @ w, rel=1e-6)


# ---------------------------------------------------------------------------- dynamics
def _impact(e, k=1e8, v0=2.0, h=1e-5, rtol=None, spatial=False):
    """A ball thrown at the plane at v0 without gravity: (contact time, rebound ratio)."""
    m = femb.Mechanism("throw")
    if spatial:
        b = m.add(SpatialRigidBody("ball", 1.0, (0.004,) * 3, position=(0.0, 0.0, 0.1 + 1e-3), velocity=(0, 0, -v0)))
        m.add(SpatialPenaltySphereOnPlane("floor", b, 0.1, k, restitution=e, v_ref=v0))
    else:
        b = m.add(RigidBody("ball", 1.0, 0.004, position=(0.0, 0.1 + 1e-3), velocity=(0.0, -v0)))
        m.add(PenaltySphereOnPlane("floor", b, 0.1, k, restitution=e, v_ref=v0))
    kw = dict(h=h) if rtol is None else dict(rtol=rtol, atol=1e-10)
    r = femb.simulate(m.compile(), t_end=4e-3, rho_inf=0.9, **kw)
    g, gd = r.series("floor.gN")[0], r.series("floor.gN_d")[0]
    i0 = int(np.argmax(g < 0))
    i1 = i0 + int(np.argmax(g[i0:] >= 0))
    assert g[i1] >= 0 > g[i1 - 1]

    def cross(i):       # linear interpolation of the crossing time and of ġ there
        s = g[i - 1] / (g[i - 1] - g[i])
        return r.t[i - 1] + s * (r.t[i] - r.t[i - 1]), gd[i - 1] + s * (gd[i] - gd[i - 1])
    (ta, va), (tb, vb) = cross(i0), cross(i1)
    return tb - ta, -vb / va, r


def hertz_contact_time(m, k, v):
    """Duration of an undamped Hertz impact, f = k δ^{3/2} (Johnson §11.4, eq. (11.24) with k = (4/3)E*√R):
    t_c = 2 (5/4)^{2/5} (2/5) B(2/5, 1/2) (m²/(k² v))^{1/5} = 3.21807 (m²/(k² v))^{1/5}."""
    return 3.2180654597 * (m * m / (k * k * v)) ** 0.2


def test_restitution_calibration():
    """e(α v⁻) of the scaled impact; α → 3(1 − e)/(2 v) (Hunt & Crossley) as e → 1."""
    for e in (0.95, 0.7, 0.5, 0.2):
        a = hunt_crossley_damping(e, 2.0)
        assert restitution_of(a * 2.0) == pytest.approx(e, abs=1e-9)
    assert hunt_crossley_damping(0.999, 1.0) == pytest.approx(1.5 * 0.001, rel=2e-3)
    assert hunt_crossley_damping(1.0, 1.0) == 0.0


@pytest.mark.parametrize("spatial", [False, True], ids=["planar", "spatial"])
def test_undamped_hertz_contact_time_and_elastic_rebound(spatial):
    tc, ratio, _ = _impact(1.0, spatial=spatial)
    assert tc == pytest.approx(hertz_contact_time(1.0, 1e8, 2.0), rel=2e-3)
    assert ratio == pytest.approx(1.0, abs=5e-3)


@pytest.mark.parametrize("e", [0.8, 0.5])
def test_rebound_ratio_is_the_requested_restitution(e):
    tc, ratio, _ = _impact(e)
    assert ratio == pytest.approx(e, abs=5e-3)


def test_adaptive_steps_resolve_the_impact():
    tc, ratio, r = _impact(0.5, rtol=1e-6)
    assert ratio == pytest.approx(0.5, abs=5e-3)
    assert np.diff(r.t).min() < 0.05 * tc < np.diff(r.t).max()     # small steps in contact, long ones outside


def _resting(spatial, stiffness=1e5):
    m = femb.Mechanism("rest")
    if spatial:
        b = m.add(SpatialRigidBody("ball", 2.0, (0.008,) * 3, position=(0.0, 0.0, 0.1)))
        m.add(SpatialPenaltySphereOnPlane("floor", b, 0.1, stiffness, restitution=0.3, mu=0.5))
        m.add(SpatialGravity((0.0, 0.0, -9.81)))
    else:
        b = m.add(RigidBody("ball", 2.0, 0.008, position=(0.0, 0.1)))
        m.add(PenaltySphereOnPlane("floor", b, 0.1, stiffness, restitution=0.3, mu=0.5))
        m.add(Gravity((0.0, -9.81)))
    return femb.simulate(m.compile(), t_end=1.0, h=1e-3)


@pytest.mark.parametrize("spatial", [False, True], ids=["planar", "spatial"])
def test_resting_sphere_carries_its_weight(spatial):
    """f_N → m g, penetration → (m g/k)^{2/3}, state stick, energy balance small."""
    r = _resting(spatial)
    assert r.series("floor.lambda_N")[0][-1] == pytest.approx(2.0 * 9.81, rel=1e-6)
    assert -r.series("floor.gN")[0][-1] == pytest.approx((2.0 * 9.81 / 1e5) ** (2 / 3), rel=1e-6)
    assert r.series("floor.state")[0][-1] == 1
    e = r.energy()
    assert abs(e["balance"]).max() < 1e-4 * 2.0 * 9.81 * 0.1


def _incline(alpha, mu, spatial=False, eps_v=2e-3, t_end=0.5, h=1e-3):
    """A body on its contact point (radius 0: a block) on a plane inclined at α, at rest at the static penetration."""
    n2 = (-math.sin(alpha), math.cos(alpha))
    d = (9.81 * math.cos(alpha) / 1e6) ** (2 / 3)          # static Hertz penetration: start at rest on the plane
    m = femb.Mechanism("incline")
    if spatial:
        b = m.add(SpatialRigidBody("blk", 1.0, (1.0,) * 3, position=(0.0, 0.0, 0.0)))
        m.add(SpatialPenaltySphereOnPlane("floor", b, 0.0, 1e6, normal=(n2[0], 0.0, n2[1]), plane_point=(d * n2[0], 0, d * n2[1]),
                                          restitution=0.5, mu=mu, eps_v=eps_v))
        m.add(SpatialGravity((0.0, 0.0, -9.81)))
    else:
        b = m.add(RigidBody("blk", 1.0, 1.0, position=(0.0, 0.0)))
        m.add(PenaltySphereOnPlane("floor", b, 0.0, 1e6, normal=n2, plane_point=(d * n2[0], d * n2[1]), restitution=0.5,
                                   mu=mu, eps_v=eps_v))
        m.add(Gravity((0.0, -9.81)))
    kw = dict(h=h) if h else dict(rtol=1e-4, atol=1e-8)
    return femb.simulate(m.compile(), t_end=t_end, **kw)


def creep_speed(eps_v, alpha, mu):
    """Steady slip of a regularized 'sticking' contact: μ f_N v/√(v² + ε²) = f_T, r = f_T/(μ f_N) = tan α/μ."""
    r = math.tan(alpha) / mu
    return eps_v * r / math.sqrt(1 - r * r)


@pytest.mark.parametrize("spatial", [False, True], ids=["planar", "spatial"])
def test_incline_sticks_below_friction_angle_slides_above(spatial):
    alpha = 0.3
    # below: tan α = 0.309 < μ = 0.5: creeps at the regularization's steady slip speed
    r = _incline(alpha, 0.5, spatial)
    slip = r.series("floor.slip")[0]
    assert slip[-1] == pytest.approx(creep_speed(2e-3, alpha, 0.5), rel=1e-3)
    assert r.series("floor.state")[0][-1] == 1
    # above: μ = 0.2 < tan α: slides with g (sin α − μ cos α), to O((ε_v/|v_T|)²)
    r = _incline(alpha, 0.2, spatial)
    s = r.series("floor.gamma_F" if not spatial else "floor.gamma_F1")[0]
    sel = r.t > 0.2
    acc = np.polyfit(r.t[sel], s[sel], 1)[0]
    assert abs(acc) == pytest.approx(9.81 * (math.sin(alpha) - 0.2 * math.cos(alpha)), rel=1e-4)
    assert set(r.series("floor.state")[0][sel]) == {2.0}


def test_incline_small_regularization_with_adaptive_steps():
    """ε_v = 1e-4 m/s: fixed steps of 1 ms do not converge (h μ f_N/(m ε_v) ≈ 47, docs/contact.md); the
    adaptive steps do, and the creep is the regularization's."""
    r = _incline(0.3, 0.5, eps_v=1e-4, h=None)
    assert r.series("floor.slip")[0][-1] == pytest.approx(creep_speed(1e-4, 0.3, 0.5), rel=1e-2)
    with pytest.raises(femb.errors.ConvergenceError):
        _incline(0.3, 0.5, eps_v=1e-4)


@pytest.mark.parametrize("spatial", [False, True], ids=["planar", "spatial"])
def test_backspin_ball_rolls_back_at_minus_ten_sevenths(spatial):
    """The ball of the backspin scene (ω₀ = 50 rad/s, μ = 0.2, dropped from 1 m): it slides, then rolls at
    ẋ = −(2/7) R ω₀ = −10/7 m/s (angular momentum about the contact point); the regularized slip decays."""
    from femb.benchmarks.scenes.contact.penalty_backspin import run
    out = run(spatial=spatial, t_end=1.0, h=1e-3)
    assert out["rolling speed"] == pytest.approx(-10 / 7, abs=1e-9)
    assert out["slip at the end"] < 1e-9
    assert 0.70 < out["slip < eps_v from"] < 0.76          # the rigid scheme's switch: 0.72812 s (e_N = 0)


def test_outputs_of_each_element_of_a_batch():
    """Outputs of element i use element i's parameters (two spheres, different stiffness, one batch)."""
    from femb.benchmarks.scenes.contact import penalty_spheres
    mech = femb.Mechanism("two")
    mech.add(SpatialGravity((0.0, 0.0, -9.81)))
    for i, k in enumerate((1e5, 4e5)):
        mech.add(SpatialRigidBody(f"s{i}", 1.0, (0.001,) * 3, position=(i, 0.0, 0.049)))
        mech.add(SpatialPenaltySphereOnPlane(f"c{i}", f"s{i}", 0.05, k, mu=0.1))
    r = femb.simulate(mech.compile(), t_end=2e-3, h=1e-3)
    for i, k in enumerate((1e5, 4e5)):
        d = -r.series(f"c{i}.gN")[0]
        assert d[0] == pytest.approx(1e-3)
        assert r.series(f"c{i}.lambda_N")[0][0] == pytest.approx(k * 1e-3 ** 1.5, rel=1e-12)
    out = penalty_spheres.outputs(r)
    assert out["lambda_N"][0] == pytest.approx(5e5 * 1e-3 ** 1.5, rel=1e-12)


# ---------------------------------------------------------------------------- sphere pairs (spatial)
def _pair(gap, qd=None, **kw):
    p, q = np.array((0.9, 0.3, -0.4, 0.1)), np.array((0.2, -0.5, 0.7, 0.3))
    from femb.base.rotations import quat_to_matrix
    p, q = p / np.linalg.norm(p), q / np.linalg.norm(q)
    sa, sb = np.array((0.01, -0.02, 0.005)), np.array((-0.01, 0.01, 0.02))
    n = np.array((0.8, 0.3, -0.2)) / np.linalg.norm((0.8, 0.3, -0.2))
    rb = quat_to_matrix(p) @ sa + (0.18 + gap) * n - quat_to_matrix(q) @ sb     # centres 0.18 + gap apart along n
    m2 = femb.Mechanism("pair")
    m2.add(SpatialRigidBody("a", 1.0, (0.004, 0.005, 0.006), rotation=p))
    m2.add(SpatialRigidBody("b", 2.0, (0.007, 0.005, 0.006), position=rb, rotation=q))
    kw.setdefault("restitution", 0.5)
    kw.setdefault("mu", 0.3)
    kw.setdefault("eps_v", 0.1)
    m2.add(SpatialPenaltySpherePair("floor", "a", "b", 0.1, 0.08, 1e5, point_a=tuple(sa), point_b=tuple(sb), **kw))
    model = m2.compile()
    st = model.initial_state()
    st.qd[:] = np.random.default_rng(0).uniform(-0.5, 0.5, 12) if qd is None else qd
    return model, st


@pytest.mark.parametrize("gap, slow", [(-1e-2, False), (-2e-6, False), (-1e-3, True)],
                         ids=["pressed", "just_closed", "slow_slip"])
def test_sphere_pair_jacobians(gap, slow):
    model, st = _pair(gap)
    if slow:
        st.qd[:] *= 1e-4
    out = _gap(model, st)
    assert out["gN"] == pytest.approx(gap, rel=1e-9) and out["lambda_N"] > 0
    report = femb.check_jacobians(model, state=st, perturb=False, rtol=1e-6, eps=1e-9 if gap > -1e-5 else None)
    assert report.ok, str(report)


def test_sphere_pair_energy_kernel_is_the_potential():
    from femb.system import kernels as K
    model, st = _pair(-1e-2, qd=np.zeros(12))
    g = model.force_groups[-1]
    w = np.random.default_rng(2).uniform(-1, 1, 12)
    h = 1e-7
    V = [K.energy(g, 0.0, model.ext(model.compose(st.q, s * h * w))[g.xdofs]).sum() for s in (1, -1)]
    assert -(V[0] - V[1]) / (2 * h) == pytest.approx(_force(model, st) @ w, rel=1e-6)


def test_sphere_pair_head_on_impact():
    """Two spheres (1 kg, 2 kg) meet head on at 2 m/s relative speed, no gravity: momentum is kept, the
    relative speed rebounds with e, the contact lasts Hertz's t_c for the reduced mass m = 2/3 kg."""
    m = femb.Mechanism("head_on")
    m.add(SpatialRigidBody("a", 1.0, (0.004,) * 3, position=(0.0, 0.0, 0.0), velocity=(1.0, 0.0, 0.0)))
    m.add(SpatialRigidBody("b", 2.0, (0.008,) * 3, position=(0.1801, 0.0, 0.0), velocity=(-1.0, 0.0, 0.0)))
    m.add(SpatialPenaltySpherePair("c", "a", "b", 0.1, 0.08, 1e8, restitution=0.6, v_ref=2.0, mu=0.2))
    r = femb.simulate(m.compile(), t_end=4e-3, h=1e-5, rho_inf=0.9)
    p = r.series("a.x_d")[0] + 2.0 * r.series("b.x_d")[0]
    assert np.abs(p - p[0]).max() < 1e-12
    g, gd = r.series("c.gN")[0], r.series("c.gN_d")[0]
    i0 = int(np.argmax(g < 0))
    i1 = i0 + int(np.argmax(g[i0:] >= 0))

    def cross(i):
        s = g[i - 1] / (g[i - 1] - g[i])
        return r.t[i - 1] + s * (r.t[i] - r.t[i - 1]), gd[i - 1] + s * (gd[i] - gd[i - 1])
    (ta, va), (tb, vb) = cross(i0), cross(i1)
    assert va == pytest.approx(-2.0, rel=1e-9)
    assert -vb / va == pytest.approx(0.6, abs=5e-3)
    tc = 3.2180654597 * ((2 / 3) ** 2 / (1e16 * 2.0)) ** 0.2 * _e_time_ratio(0.6)
    assert tb - ta == pytest.approx(tc, rel=5e-3)
    assert r.series("c.state")[0][i0 + 2] == 1                   # no tangential motion: sticks


def _e_time_ratio(e):
    """Contact time with damping over the undamped one, from the scaled impact of restitution_of (numerical)."""
    from scipy.integrate import solve_ivp
    from femb.elements.penalty_contact import hunt_crossley_damping

    def duration(c):
        def rhs(_, y):
            return (y[1], -max(y[0], 0.0) ** 1.5 * max(0.0, 1.0 + c * y[1]))

        def back(_, y):
            return y[0]
        back.terminal, back.direction = True, -1.0
        return solve_ivp(rhs, (0, 100), (0.0, 1.0), rtol=1e-11, atol=1e-13, events=back).t_events[0][0]
    return duration(hunt_crossley_damping(e, 1.0)) / duration(0.0)


def test_sphere_pair_bad_input():
    with pytest.raises(ModelError, match="SpatialPenaltySpherePair 'c'.*radius_b"):
        SpatialPenaltySpherePair("c", "a", "b", 0.1, -0.1, 1e5)
    m = femb.Mechanism("same")
    m.add(SpatialRigidBody("a", 1.0, (1.0, 1.0, 1.0)))
    m.add(SpatialPenaltySpherePair("c", "a", "a", 0.1, 0.1, 1e5))
    with pytest.raises(ModelError, match="SpatialPenaltySpherePair 'c'.*same"):
        m.compile()


# ---------------------------------------------------------------------------- sphere on a body's plane (spatial)
def _body_plane(gap, qd=None, **kw):
    p, q = np.array((0.9, 0.3, -0.4, 0.1)), np.array((0.2, -0.5, 0.7, 0.3))
    nb = np.array((0.1, -0.2, 1.0)) / np.linalg.norm((0.1, -0.2, 1.0))
    pb, sb = np.array((0.02, 0.01, -0.03)), np.array((-0.01, 0.01, 0.02))
    m = femb.Mechanism("body_plane")
    a = m.add(SpatialRigidBody("a", 10.0, (0.04, 0.05, 0.06), rotation=p / np.linalg.norm(p)))
    b = SpatialRigidBody("b", 2.0, (0.007, 0.005, 0.006), rotation=q / np.linalg.norm(q))
    n = a.node.rotation0 @ nb
    C = a.node.rotation0 @ pb + (0.08 + gap) * n + 0.03 * np.cross(n, (1.0, 0.0, 0.0))
    m.add(SpatialRigidBody("b", 2.0, (0.007, 0.005, 0.006), position=C - b.node.rotation0 @ sb,
                           rotation=q / np.linalg.norm(q)))
    kw.setdefault("restitution", 0.5)
    kw.setdefault("mu", 0.3)
    kw.setdefault("eps_v", 0.1)
    m.add(SpatialPenaltySphereOnBodyPlane("floor", "a", "b", 0.08, 1e5, plane_point=tuple(pb), normal=tuple(nb),
                                          point=tuple(sb), **kw))
    model = m.compile()
    st = model.initial_state()
    st.qd[:] = np.random.default_rng(0).uniform(-0.5, 0.5, 12) if qd is None else qd
    return model, st


@pytest.mark.parametrize("gap, slow", [(-1e-2, False), (-2e-6, False), (-1e-3, True)],
                         ids=["pressed", "just_closed", "slow_slip"])
def test_body_plane_jacobians(gap, slow):
    model, st = _body_plane(gap)
    if slow:
        st.qd[:] *= 1e-4
    out = _gap(model, st)
    assert out["gN"] == pytest.approx(gap, rel=1e-9) and out["lambda_N"] > 0
    report = femb.check_jacobians(model, state=st, perturb=False, rtol=1e-5, eps=1e-9 if gap > -1e-5 else None)
    assert report.ok, str(report)


def test_body_plane_energy_kernel_is_the_potential():
    from femb.system import kernels as K
    model, st = _body_plane(-1e-2, qd=np.zeros(12))
    g = model.force_groups[-1]
    w = np.random.default_rng(2).uniform(-1, 1, 12)
    h = 1e-7
    V = [K.energy(g, 0.0, model.ext(model.compose(st.q, s * h * w))[g.xdofs]).sum() for s in (1, -1)]
    assert -(V[0] - V[1]) / (2 * h) == pytest.approx(_force(model, st) @ w, rel=1e-6)


def test_body_plane_keeps_momentum():
    """A spinning sphere thrown onto a free-floating plate (no gravity): F on the sphere and −F on the plate at
    one point, so the linear and angular momentum of the two are kept through the contact (to the scheme's
    accuracy for the angular momentum of spinning bodies: 1e-7 relative here)."""
    m = femb.Mechanism("throw_on_plate")
    a = m.add(SpatialRigidBody("a", 10.0, (0.04, 0.05, 0.06), omega=(0.0, 0.0, 0.5)))
    m.add(SpatialRigidBody("b", 1.0, (0.004,) * 3, position=(0.0, 0.0, 0.081), velocity=(0.5, 0.0, -1.0),
                           omega=(0.0, 30.0, 0.0)))
    m.add(SpatialPenaltySphereOnBodyPlane("c", a, "b", 0.08, 1e7, restitution=0.5, mu=0.3))
    r = femb.simulate(m.compile(), t_end=0.01, h=1e-5, rho_inf=0.9)
    assert r.series("c.lambda_N")[0].max() > 100.0 and r.series("c.gN")[0][-1] > 0      # it hit and left
    p, H = r.momentum()
    assert np.abs(p - p[0]).max() < 1e-12
    assert np.abs(H - H[0]).max() < 1e-6 * np.linalg.norm(H[0])
    assert r.series("c.slip")[0][np.argmax(r.series("c.lambda_N")[0])] > 0.01         # friction was at work


# ---------------------------------------------------------------------------- the two-body kernels against recorded values
# f, f_q w, wᵀ f_q, f_v w, wᵀ f_v (w = uniform(-1, 1, 12) of default_rng(7)) of the two-body kernels at the states of
# _pair and _body_plane (pressed: gap -1e-2; slow: gap -1e-3, velocities times 1e-4), recorded from the first
# implementation of these kernels (array code) before it was rewritten with tuples; the rewrite must give the same.
RECORDED = {
    ("pair", -0.01, False): (
        -90.97242320006276, -13.255299549077277, 42.83198983095609, 0.20619281898578637,
        -2.081738092910074, 1.1134642459504485, 90.97242320006276, 13.255299549077277,
        -42.83198983095609, 1.9193816666300925, -0.6047866392790372, -0.9709092082992538,
        -16113.08671575675, -2509.8864732395355, 7770.155892909722, 21.67951069055322,
        -367.27216215603454, 186.03621554224745, 16113.08671575675, 2509.8864732395355,
        -7770.155892909722, 342.6420212808097, -102.96794787084858, -158.42691443144525,
        -15549.15139888532, -6330.730058691331, 3709.554003856936, -316.93952459433683,
        -190.9640311154001, -123.25107039134528, 15549.15139888532, 6330.730058691331,
        -3709.554003856936, 353.24764832667245, -71.2299697853252, 210.46824811017802,
        -167.00789945254465, -10.94466431244001, 62.19414022386742, 1.2853257126323592,
        -1.9786073775226074, 1.7713125426474017, 167.00789945254465, 10.94466431244001,
        -62.19414022386742, 1.9832728281251188, -0.6982158719831446, -1.6097419459468338,
        -161.64109786499264, -45.44013025005055, 25.692907598652646, -2.2020394107037675,
        -0.1918131942798127, -1.3511389950975268, 161.64109786499264, 45.44013025005055,
        -25.692907598652646, 2.112192708829218, -0.2763523223593465, 2.151967576493116,
    ),
    ("pair", -0.001, True): (
        -2.8830432128599996, -1.0806829598633783, 0.7212012328816516, -0.058539440863911774,
        -0.03481463953524404, -0.02195215590463024, 2.8830432128599996, 1.0806829598633783,
        -0.7212012328816516, 0.0653619759732409, -0.011935723128422598, 0.03859727984444638,
        -5133.758947180483, -1929.8933923003337, 1289.205338386782, -104.36010426131335,
        -62.033380630239265, -39.00910346564297, 5133.758947180483, 1929.8933923003337,
        -1289.205338386782, 116.47898351126841, -21.150569728566992, 68.72324203154879,
        -5133.637106565586, -1930.6626471619732, 1288.3911863951928, -104.40746597845752,
        -62.04719799091408, -39.085405104847254, 5133.637106565586, 1930.6626471619732,
        -1288.3911863951928, 116.46211165886514, -21.166036732728298, 68.83759895384286,
        -6.599883704535572, 0.6367313806552266, -1.833521352709629, 0.08915350081913376,
        0.3402460215942231, -0.09746563735783925, 6.599883704535572, -0.6367313806552266,
        1.833521352709629, -0.20711331651463893, 0.06950290603211565, 0.11163095707424353,
        -6.599766979364273, 0.6359953289935203, -1.834300040225652, 0.08907480991635469,
        0.3402861871327921, -0.09753477902593805, 6.599766979364273, -0.6359953289935203,
        1.834300040225652, -0.20710988301827077, 0.06951341095128769, 0.11171518070057673,
    ),
    ("body_plane", -0.01, False): (
        47.024997795284044, 96.13352493147855, -28.51306819585232, -1.6182804294982478,
        3.191289803439404, 1.420063827062918, -47.024997795284044, -96.13352493147855,
        28.51306819585232, -0.791734461585165, 2.4380593813350666, 0.30143309013959896,
        -4988.06319482824, -10348.05245530758, 3034.404298528045, 98.37195594835802,
        -415.035750451853, -192.00743582345024, 4988.06319482824, 10348.05245530758,
        -3034.404298528045, 82.10605262859318, -263.4355300038996, -31.60128207693243,
        -5036.320840495375, -8074.837670708171, 5622.710584017987, 265.0694503138256,
        -512.705736735881, -131.91461074482044, 5036.320840495375, 8074.837670708171,
        -5622.710584017987, 183.8141018500306, 25.721885179809362, 74.07132588394741,
        -87.72240153113378, -76.14131291881783, 12.621934305787345, 2.726279499218212,
        -1.8698388852861298, 0.8118718422291897, 87.72240153113378, 76.14131291881783,
        -12.621934305787345, 4.826130315140464, -4.301988500446539, 0.7791361752544432,
        -88.11730542048997, -56.22615460218768, 35.6467157508732, 3.7278188893567603,
        -2.4713276784002574, 1.188186432068, 88.11730542048997, 56.22615460218768,
        -35.6467157508732, 5.723699450534998, -1.6940296666888381, 1.7685252827733375,
    ),
    ("body_plane", -0.001, True): (
        1.4507145137142794, 2.3077293812784743, -1.6031021239484857, -0.08129784318589692,
        0.11670115580050502, 0.031482500966999796, -1.4507145137142794, -2.3077293812784743,
        1.6031021239484857, -0.05271326460988321, -0.008243934644147174, -0.022196168621720372,
        -1550.6622406587353, -2470.558391146405, 1714.770046248499, 85.43862242615376,
        -127.51806718917754, -34.061489961767315, 1550.6622406587353, 2470.558391146405,
        -1714.770046248499, 56.355366416356674, 8.777142804532922, 23.747940504830858,
        -1550.67315604134, -2470.114939952414, 1715.2854970463068, 85.35636119549434,
        -127.57217341306898, -34.14800623797307, 1550.67315604134, 2470.114939952414,
        -1715.2854970463068, 56.380625582709214, 8.857300006296386, 23.749782521542514,
        -10.079476518874802, 1.2746010085896842, -0.9115087944742775, 0.2890808290869006,
        0.03935474163689566, 0.4044733938738513, 10.079476518874802, -1.2746010085896842,
        0.9115087944742775, 0.8910001482001499, -0.3387747011223241, 0.2567027378947555,
        -10.079486606295394, 1.2750243799600158, -0.9110163059089471, 0.28909732347248907,
        0.03934468982689179, 0.40448249424420524, 10.079486606295394, -1.2750243799600158,
        0.9110163059089471, 0.8910193937803709, -0.3387190598143822, 0.2567238833177278,
    ),
}


@pytest.mark.parametrize("key", list(RECORDED), ids=[f"{k[0]}-{'slow' if k[2] else 'pressed'}" for k in RECORDED])
def test_two_body_kernels_match_recorded_values(key):
    from femb.system import kernels as K
    name, gap, slow = key
    model, st = (_pair if name == "pair" else _body_plane)(gap)
    if slow:
        st.qd[:] *= 1e-4
    g = model.force_groups[-1]
    v = np.concatenate((st.qd, np.zeros(model.nfix_v)))
    xe, ve = model.ext(st.q)[g.xdofs], v[g.dofs]
    fe, fq, fv = np.zeros((1, 12)), np.zeros((1, 12, 12)), np.zeros((1, 12, 12))
    K._kernel(g, "force")(g.P, 0.0, K.time_values(g, 0.0), xe, ve, True, fe, fq, fv)
    w = np.random.default_rng(7).uniform(-1, 1, 12)
    got = np.concatenate((fe[0], fq[0] @ w, w @ fq[0], fv[0] @ w, w @ fv[0]))
    ref = np.array(RECORDED[key])
    assert np.abs(got - ref).max() < 1e-11 * np.abs(ref).max()

"""Readable results: point kinematics, reactions with moments, interpolation, energies, tables and plots."""
import math

import numpy as np
import pytest

import femb
from femb import Mechanism
from femb.elements import (DrivenAngle, Force, Gravity, Hinge, PointMass, RigidBody, Section, SpringDamper, Torque,
                           add_beam)
from femb.analysis.static import solve_static
from femb.errors import ModelError

G = 9.81


def pendulum(extra=False):
    m = Mechanism("pendulum")
    bar = m.add(RigidBody("bar", 2.0, 2.0 / 12, position=(0.5, 0.0), points={"O": (-0.5, 0.0), "tip": (0.5, 0.0)}))
    m.add(Hinge("pivot", "ground", bar, point_b="O"))
    m.add(Gravity((0.0, -G)))
    if extra:
        p = m.add(PointMass("p", 0.5, position=(1.0, -0.6)))
        m.add(SpringDamper("spring", bar, p, 80.0, damping=0.8, point_a="tip", length=0.5))
        m.add(Force("push", bar, (1.5, 0.0), point="tip"), Torque("twist", bar, -0.7))
    return m.compile()


@pytest.fixture(scope="module")
def run():
    return femb.simulate(pendulum(), 1.0, 1e-3)


def test_point_kinematics(run):
    # the hinge point stays at the origin; the index-3 scheme satisfies the velocity and acceleration
    # constraints to O(h²) only (Arnold & Brüls 2007): 7.8e-6 m/s and 2.1e-4 m/s² at h = 1e-3 s,
    # four times less at h/2 (measured)
    assert np.abs(run.point("bar", "O")).max() < 1e-10
    assert np.abs(run.point_velocity("bar", "O")).max() < 1e-5
    assert np.abs(run.point_acceleration("bar", "O")).max() < 3e-4
    # the tip: |r| = 1 along the bar; rigid-body kinematics relative to O: v = ω J d, a = α J d − ω² d
    r, v, a = run.point("bar", "tip"), run.point_velocity("bar", "tip"), run.point_acceleration("bar", "tip")
    th = run.body("bar")
    om, al = run.body("bar", "qd")[:, 2], run.body("bar", "qdd")[:, 2]
    np.testing.assert_allclose(np.linalg.norm(r, axis=1), 1.0, atol=1e-10)
    np.testing.assert_allclose(r, np.stack((np.cos(th[:, 2]), np.sin(th[:, 2])), axis=1), atol=1e-10)
    d = r - run.point("bar", "O")
    Jd = np.stack((-d[:, 1], d[:, 0]), axis=1)
    np.testing.assert_allclose(v - run.point_velocity("bar", "O"), om[:, None] * Jd, atol=1e-12)
    np.testing.assert_allclose(a - run.point_acceleration("bar", "O"), al[:, None] * Jd - om[:, None] ** 2 * d,
                               atol=1e-11)
    # the derivative of the stored positions agrees (central differences, O(h²))
    dt = run.t[1] - run.t[0]
    np.testing.assert_allclose(np.gradient(r, dt, axis=0)[1:-1], v[1:-1], atol=1e-4)     # |v| up to 4 m/s
    np.testing.assert_allclose(run.position("bar", "tip"), r)
    with pytest.raises(ModelError, match="no point named 'knee'"):
        run.point("bar", "knee")
    with pytest.raises(ModelError, match="no body named 'arm'"):
        run.point_velocity("arm")


def test_reaction_force_and_moment(run):
    lam = run.reaction("pivot")
    R = run.reaction_at("pivot")                      # on the bar, about its point O
    np.testing.assert_allclose(R[:, :2], lam, atol=1e-12)
    np.testing.assert_allclose(R[:, 2], 0.0, atol=1e-12)
    # about the centre: M = (r_O − r_c) × F
    Rc = run.reaction_at("pivot", point=(0.0, 0.0))
    d = run.point("bar", "O") - run.point("bar")
    np.testing.assert_allclose(Rc[:, 2], d[:, 0] * lam[:, 1] - d[:, 1] * lam[:, 0], atol=1e-12)
    # Newton's second law for the bar: m a_c = F + m g
    a_c = run.point_acceleration("bar")
    np.testing.assert_allclose(2.0 * a_c, lam + [0.0, -2.0 * G], atol=1e-6)
    # on the ground: the opposite
    np.testing.assert_allclose(run.reaction_at("pivot", on="a"), -R, atol=1e-12)
    with pytest.raises(ModelError, match="'bar' is a body, not a joint"):
        run.reaction("bar")
    with pytest.raises(ModelError, match="on must be"):
        run.reaction_at("pivot", on="c")


def test_clamp_moment_of_a_cantilever():
    """Static cantilever under a tip load P: the clamp holds it with F = (0, P) and M = P L at the root."""
    P, L = 1e-4, 1.0
    m = Mechanism("cantilever")
    b = add_beam(m, "b", Section(1e7, 1e7, 1.0, 1.0, 1e-3), (0.0, 0.0), (L, 0.0), 4, start_joint="clamp")
    m.add(Force("P", b.nodes[-1], (0.0, -P)))
    res = solve_static(m.compile())
    R = res.reaction_at("b.start")[-1]
    tip = res.body("b.n4")[-1]
    np.testing.assert_allclose(R, [0.0, P, P * tip[0]], atol=1e-12)
    with pytest.raises(ModelError, match="SpringDamper 'spring' has no constraint equations|no constraint"):
        femb.simulate(pendulum(True), 0.01, 1e-3).reaction("spring")


def test_at_interpolates_and_refuses_outside(run):
    coarse = femb.simulate(pendulum(), 1.0, 1e-3, stride=20)
    for t in (0.0, 0.02, 0.5, 1.0):
        st = coarse.at(t)
        k = int(round(t / 1e-3))
        assert st.t == t and np.array_equal(st.q, run.q[k])
    for t in (0.0107, 0.3333, 0.9871):
        st = coarse.at(t)
        k = int(round(t / 1e-3))
        exact = run.at(k * 1e-3)
        st = coarse.at(k * 1e-3)
        assert np.abs(st.q - exact.q).max() < 1e-6           # cubic Hermite over 0.02 s
        assert np.abs(st.qd - exact.qd).max() < 1e-4
        assert np.abs(st.lam - exact.lam).max() < 0.15        # linear: Δt²/8 |λ''| (|λ| ≈ 30 N)
    with pytest.raises(ModelError, match="outside the stored interval"):
        coarse.at(1.5)
    with pytest.raises(ModelError, match="outside"):
        coarse.at(-0.1)
    assert coarse.nearest(0.03) == 1 and coarse.nearest(0.031) == 2


def test_energy_balance():
    # conservative: T + V constant up to the scheme's small numerical dissipation
    res = femb.simulate(pendulum(), 1.0, 1e-3, rho_inf=0.95)
    e = res.energy()
    assert np.ptp(e["kinetic"]) > 5.0
    assert res.energy_balance() < 1e-4
    np.testing.assert_allclose(e["total"], e["total"][0], atol=5e-4 * np.ptp(e["kinetic"]))
    # with a damped spring, a force and a torque, the balance needs every term
    res = femb.simulate(pendulum(True), 1.0, 1e-3, rho_inf=0.95)
    e = res.energy()
    assert e["dissipated"][-1] > 0.01 and abs(e["work_loads"][-1]) > 0.1 and np.ptp(e["elastic"]) > 0.01
    assert np.all(np.diff(e["dissipated"]) >= -1e-15)
    assert res.energy_balance() < 1e-3
    assert abs(e["balance"][-1]) < 1e-3 * abs(e["work_loads"][-1])


def test_energy_of_a_driven_crank():
    """A crank driven at constant speed against gravity: the drive's work equals the change of energy."""
    m = Mechanism("driven")
    bar = m.add(RigidBody("bar", 1.0, 1 / 12, position=(0.5, 0.0), points={"O": (-0.5, 0.0)}))
    m.add(Hinge("pivot", "ground", bar, point_b="O"))
    m.add(DrivenAngle("motor", "ground", bar, (lambda t: 2.0 * t, lambda t: 2.0, lambda t: 0.0)))
    m.add(Gravity((0.0, -G)))
    model = m.compile()
    res = femb.simulate(model, 1.0, 1e-3, state=femb.consistent_initial_state(model))
    e = res.energy()
    assert abs(e["work_drives"][-1]) > 1.0
    assert res.energy_balance() < 1e-4


def test_to_pandas_and_plot(run, tmp_path):
    pd = pytest.importorskip("pandas")
    df = run.to_pandas()
    assert isinstance(df, pd.DataFrame) and df.index.name == "t" and len(df) == run.t.size
    for col in ("bar.x", "bar.theta", "bar.theta_d", "pivot.x", "pivot.y"):
        assert col in df.columns
    np.testing.assert_array_equal(df["pivot.y"].to_numpy(), run.reaction("pivot")[:, 1])
    sel = run.to_pandas(["bar.tip.y", "pivot.M", "energy.kinetic"])
    assert list(sel.columns) == ["bar.tip.y", "pivot.M", "energy.kinetic"]
    assert sel.attrs["units"] == {"bar.tip.y": "m", "pivot.M": "N·m", "energy.kinetic": "J"}
    np.testing.assert_allclose(sel["bar.tip.y"], run.point("bar", "tip")[:, 1])
    with pytest.raises(ModelError, match="output 'bar.knee.x'"):
        run.series("bar.knee.x")
    out = tmp_path / "p.png"
    fig = run.plot(["bar.theta", "pivot.y", "energy.total"], file=out)
    assert out.stat().st_size > 1000 and len(fig.axes) == 3
    assert fig.axes[1].get_ylabel() == "pivot.y (λ)"

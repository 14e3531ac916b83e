"""The sparse path's broad phase (femb/contact/broadphase.py, docs/contact.md §7 "Broad phase"): each step
solved on the contacts that can close in it gives the solution of the step on every contact."""
import itertools

import numpy as np
import pytest

from femb import Mechanism
from femb.contact import assemble, broadphase, simulate
from femb.contact import step as contact_step
from femb.elements import Gravity, RigidBody, SpatialGravity, SpatialRigidBody
from femb.elements.contact import DiscOnDisc, SphereOnPlane, SpatialSphereOnPlane, SpatialSpherePair
from femb.system import kernels

R = 0.05
#: Newton tolerance of the runs compared: a step solved on a subset of the contacts takes another path to its
#: solution than the step on all of them, and at the default 1e-12 L the two ends can differ by what the
#: tolerance leaves open, which impacts amplify (the planar discs below: 5e-5 rad at 1e-12, 7e-18 at 1e-14)
TOL = 1e-14


def _pile(n, v=0.4, seed=3, pitch=0.104, e_N=0.5, mu=0.3):
    """n spheres resting on the floor on a grid (gaps 4 mm), pushed at each other; every pair declared."""
    rng = np.random.default_rng(seed)
    side = int(np.ceil(np.sqrt(n)))
    m = Mechanism("pile")
    m.add(SpatialGravity((0.0, 0.0, -9.81)))
    for i in range(n):
        m.add(SpatialRigidBody(f"s{i}", 1.0, (0.4 * R * R,) * 3, position=(pitch * (i % side), pitch * (i // side), R),
                               velocity=(*rng.uniform(-v, v, 2), 0.0), omega=tuple(rng.uniform(-5.0, 5.0, 3))))
        m.add(SpatialSphereOnPlane(f"c{i}", f"s{i}", radius=R, mu=mu, e_N=e_N))
    for i, j in itertools.combinations(range(n), 2):
        m.add(SpatialSpherePair(f"p{i}_{j}", f"s{i}", f"s{j}", radius_a=R, radius_b=R, mu=mu, e_N=e_N))
    return m.compile()


def _same(a, b, L=1.0, tol=1e-10):
    """The two results agree to round-off: coordinates, velocities, every per-contact output, the events."""
    assert a.q.shape == b.q.shape
    assert np.max(np.abs(a.q - b.q)) <= tol * L
    assert np.max(np.abs(a.qd - b.qd)) <= 1e3 * tol
    for k in ("gN", "gN_d", "gam_F", "lam_N", "Lam_N", "P_N", "lam_F", "P_F"):
        x, y = np.asarray(a.contact[k]), np.asarray(b.contact[k])
        assert np.all(np.isfinite(x)), k
        assert np.max(np.abs(x - y), initial=0.0) <= 1e3 * tol, k
    assert np.array_equal(a.contact["state"], b.contact["state"])
    assert [(e["contact"], e["step"]) for e in a.events] == [(e["contact"], e["step"]) for e in b.events]
    assert np.max(np.abs(np.array([e["t"] for e in a.events]) - np.array([e["t"] for e in b.events])),
                  initial=0.0) <= tol


def _unit(p):
    return tuple(p / np.linalg.norm(p))


def _kernel_rows(model, q, u):
    ev = assemble.evaluate(model, 0.0, q, u)
    return ev["gN"], ev["WN"] @ u


@pytest.mark.parametrize("planar", [False, True])
def test_sphere_pairs_are_the_kernels_gaps_and_normal_velocities(planar):
    """``sphere_pairs`` of SpatialSpherePair and DiscOnDisc (off-centre spheres on turned, moving bodies)
    gives the kernel's g_N and W_N u."""
    rng = np.random.default_rng(0)
    m = Mechanism("two")
    if planar:
        m.add(RigidBody("a", 1.0, 0.1, position=(0.0, 0.0), angle=0.3, velocity=(0.2, -0.1), omega=1.5))
        m.add(RigidBody("b", 1.0, 0.1, position=(0.5, 0.1), angle=-0.7, velocity=(-0.3, 0.4), omega=-2.0))
        m.add(DiscOnDisc("p", "a", "b", 0.1, 0.15, point_a=(0.05, 0.02), point_b=(-0.03, 0.04)))
    else:
        m.add(SpatialRigidBody("a", 1.0, (0.1, 0.1, 0.1), position=(0.0, 0.0, 0.0), velocity=(0.2, -0.1, 0.3),
                               omega=tuple(rng.normal(size=3)), rotation=_unit(rng.normal(size=4))))
        m.add(SpatialRigidBody("b", 1.0, (0.1, 0.1, 0.1), position=(0.5, 0.1, -0.2), velocity=(-0.3, 0.4, 0.0),
                               omega=tuple(rng.normal(size=3)), rotation=_unit(rng.normal(size=4))))
        m.add(SpatialSpherePair("p", "a", "b", 0.1, 0.15, point_a=(0.05, 0.02, -0.01), point_b=(-0.03, 0.04, 0.02)))
    model = m.compile()
    st = model.initial_state()
    gN, gNd = _kernel_rows(model, st.q, st.qd)
    bp = broadphase.BroadPhase(model)
    assert bp.n == 1
    g, rate, speed, size = bp.spheres(st.q, st.qd)
    assert g[0] == pytest.approx(gN[0], abs=1e-15)
    assert rate[0] == pytest.approx(gNd[0], abs=1e-14)
    assert speed[0] >= abs(rate[0]) and size[0] == pytest.approx(0.25)


def test_subset_evaluates_as_the_model():
    """A ContactSubset's contacts are the model's rows, in the model's order, and its kernels give them."""
    model = _pile(6)
    st = model.initial_state()
    full = assemble.evaluate(model, 0.0, st.q, st.qd)
    keep = [np.array([1, 4]), np.array([0, 3, 7])] if len(model.contact_groups) == 2 else None
    assert keep is not None
    sub = broadphase.ContactSubset(model, keep)
    part = assemble.evaluate(sub, 0.0, st.q, st.qd)
    assert sub.n_contacts == 5 and np.all(np.diff(sub.rows_N) > 0) and np.all(np.diff(sub.rows_F) > 0)
    assert np.array_equal(part["gN"], full["gN"][sub.rows_N])
    assert np.allclose((part["WN"] @ st.qd), (full["WN"] @ st.qd)[sub.rows_N], atol=1e-15)
    assert np.allclose((part["WF"] @ st.qd), (full["WF"] @ st.qd)[sub.rows_F], atol=1e-15)
    assert assemble.layout(sub).names == [assemble.layout(model).names[i] for i in sub.rows_N]


def test_colliding_pile_as_without_the_broad_phase():
    """Spheres pushed at each other on the floor, every pair declared: the pairs that collide join the
    steps (impacts on pairs occur), the far ones stay out, and the result is the one without the broad phase."""
    model = _pile(12)
    a = simulate(model, 0.04, 1e-3, tol=TOL)
    b = simulate(model, 0.04, 1e-3, broad_phase=False, tol=TOL)
    assert sum(e["contact"].startswith("p") for e in a.events) >= 2
    _same(a, b)
    assert a.contact["gN"].min() >= -1e-10


def test_broad_phase_is_used_and_leaves_far_pairs_out():
    model = _pile(12)
    st = simulate(model, 0.01, 1e-3).stats["broad_phase"]
    assert st["solves"] >= 10 and st["rebuilt"] >= 1
    assert st["mean_contacts"] < 0.5 * model.n_contacts      # 12 floor contacts and a few of the 66 pairs
    assert "broad_phase" not in simulate(model, 0.002, 1e-3, broad_phase=False).stats


def test_pairs_left_out_that_come_close_are_added(monkeypatch):
    """With no pair a candidate at the start of a step (the margin set to nothing), the check at the step's
    end adds the pairs that came close and solves again: the same result.

    Over the first 16 steps, to 1e-17 m. (In the 17th a pair's impact is taken in a substep of 1e-7 s, whose
    velocities the Newton tolerance fixes to tol/h = 1e-7 m/s: the two runs part there by 5e-11 m/s, which
    the slip–stick of the next substep raises to 1e-8 m/s.)"""
    model = _pile(12)
    b = simulate(model, 0.016, 1e-3, broad_phase=False, tol=TOL)
    monkeypatch.setattr(broadphase, "NEAR", 0.0)
    monkeypatch.setattr(broadphase.BroadPhaseStep, "_candidates",
                        lambda self, s: ~self._pair | ~self._negligible(s))
    stats = {}
    real = broadphase.BroadPhaseStep.solve

    def spy(self, s):
        out = real(self, s)
        stats.update(self.stats)
        return out

    monkeypatch.setattr(broadphase.BroadPhaseStep, "solve", spy)
    a = simulate(model, 0.016, 1e-3, tol=TOL)
    assert stats["repeated"] >= 1
    _same(a, b)


def test_stride_and_left_out_rates(monkeypatch):
    """With a stride the left-out pairs' normal and slip velocities are computed at the stored rows only,
    and equal those of the run that stores every step."""
    model = _pile(12)
    a = simulate(model, 0.03, 1e-3, stride=7, tol=TOL)
    b = simulate(model, 0.03, 1e-3, broad_phase=False, tol=TOL)
    keep = [0, 7, 14, 21, 28, 30]
    assert np.allclose(a.t, b.t[keep], atol=1e-15)
    for k in ("gN_d", "gam_F", "gN"):
        assert np.max(np.abs(np.asarray(a.contact[k]) - np.asarray(b.contact[k])[keep])) <= 1e-7, k


def test_planar_discs(monkeypatch):
    """DiscOnDisc pairs on the sparse path (forced here for a small model): as without the broad phase."""
    monkeypatch.setattr(contact_step, "DENSE_MAX_UNKNOWNS", 0)
    monkeypatch.setattr(broadphase, "BROAD_PHASE_MIN", 4)
    m = Mechanism("discs")
    m.add(Gravity((0.0, -9.81)))
    rng = np.random.default_rng(1)
    n = 6
    for i in range(n):
        m.add(RigidBody(f"d{i}", 1.0, 0.5 * R * R, position=(0.104 * i, R), velocity=(rng.uniform(-0.5, 0.5), 0.0),
                   omega=rng.uniform(-3.0, 3.0)))
        m.add(SphereOnPlane(f"c{i}", f"d{i}", radius=R, mu=0.3))
    for i, j in itertools.combinations(range(n), 2):
        m.add(DiscOnDisc(f"p{i}_{j}", f"d{i}", f"d{j}", R, R, mu=0.2, e_N=0.7))
    model = m.compile()
    a = simulate(model, 0.05, 1e-3, tol=TOL)
    b = simulate(model, 0.05, 1e-3, broad_phase=False, tol=TOL)
    assert sum(e["contact"].startswith("p") for e in a.events) >= 1
    _same(a, b)


def test_broad_phase_option_checked():
    model = _pile(3)
    with pytest.raises(Exception, match="unknown keyword"):
        simulate(model, 0.01, 1e-3, broad_fase=False)


def test_adaptive_steps_as_without_the_broad_phase():
    model = _pile(12)
    a = simulate(model, 0.02, 1e-3, rtol=1e-4, tol=TOL)
    b = simulate(model, 0.02, 1e-3, rtol=1e-4, tol=TOL, broad_phase=False)
    assert a.stats["rejected_steps"] == b.stats["rejected_steps"]
    _same(a, b)
    assert a.stats["broad_phase"]["mean_contacts"] < 0.5 * model.n_contacts


def test_a_failing_step_stops_with_the_partial_result(monkeypatch):
    """A step without a solution on the subset stops the run as it does without the broad phase: a
    ContactError naming time and step, with the steps taken before (every contact's outputs finite)."""
    from femb.errors import ContactError

    model = _pile(12)
    real, calls = contact_step.NonsmoothStep.solve, [0]

    def failing(self, s):
        calls[0] += 1
        if s.t >= 0.005 - 1e-12:
            raise contact_step.StepFailure("no solution here (test)", None, None)
        return real(self, s)

    monkeypatch.setattr(contact_step.NonsmoothStep, "solve", failing)
    with pytest.raises(ContactError, match=r"step 6 from t = 0\.005") as err:
        simulate(model, 0.02, 1e-3)
    res = err.value.result
    assert res.status == "failed" and res.t[-1] == pytest.approx(0.005)
    assert all(np.all(np.isfinite(np.asarray(res.contact[k], float))) for k in res.contact)


def test_dense_models_with_many_pairs():
    """Ten spheres, 45 pairs, 565 unknowns (the dense path): the broad phase runs (Python loop, subsets)
    and gives the compiled loop's result on every contact; below BROAD_PHASE_DENSE_MIN unknowns, or with
    compiled=True, the compiled loop runs."""
    model = _pile(10)
    a = simulate(model, 0.03, 1e-3, tol=TOL)
    b = simulate(model, 0.03, 1e-3, tol=TOL, broad_phase=False)
    assert "broad_phase" in a.stats and "broad_phase" not in b.stats
    _same(a, b)
    assert "broad_phase" not in simulate(model, 0.002, 1e-3, compiled=True).stats
    assert "broad_phase" not in simulate(_pile(7), 0.002, 1e-3).stats       # 21 pairs

"""The compiled dense path of the nonsmooth step against the numpy/scipy path it replaces.

Small systems (``femb.contact.step.DENSE_MAX_UNKNOWNS``) run the semismooth Newton iteration
compiled (femb/contact/core.py, femb/contact/dense.py, femb/contact/batches.py); larger ones run
the sparse numpy/scipy code of :class:`femb.contact.step.NonsmoothStep`. Setting the limit to 0
sends a small model through the sparse code, so the two can be compared on the same model: the
same trajectory to round-off, through impacts, slip, stick, hinges, spatial rotations and the
prox fixed-point fallback.
"""
import numpy as np
import pytest

from femb.benchmarks.scenes.contact import contact_ball, contact_slider_crank, contact_tippetop
from femb.contact import simulate
from femb.contact import step as contact_step
from femb.contact.result import SLIP


def _both(monkeypatch, model, t_end, h, **kw):
    dense = simulate(model, t_end, h, **kw)
    with monkeypatch.context() as m:
        m.setattr(contact_step, "DENSE_MAX_UNKNOWNS", 0)
        sparse = simulate(model, t_end, h, **kw)
    return dense, sparse


def _same(a, b, tol):
    assert a.t.shape == b.t.shape
    assert np.max(np.abs(a.q - b.q)) <= tol
    assert np.max(np.abs(a.qd - b.qd)) <= tol * 1e3
    assert np.max(np.abs(a.contact["lam_N"] - b.contact["lam_N"])) <= tol * 1e3
    assert np.max(np.abs(a.contact["P_N"] - b.contact["P_N"])) <= tol * 1e3
    assert [e["contact"] for e in a.events] == [e["contact"] for e in b.events]
    assert np.allclose([e["t"] for e in a.events], [e["t"] for e in b.events], rtol=0.0, atol=1e-12)


def test_small_models_run_the_compiled_iteration():
    from femb.contact import assemble
    from femb.solve.alpha import GeneralizedAlpha
    for build in (contact_ball.build, contact_slider_crank.build, contact_tippetop.build):
        model = build().compile()
        st = contact_step.NonsmoothStep(model, 1e-3, GeneralizedAlpha.from_rho_inf(0.8), assemble.layout(model), 1e-12)
        assert st.dense and st._loop_ok


@pytest.mark.parametrize("omega0", [0.0, 50.0])
def test_ball_bounces_and_backspin_as_the_sparse_path(monkeypatch, omega0):
    model = contact_ball.build(omega0=omega0, mu=0.2, e_N=0.5 if omega0 == 0.0 else 0.0).compile()
    dense, sparse = _both(monkeypatch, model, 0.8, 2e-3)
    assert len(dense.events) >= 1
    _same(dense, sparse, 1e-12)


def test_slider_crank_hinges_and_corners_as_the_sparse_path(monkeypatch):
    # up to its first cluster of impacts (t < 8e-3 s): afterwards round-off decides between
    # neighbouring micro-impacts and the two paths drift apart by more than round-off
    model = contact_slider_crank.build().compile()
    dense, sparse = _both(monkeypatch, model, 6e-3, 2e-4)
    assert len(dense.events) >= 2
    _same(dense, sparse, 1e-12)


def test_tippe_top_rotations_as_the_sparse_path(monkeypatch):
    model = contact_tippetop.build().compile()
    dense, sparse = _both(monkeypatch, model, 0.03, 1e-3)
    assert dense.q.shape[1] == 7
    _same(dense, sparse, 1e-12)


def test_fixed_point_fallback_as_the_sparse_path(monkeypatch):
    # four semismooth Newton iterations are too few at one of the slider's impacts: the prox fixed point
    # runs there (its inner problem with fixed contact unknowns on the compiled path)
    model = contact_slider_crank.build().compile()
    dense, sparse = _both(monkeypatch, model, 6e-3, 2e-4, max_iter=4)
    assert dense.stats["fixed_point_steps"] >= 1
    assert dense.stats["fixed_point_steps"] == sparse.stats["fixed_point_steps"]
    _same(dense, sparse, 1e-12)


def test_papers_slip_law_as_the_sparse_path(monkeypatch):
    """The slip law (138b) on the whole percussions (NonsmoothStep.slip_on_P) on every step: the compiled
    residual and Jacobian against the numpy ones, on the tippe top (a slip whose direction turns)."""
    monkeypatch.setattr(contact_step.NonsmoothStep, "slip_on_P", True)
    model = contact_tippetop.build().compile()
    dense, sparse = _both(monkeypatch, model, 0.03, 1e-3)
    assert np.any(dense.contact["state"] == SLIP)
    _same(dense, sparse, 1e-12)

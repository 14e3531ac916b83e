"""The compiled time loop of femb.contact (femb/contact/loop.py) against the Python loop, scene by scene:
the same steps, substeps, impacts and outputs (to round-off), the same failure and diagnosis."""
import math

import numpy as np
import pytest

import femb
from femb.benchmarks.scenes.contact import (
    contact_ball, contact_beam_stop, contact_block, contact_painleve, contact_rocking, contact_slider_crank, contact_sphere3d,
    contact_tippetop)
from femb.contact import simulate
from femb.contact.loop import first_root
from femb.contact.step import NonsmoothStep
from femb.elements import Gravity, RigidBody
from femb.elements.contact import SphereOnPlane
from femb.errors import ContactError, ParameterError

RTOL = 1e-12


def _ball(e_N, mu=0.0, y0=1.0):
    m = femb.Mechanism("ball")
    m.add(RigidBody("ball", 1.0, 0.004, position=(0.0, y0)))
    m.add(Gravity((0.0, -9.81)))
    m.add(SphereOnPlane("floor", "ball", radius=0.1, e_N=e_N, mu=mu))
    return m.compile()


SCENES = {
    "ball": (lambda: contact_ball.build(e_N=0.5).compile(), 1.5, 2e-3),
    "backspin 50": (lambda: contact_ball.build(e_N=0.0, mu=0.2, omega0=50.0).compile(), 1.0, 2e-3),
    "backspin 10": (lambda: contact_ball.build(e_N=0.0, mu=0.2, omega0=10.0).compile(), 0.6, 2e-3),
    "block": (lambda: contact_block.build(mu=0.5).compile(), 1.0, 1e-2),
    "rocking": (lambda: contact_rocking.build().compile(), 0.8, 2e-3),
    "sphere 3d": (lambda: contact_sphere3d.build().compile(), 0.6, 2e-3),
    "tippe top": (lambda: contact_tippetop.build().compile(), 0.2, 2e-3),
    "thousand bounces": (lambda: _ball(1.0, mu=0.3, y0=0.1 + 0.25e-6), 0.5, 1e-3),
    "painleve mu = 0.3": (lambda: contact_painleve.build(mu=0.3).compile(), 0.2, 1e-3),
    # μ = 5/3 falling at 20 m/s onto the floor: one step needs the prox fixed point (the Python loop takes it)
    "painleve impact": (lambda: contact_painleve.build(mu=5.0 / 3.0, v0=-20.0, gap=1e-3).compile(), 0.3, 1e-3),
    "beam stop": (lambda: contact_beam_stop.build().compile(), 0.28, 1e-3),
}


def _close(a, b, what, upto=None):
    a, b = np.atleast_1d(np.asarray(a, dtype=float))[:upto], np.atleast_1d(np.asarray(b, dtype=float))[:upto]
    assert a.shape == b.shape, what
    scale = max(1.0, float(np.max(np.abs(a), initial=0.0)))
    err = float(np.max(np.abs(a - b), initial=0.0))
    assert err <= RTOL * scale, f"{what}: {err:.3e} (scale {scale:.3e})"


def _same(py, c, upto=None):
    """Every stored output of the two runs equal to round-off (the first ``upto`` steps)."""
    for key in ("t", "q", "qd", "qdd", "lam"):
        _close(getattr(py, key), getattr(c, key), key, upto)
    for key, v in py.contact.items():
        _close(v, c.contact[key], key, upto)
    n = len(py.events) if upto is None else sum(e["step"] < upto for e in py.events)
    assert len(c.events) >= n
    for e, f in zip(py.events[:n], c.events[:n]):
        assert e["contact"] == f["contact"] and e["step"] == f["step"]
        for key in ("t", "v_before", "v_after", "Lambda_N", "P_N", "u_before", "u_after"):
            _close(e[key], f[key], f"event {key}")
    if upto is None:
        assert len(c.events) == n
        np.testing.assert_array_equal(py.newton_iterations, c.newton_iterations)
        assert py.stats == c.stats


def _both_loops_agree(name):
    """Scene ``name`` of SCENES through both loops: both succeed with the same outputs; the compiled run."""
    build, t_end, h = SCENES[name]
    model = build()
    py = simulate(model, t_end, h, compiled=False)
    c = simulate(model, t_end, h, compiled=True)
    assert py.status == c.status == "success"
    _same(py, c)
    return c


@pytest.mark.parametrize("name", list(SCENES))
def test_compiled_loop_equals_python_loop(name):
    c = _both_loops_agree(name)
    if name == "painleve impact":
        assert c.stats["fixed_point_steps"] == 1


@pytest.mark.parametrize("name", ["backspin 50", "tippe top"])
def test_compiled_loop_equals_python_loop_with_the_papers_slip_law(monkeypatch, name):
    """The slip law (138b) on the whole percussions (NonsmoothStep.slip_on_P, the second pass of a step that
    has no solution with femb's law on Λ) on every step, in both loops: a straight slip and one whose
    direction turns."""
    monkeypatch.setattr(NonsmoothStep, "slip_on_P", True)
    _both_loops_agree(name)


def test_slider_crank_up_to_its_first_branch():
    """The clearance slider–crank: its micro-impact clusters (impacts within 1e-4 h of each other) may
    branch on round-off; the runs agree to round-off up to the first step where an output differs by more
    than 1e-9 (and over at least the first 50 steps and its first impacts)."""
    model = contact_slider_crank.build().compile()
    py = simulate(model, 0.02, 1e-4, compiled=False)
    c = simulate(model, 0.02, 1e-4, compiled=True)
    d = np.max(np.abs(py.q - c.q), axis=1)
    upto = int(np.argmax(d > 1e-9)) if np.any(d > 1e-9) else py.t.size
    assert upto >= 50
    assert sum(e["step"] < upto for e in py.events) >= 1
    _same(py, c, upto)


def test_step_failure_is_the_same():
    """A step that finds no contact force (the μ = 5/3 rod dropped at 20 m/s, one fixed-point iteration
    allowed) is handed to the Python loop, which raises the same ContactError (time, step, contact,
    diagnosis) with the same partial result; Painlevé's rod at t0 is diagnosed before either loop."""
    model = contact_painleve.build(mu=5.0 / 3.0, v0=-20.0, gap=1e-3).compile()
    for mdl, kw in ((model, dict(max_fixed_point=1)), (contact_painleve.build().compile(), {})):
        errs = []
        for compiled in (False, True):
            with pytest.raises(ContactError) as err:
                simulate(mdl, 0.3, 1e-3, compiled=compiled, **kw)
            errs.append(err.value)
        a, b = errs
        assert str(a) == str(b) and a.contact == b.contact and a.step == b.step and a.t == b.t
        if a.step > 0:
            assert a.step == 15 and "failed" in str(a)
            assert a.result.status == b.result.status == "failed"
            _same(a.result, b.result)
        else:
            assert "Painlevé" in str(a) and a.contact == "tip"


def test_compiled_true_where_it_does_not_apply_is_an_error():
    m = femb.Mechanism("balls")                   # 60 balls: 840 unknowns, beyond the dense path
    for i in range(60):
        m.add(RigidBody(f"b{i}", 1.0, 0.004, position=(0.3 * i, 0.2)))
        m.add(SphereOnPlane(f"c{i}", f"b{i}", radius=0.1, e_N=0.5, mu=0.2))
    m.add(Gravity((0.0, -9.81)))
    with pytest.raises(ParameterError, match="compiled"):
        simulate(m.compile(), 1e-3, 1e-3, compiled=True)


@pytest.mark.parametrize("abc, lo_hi, closed, want", [
    ((1.0, -3.0, 2.0), (0.0, 5.0), False, 1.0),
    ((1.0, -3.0, 2.0), (1.0, 5.0), False, 2.0),
    ((1.0, -3.0, 2.0), (1.0, 5.0), True, 1.0),
    ((1.0, 0.0, 1.0), (-5.0, 5.0), False, math.nan),      # complex roots
    ((0.0, 2.0, -1.0), (0.0, 1.0), False, 0.5),           # linear
    ((0.0, 0.0, 1.0), (0.0, 1.0), False, math.nan),
    ((2.0, -1.0, 0.0), (0.0, 1.0), True, 0.0),            # c = 0: the root 0
    ((-4.905, -1.0, 1e-3), (0.0, 1.0), False, None),
])
def test_first_root(abc, lo_hi, closed, want):
    a, b, c = abc
    r = first_root(a, b, c, lo_hi[0], lo_hi[1], closed)
    if want is None:
        roots = [x.real for x in np.roots([a, b, c]) if abs(x.imag) == 0 and lo_hi[0] < x.real < lo_hi[1]]
        assert r == pytest.approx(min(roots), rel=1e-15)
    elif math.isnan(want):
        assert math.isnan(r)
    else:
        assert r == pytest.approx(want, rel=1e-15)


def test_the_stages_argument_and_return_types_are_those_the_parallel_build_compiles():
    """femb.contact.loop.stage_signatures gives each stage called by symbol the argument types that
    run_steps calls it with, and its declared return type is what it compiles to: what the
    engine's parallel build (femb/engine/parallel.py) compiles each stage with, in a worker of its
    own, after runs with three sets of element types (planar, spatial, a spatial beam)."""
    from femb.base.jit import jit_disabled
    from femb.contact import loop
    from femb.engine.link import declared_return
    if jit_disabled():
        pytest.skip("compiled code only")
    for name in ("ball", "sphere 3d", "beam stop"):
        build, _, h = SCENES[name]
        simulate(build(), 5 * h, h, compiled=True)
    wanted = {}
    for sig in loop.run_steps.overloads:
        for disp, argtypes in loop.stage_signatures(sig).items():
            wanted.setdefault(disp, set()).add(tuple(argtypes))
    assert loop.run_steps.overloads and len(wanted) == 10
    for disp, sigs in wanted.items():
        name = disp.py_func.__qualname__
        assert set(disp.overloads) == sigs, name
        for cres in disp.overloads.values():
            assert declared_return(disp) == cres.signature.return_type, name


def test_the_compiled_loop_returns_to_python_between_chunks_of_steps(monkeypatch):
    """femb.contact.simulate runs the steps in several calls of the compiled loop, contiguous and in order,
    so that Python sees Ctrl-C between them (one call over every step held a KeyboardInterrupt until the
    end of the run: 30 s for 1e6 steps of the ball, before 2026-11-29); the result is the same bit for bit
    as in one call."""
    from femb.contact import compiled

    model = contact_ball.build().compile()
    calls = []
    entry = compiled._entry

    def spy(dm, args):
        fn = entry(dm, args)

        def call(*a):
            status, n = fn(*a)
            calls.append((a[2], a[3], n))                   # first step, last step asked, next step
            return status, n
        return call

    chunked = simulate(model, 1.5, 2e-3)
    monkeypatch.setattr(compiled, "_entry", spy)
    monkeypatch.setattr(compiled, "CALL_SECONDS", 0.0)         # no growth: 16 steps a call
    small = simulate(model, 1.5, 2e-3)
    # each call writes its steps into rows 1, 2, … of the stored steps' window (the first step asked is 1,
    # the next step returned the row after the last one taken); a call also returns early when the event
    # arrays are full: they grow and it goes on from there
    assert len(calls) >= math.ceil(750 / 16) and all(c[0] == 1 for c in calls)
    done = np.cumsum([c[2] - 1 for c in calls])
    assert done[-1] == 750
    assert all(c[1] == min(16, 750 - before) for c, before in zip(calls, np.append(0, done[:-1])))
    calls.clear()
    monkeypatch.setattr(compiled, "CALL_SECONDS", 1e9)         # grows every call: 16, 32, 64, ...
    simulate(model, 1.5, 2e-3)
    assert [b - a + 1 for a, b, _ in calls[:4]] == [16, 32, 64, 128]
    for name in ("q", "qd", "lam"):
        np.testing.assert_array_equal(getattr(small, name), getattr(chunked, name))
    np.testing.assert_array_equal(small.contact["lam_N"], chunked.contact["lam_N"])

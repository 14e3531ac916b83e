"""Notebook-friendly objects: short, informative ``repr`` and ``_repr_html_`` tables of
mechanisms, models, results, static and modal results; type hints on the public API."""
import typing

import numpy as np
import pytest

import femb
from femb import Mechanism
from femb.analysis.modal import buckling_analysis, modal_analysis
from femb.analysis.static import solve_static
from femb.elements import Gravity, Hinge, RigidBody, Section, add_beam

SHORT = 600    # characters: a few lines, never the arrays


def mechanism():
    m = Mechanism("pendulum")
    bar = m.add(RigidBody("bar", 2.0, 2.0 / 12, position=(0.5, 0.0), points={"O": (-0.5, 0.0)}))
    m.add(Hinge("pivot", "ground", bar, point_b="O"))
    m.add(Gravity((0.0, -9.81)))
    return m


@pytest.fixture(scope="module")
def model():
    return mechanism().compile()


def _check(obj, *must):
    text = repr(obj)
    assert len(text) < SHORT, text
    assert "array(" not in text and "object at 0x" not in text, text
    for m in must:
        assert m in text, (m, text)
    table = obj._repr_html_()
    assert table.startswith("<table>") and table.endswith("</table>")
    assert table.count("<tr>") == len(text.splitlines()) - 1      # one row per line under the title
    return text


def test_mechanism_and_model(model):
    _check(mechanism(), "Mechanism 'pendulum'", "1 RigidBody", "1 Hinge", "1 Gravity", "bar, pivot, gravity",
           "planar")
    _check(model, "Model 'pendulum'", "nq = 3", "nc = 2", "1 RigidBody, 1 Hinge", "ground, bar")


def test_result_fixed_and_adaptive(model):
    r = femb.simulate(model, 0.5, 1e-3)
    text = _check(r, "Result of 'pendulum'", "success", "0 … 0.5 s (501 stored)", "500 (fixed h = 0.001 s)",
                  "q (501, 3)", "lam (501, 2)", "bar, pivot, energy")
    assert f"{len(r.outputs())} of" in text
    a = femb.simulate(model, 0.5, rtol=1e-5)
    _check(a, "adaptive, rtol = 1e-05", f"{a.n_rejected} rejected", f"({a.t.size} stored)")


def test_contact_result():
    """femb.contact.simulate's result: Result's summary plus a contacts row (before 2026-11-29 the dataclass's
    own repr printed every array)."""
    from femb.benchmarks.scenes.contact import contact_ball
    from femb.contact import simulate
    r = simulate(contact_ball.build().compile(), 1.0, 2e-3)
    _check(r, "Result of 'contact_ball'", "success", "contacts: 1 (floor)", f"{len(r.events)} impacts",
           "min g_N =", f"steps:    500 (fixed h = 0.002 s; {r.stats['substeps']} substeps)")
    assert r.stats["substeps"] > 500
    assert len(r.events) == 2                     # at 0.428 and 0.857 s (contact_ball: the next at 1.07 s)


def test_static_modal_buckling(model):
    s = solve_static(model)
    _check(s, "StaticResult of 'pendulum'", "direct", "1 … 1 (1 equilibria stored)", "q (1, 3)")
    md = modal_analysis(model, s.state, n_modes=1)
    _check(md, "ModalResult of 'pendulum'", "1 of nq = 3", f"{md.frequency[0]:.5g} Hz")
    m = Mechanism("column")
    add_beam(m, "b", Section.rectangle(2.1e11, 8e10, 0.01, 0.01, 7800.0), m.ground, (0.0, 1.0), 4)
    from femb.elements import Force
    m.add(Force("P", "b.n4", (0.0, -1.0)))
    b = buckling_analysis(m.compile(), 2)
    _check(b, "BucklingResult of 'column'", f"{b.factors[0]:.6g}")


def test_long_names_are_cut():
    m = Mechanism("chain")
    prev = m.ground
    for k in range(40):
        body = m.add(RigidBody(f"link_with_a_long_name_{k}", 1.0, 0.1, position=(k + 0.5, 0.0),
                               points={"O": (-0.5, 0.0), "E": (0.5, 0.0)}))
        m.add(Hinge(f"h{k}", prev, body, point_a=None if k == 0 else "E", point_b="O"))
        prev = body
    text = _check(m, "elements: 80: 40 RigidBody, 40 Hinge", "(+74 more)")
    assert all(len(line) < 140 for line in text.splitlines())
    _check(m.compile(), "40 RigidBody, 40 Hinge")


@pytest.mark.parametrize("fn", [femb.simulate, femb.Mechanism.compile, femb.Mechanism.add, femb.Mechanism.__init__,
                                femb.Result.series, femb.Result.to_pandas, solve_static, modal_analysis,
                                buckling_analysis, femb.check_jacobians, femb.consistent_initial_state])
def test_public_functions_have_type_hints(fn):
    hints = typing.get_type_hints(fn)
    assert "return" in hints, fn.__qualname__
    assert len(hints) > 1 or fn is femb.Mechanism.__init__, fn.__qualname__


def test_sweep_has_type_hints():
    pytest.importorskip("dask")
    from femb.study.sweep import sweep           # femb.sweep is the module once another test imported it

    hints = typing.get_type_hints(sweep)
    assert "return" in hints and "scene" in hints


def test_import_femb_is_light_and_everything_loads_on_use():
    """`import femb` loads neither numba nor scipy; public names and submodules come on first use."""
    import subprocess
    import sys

    code = ("import sys, femb\n"
            "assert not [m for m in sys.modules if m.split('.')[0] in ('numba', 'scipy', 'pyvista', 'meshio')]\n"
            "assert femb.system.assembly.mass_matrix and femb.analysis.static.solve_static and femb.io.read_pvd\n"
            "assert femb.Mechanism.__module__ == 'femb.system.mechanism' and callable(femb.simulate)\n"
            "assert 'numba' in sys.modules\n"
            "assert set(femb.__all__) <= set(dir(femb))\n"
            "try:\n    femb.nothing\nexcept AttributeError as e:\n    assert 'nothing' in str(e)\n"
            "else:\n    raise SystemExit('femb.nothing did not raise')\n")
    subprocess.run([sys.executable, "-c", code], check=True)

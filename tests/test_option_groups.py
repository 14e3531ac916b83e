"""Options grouped in dataclasses: ``options=`` and the keywords give the same run, unknown names
are named in a ParameterError."""
import numpy as np
import pytest

from femb import Mechanism
from femb.analysis.static import StaticOptions, solve_static
from femb.elements import Gravity, PointMass, SpringDamper
from femb.errors import ParameterError


def _hanging():
    m = Mechanism("hanging")
    p = m.add(PointMass("p", 1.0, position=(0.0, -1.0)))
    m.add(SpringDamper("s", "ground", p, 100.0), Gravity((0.0, -10.0)))
    return m.compile()


def test_static_options_and_keywords_agree():
    model = _hanging()
    a = solve_static(model, load_steps=3, rtol=1e-11)
    b = solve_static(model, options=StaticOptions.create(load_steps=3, rtol=1e-11))
    c = solve_static(model, options=StaticOptions.create(load_steps=5), load_steps=3, rtol=1e-11)
    for r in (b, c):
        np.testing.assert_array_equal(r.q, a.q)
        assert r.settings == a.settings and r.strategy == a.strategy == "load steps"
    assert len(a.t) == 4


def test_static_unknown_option_is_named():
    with pytest.raises(ParameterError, match="unknown option.*load_stepz"):
        solve_static(_hanging(), load_stepz=3)
    with pytest.raises(ParameterError, match="options must be a StaticOptions"):
        solve_static(_hanging(), options={"load_steps": 3})
    with pytest.raises(ParameterError, match="load_steps must be at least 1"):
        StaticOptions.create(load_steps=0)


def test_simulate_options_and_keywords_agree():
    import femb
    from femb.solve.options import SolverOptions

    model = _hanging()
    a = femb.simulate(model, 0.05, 0.01, rho_inf=0.5, max_iter=12, stride=2)
    b = femb.simulate(model, 0.05, options=SolverOptions.create(0.01, rho_inf=0.5, max_iter=12), stride=2)
    c = femb.simulate(model, 0.05, 0.01, options=SolverOptions.create(0.02, rho_inf=0.9, max_iter=12),
                      rho_inf=0.5, stride=2)
    for r in (b, c):
        np.testing.assert_array_equal(r.t, a.t)
        np.testing.assert_array_equal(r.q, a.q)
    d = femb.simulate(model, 0.05, rtol=1e-4, rho_inf=0.5)
    e = femb.simulate(model, 0.05, options=SolverOptions.create(None, rtol=1e-4, rho_inf=0.5))
    np.testing.assert_array_equal(e.t, d.t)
    np.testing.assert_array_equal(e.q, d.q)
    with pytest.raises(ParameterError, match="unknown solver option.*max_iterz"):
        femb.simulate(model, 0.05, 0.01, max_iterz=3)
    with pytest.raises(ParameterError, match="options must be"):
        femb.simulate(model, 0.05, 0.01, options={"rho_inf": 0.5})


def test_sweep_plan_names_unknown_options():
    from femb.study.sweep import SweepPlan, sweep

    with pytest.raises(ParameterError, match="unknown option.*gird"):
        sweep("slider_crank", gird={"k": [1.0]})
    with pytest.raises(ParameterError, match="plan must be a SweepPlan"):
        sweep("slider_crank", plan={"grid": {}})
    p = SweepPlan.create(grid={"k": [1.0]}, h=0.01)
    assert SweepPlan.create(p, h=0.02).h == 0.02 and SweepPlan.create(p, h=0.02).grid == {"k": [1.0]}


def test_solver_options_replace_and_round_trip():
    """SolverOptions.replace re-validates one change on resolved options (rho_inf over the resolved
    alpha; the unbounded default h_max), and create(**as_kwargs()) gives the same options."""
    from femb.solve.options import SolverOptions

    o = SolverOptions.create(h=1e-3, rho_inf=0.9)
    assert SolverOptions.create(**o.as_kwargs()) == o
    r = o.replace(rho_inf=0.5)
    assert r.alpha.rho_inf == 0.5 and r.h == 1e-3 and r.h_max == o.h_max
    assert o.replace(newton="modified").newton == "modified" and o.replace(newton="modified").alpha == o.alpha
    with pytest.raises(ParameterError, match="max_iter"):
        o.replace(max_iter=0)

"""The engine's border by name: options validated once (SolverOptions), every field of the arrays
that cross into compiled code written by name, the rule for fixed steps, the default atol, absurd
step counts, and storage proportional to what is stored."""
import math
import tracemalloc

import numpy as np
import pytest

import femb
from femb import engine as S
from femb.elements import PointMass, SpringDamper
from femb.errors import ParameterError
from femb.solve.options import MAX_STEPS, SolverOptions, fixed_steps
from femb.solve.solver import GeneralizedAlphaSolver

K, MASS = 40.0, 0.5


def oscillator():
    m = femb.Mechanism("osc")
    m.ground.add_point("anchor", (0.0, 0.0))
    p = m.add(PointMass("p", MASS, (1.1, 0.0)))
    m.add(SpringDamper("s", "ground", p, K, 0.0, length=1.0, point_a="anchor"))
    return m


@pytest.fixture(scope="module")
def osc():
    return oscillator().compile()


# ---- named fields ---------------------------------------------------------------------------
@pytest.mark.parametrize("prefix, fields", [("IP", S.IP_FIELDS), ("FP", S.FP_FIELDS), ("SI", S.SI_FIELDS),
                                            ("SF", S.SF_FIELDS), ("NS", S.NS_FIELDS),
                                            ("W", tuple(n for n, _ in S.W_FIELDS)),
                                            ("C", tuple(n for n, _ in S.C_FIELDS))])
def test_field_constants_come_from_one_list(prefix, fields):
    assert len(set(fields)) == len(fields)
    assert [getattr(S, f"{prefix}_{n.upper()}") for n in fields] == list(range(len(fields)))
    assert getattr(S, "N" + prefix) == len(fields)


def test_named_arrays_refuse_a_wrong_kind():
    vals = {"a": np.zeros(3), "b": np.zeros((2, 2), dtype=np.int64)}
    assert len(S.named_arrays((("a", "f1"), ("b", "i2")), vals, "X")) == 2
    with pytest.raises(TypeError, match="field b"):
        S.named_arrays((("a", "f1"), ("b", "f2")), vals, "X")
    with pytest.raises(KeyError, match="'c'"):
        S.named_arrays((("a", "f1"), ("b", "i2"), ("c", "f1")), vals, "X")


def test_named_array_refuses_missing_unknown_fields():
    vals = dict.fromkeys(S.FP_FIELDS, 1.0)
    assert S.named_array(S.FP_FIELDS, vals, np.float64, "fp").shape == (S.NFP,)
    del vals["h"]
    with pytest.raises(KeyError, match="'h'"):
        S.named_array(S.FP_FIELDS, vals, np.float64, "fp")
    vals["h"] = 1.0
    vals["hh"] = 2.0
    with pytest.raises(KeyError, match="'hh'"):
        S.named_array(S.FP_FIELDS, vals, np.float64, "fp")


@pytest.mark.parametrize("h", [1e-3, None])
def test_every_engine_field_is_written_once_by_name(osc, h):
    s = GeneralizedAlphaSolver(osc, h, t_end=0.01, rtol=1e-4 if h is None else None)
    ip, fp = s._int_parameters(), s._float_parameters()
    # each builder names every field exactly once (a dict cannot repeat a key; the lists are complete)
    assert list(ip) == list(S.IP_FIELDS) and list(fp) == list(S.FP_FIELDS)
    # and the arrays the engine reads hold those values at the fields' indices
    for name, v in ip.items():
        assert s.ip[getattr(S, "IP_" + name.upper())] == v or name in ("stride", "store")
    for name, v in fp.items():
        assert s.fp[getattr(S, "FP_" + name.upper())] == v
    # nothing left at a placeholder: sizes and options as given
    assert s.ip[S.IP_NV] == osc.nq and s.ip[S.IP_MAXIT] == 25 and s.ip[S.IP_MODE] == int(h is None)
    assert s.fp[S.FP_H] == (h or 0.0) and s.fp[S.FP_TEND] == 0.01 and s.fp[S.FP_AM] == s.alpha.alpha_m
    assert np.all(np.isfinite(s.fp[[S.FP_FIELDS.index(n) for n in S.FP_FIELDS if n != "hmax"]]))
    # the work pack holds one array per W field, of the size the field names; the model
    # constants one per C field, of the field's kind
    assert s.W[2].shape[0] == len(S.W_FIELDS)
    np.testing.assert_array_equal(s.Wv[S.W_ATOLV], s.atol)
    assert s.cp.C[2].shape[0] == len(S.C_FIELDS)
    for (name, kind), a in zip(S.C_FIELDS, s.cp.Cv):
        assert a.ndim == int(kind[1]) and (a.dtype.kind == "f") == (kind[0] == "f"), name
    np.testing.assert_array_equal(s.cp.Cv[S.C_QFIX], osc.q_fixed)


def test_named_packs_are_the_solver_arrays_and_the_engine_types(osc):
    """The packs P, S, N hold the solver's arrays themselves (what the engine writes, Python
    reads), one per field name; their numba types are those of the engine's signature of run."""
    from numba import typeof
    s = GeneralizedAlphaSolver(osc, 1e-3, t_end=0.01)
    attr = {"stats": "stats_arr", "tfv": None}
    for pack, cls in ((s.par, S.Par), (s.step_state, S.StepState), (s.newton_arrays, S.NewtonArrays)):
        assert type(pack) is cls and pack._fields == cls._fields
        for name in cls._fields:
            own = s.cp.tfv if name == "tfv" else getattr(s, attr.get(name) or name)
            assert getattr(pack, name) is own, name
    b = s._buffers(3)
    out = S.Out(*b)
    sig = S.engine_signatures()[S.run]
    assert [typeof(x) for x in (s.cp.G, s.cp.C, s.W, s.par, s.step_state, s.newton_arrays, out)] == list(sig[:7])
    # a step through the packs moves the solver's own state
    q0 = s.q.copy()
    status, m, k = s.advance(2)
    assert k == 2 and int(s.par.si[S.SI_STEP]) == 2 and not np.array_equal(s.step_state.q, q0)
    assert s.step_state.q is s.q and b[0][m - 1] == pytest.approx(0.002)


def test_engine_functions_are_short_with_few_arguments():
    """No function of femb/engine has more than 10 arguments or more than about 100 lines."""
    import ast
    from pathlib import Path
    root = Path(S.__file__).parent
    long = []
    for path in sorted(root.glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.FunctionDef):
                n_args = len(node.args.args) + len(node.args.kwonlyargs)
                n_lines = node.end_lineno - node.lineno + 1
                if n_args > 10 or n_lines > 105:
                    long.append(f"{path.name}:{node.name} ({n_args} arguments, {n_lines} lines)")
    assert not long, long


# ---- SolverOptions --------------------------------------------------------------------------
def test_solver_options_validate_by_name():
    o = SolverOptions.create(1e-3, rho_inf=0.8, max_iter=7)
    assert o.h == 1e-3 and o.max_iter == 7 and o.alpha.rho_inf == pytest.approx(0.8) and not o.adaptive
    for kw, word in [({"max_iter": 0}, "max_iter"), ({"newton_test": "x"}, "newton_test"),
                     ({"rtol": -1.0}, "rtol"), ({"check_every": 1}, "check_every"), ({"min_iter": 2}, "min_iter"),
                     ({"formulation": "index1"}, "formulation"), ({"predictor": 3}, "predictor"),
                     ({"max_iter": 2.5}, "max_iter")]:
        with pytest.raises(ParameterError, match=word):
            SolverOptions.create(1e-3, **kw)
    with pytest.raises(ParameterError, match="newtn"):
        SolverOptions.create(1e-3, newtn="full")


def test_unknown_simulate_option_is_a_parameter_error(osc):
    with pytest.raises(ParameterError, match="max_iters"):
        femb.simulate(osc, 0.01, 1e-3, max_iters=3)


def test_solver_accepts_options_object(osc):
    o = SolverOptions.create(1e-3, rho_inf=0.9)
    a = GeneralizedAlphaSolver(osc, 1e-3, options=o, t_end=0.01)
    b = GeneralizedAlphaSolver(osc, 1e-3, rho_inf=0.9, t_end=0.01)
    np.testing.assert_array_equal(a.fp, b.fp)
    np.testing.assert_array_equal(a.ip, b.ip)


# ---- fixed steps: never stretched, end on t_end -----------------------------------------------
def test_fixed_step_that_does_not_divide_t_end_is_never_stretched(osc):
    r = femb.simulate(osc, 0.01, 0.007)          # t_end = 0.01, h = 0.007: formerly one step of 0.01
    assert r.steps == 2 and r.t[-1] == 0.01
    assert np.all(r.h_steps <= 0.007) and r.h_steps == pytest.approx([0.005, 0.005])


def test_fixed_steps_rule():
    assert fixed_steps(3e-5, 0.0, 1000 * 3e-5) == (1000, pytest.approx(3e-5))    # round-off of t_end/h
    assert fixed_steps(0.01, 0.0, 0.0149)[0] == 2        # formerly 1 step: +49 %
    n, h = fixed_steps(0.01, 0.0, 0.015)
    assert n == 2 and h == 0.0075


@pytest.mark.parametrize("h", [1e-300, 1e-12, 5e-324])
def test_absurd_step_count_is_refused_before_the_run(osc, h):
    with pytest.raises(ParameterError) as e:
        femb.simulate(osc, 1.0, h, store=False)
    msg = str(e.value)
    assert "h = " in msg and "t_end" in msg and "steps" in msg


def test_step_below_round_off_of_t_is_refused(osc):
    with pytest.raises(ParameterError, match="round-off"):
        femb.simulate(osc, 1e6 + 1.0, 1e-10 * 1e-1, t0=1e6, store=False)
    assert MAX_STEPS < 2 ** 62


# ---- rtol alone -------------------------------------------------------------------------------
def test_rtol_alone_is_not_governed_by_a_fixed_atol(osc):
    w = math.sqrt(K / MASS)
    errs = {}
    for rtol in (1e-6, 1e-9):
        r = femb.simulate(osc, 0.5, rtol=rtol)
        assert r.settings["atol"] == pytest.approx(1e-3 * rtol)
        x = r.body("p")[:, 0] - 1.0
        errs[rtol] = np.abs(x - 0.1 * np.cos(w * r.t)).max()
    # the error follows rtol (formerly atol = 1e-6 governed both: a factor below 2)
    assert errs[1e-6] / errs[1e-9] > 20.0
    # the former default pair is the rule at rtol = 1e-3; fixed steps check at rtol = atol
    assert femb.simulate(osc, 0.01).settings["atol"] == pytest.approx(1e-6)
    assert femb.simulate(osc, 0.01, 1e-3, rtol=1e-5).settings["atol"] == pytest.approx(1e-8)
    assert femb.simulate(osc, 0.01, 1e-3).settings["atol"] == pytest.approx(1e-3)


# ---- storage: arrays, proportional to what is stored ------------------------------------------
def _traced_peak(model, n):
    tracemalloc.start()
    try:
        femb.simulate(model, n * 1e-3, 1e-3, store=False, check_every=0)
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_unstored_steps_cost_only_their_array_records(osc):
    femb.simulate(osc, 0.01, 1e-3)             # engine loaded
    small, large = _traced_peak(osc, 4000), _traced_peak(osc, 44000)
    per_step = (large - small) / 40000
    # h, Newton iterations and the error estimate: 20 bytes a step in numpy arrays (a Python
    # float appended to a list per record cost about 100 bytes a step)
    assert per_step < 32.0, per_step


def test_stored_states_are_arrays_of_the_stored_count(osc):
    r = femb.simulate(osc, 0.1, 1e-3, stride=10)
    assert isinstance(r.q, np.ndarray) and r.q.shape == (11, osc.nx)
    assert isinstance(r.h_steps, np.ndarray) and r.h_steps.shape == (100,)
    assert r.newton_iterations.dtype == np.int32 and r.newton_iterations.shape == (100,)
    ra = femb.simulate(osc, 0.1, rtol=1e-6)         # adaptive: chunks joined once
    assert ra.q.shape == (ra.steps + 1, osc.nx) and ra.t[-1] == 0.1


def test_storage_that_does_not_fit_is_refused_up_front(osc, monkeypatch):
    import femb.results.storage
    monkeypatch.setattr(femb.results.storage, "available_memory", lambda: 10 * 2 ** 20)
    with pytest.raises(ParameterError, match="GiB") as e:
        femb.simulate(osc, 1e3, 1e-3)            # 10⁶ stored states of 64 bytes: 61 MiB
    assert "stride" in str(e.value)
    femb.simulate(osc, 0.1, 1e-3)                # small runs go on


def test_cli_run_refuses_an_absurd_step_count_before_building(capsys):
    from femb.console import cli
    assert cli.main(["run", "pendulum", "--t-end", "1", "--h", "1e-300"]) == 2
    err = capsys.readouterr().err
    assert "h = 1e-300" in err and "steps" in err

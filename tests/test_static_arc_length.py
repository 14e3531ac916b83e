"""Arc-length continuation of solve_static (method="arc_length") through limit points.

References: the shallow two-bar (von Mises) truss, whose equilibrium path follows
in closed form from the bars' axial strain (l − L)/L (the SE(3) element and the
planar Reissner element both hold a straight bar at this strain exactly): with
half span a, rise h, bar length L = √(a² + h²) and apex deflection w,

    P(w) = 2 EA (L − l)/L · (h − w)/l,    l = √(a² + (h − w)²);

and the deep clamped–hinged circular arch of DaDeppo & Schmidt (1975), limit load
P_cr = 8.97 EI/R² (897 for EI = 10⁶, R = 100; the reference value quoted by
Ibrahimbegović 1995, CMAME 122:11–26, Table of Example 2, with EA = GA = 100 EI/m²).
"""
import math

import numpy as np
import pytest

from femb.errors import PathJumpWarning

from femb import Mechanism
from femb.analysis.static import solve_static
from femb.errors import ConvergenceError, ParameterError

A, H, EA = 1.0, 0.1, 1e6                     # half span, rise, axial stiffness of the truss
L0 = math.hypot(A, H)


def p_exact(w):
    """Exact apex load (downwards) of the two-bar truss at apex deflection w (downwards)."""
    l = np.hypot(A, H - w)
    return 2.0 * EA * (L0 - l) / L0 * (H - w) / l


def _p_max():
    """Limit load: maximum of P on 0 ≤ w ≤ H (dP/dw = 0 at l³ = L0 a², exact)."""
    l = (L0 * A * A) ** (1.0 / 3.0)
    w = H - math.sqrt(l * l - A * A)
    return float(p_exact(w)), w


P_MAX, W_LIM = _p_max()
P_REF = 2.0 * P_MAX                          # μ = 1 lies beyond the snap-through, on the far branch


def spatial_truss(n, load=True):
    """Two bars of n SE(3) elements each, pinned by revolute joints (axis z) at the supports and the apex
    (``load``: the apex load P_ref downwards)."""
    from femb.elements.spatial_beam import SpatialSection, spatial_beam
    from femb.elements.spatial_forces import SpatialForce
    from femb.elements.spatial_joints import RevoluteJoint
    m = Mechanism("von_mises_3d")
    sec = SpatialSection.from_properties(EA, EA, EA, 10.0, 10.0, 10.0, rhoA=1.0, rhoJ=(1e-3, 1e-3, 1e-3))
    b1 = spatial_beam(m, "bar1", sec, [(-A, 0, 0), (0, H, 0)], n)
    b2 = spatial_beam(m, "bar2", sec, [(A, 0, 0), (0, H, 0)], n)
    m.add(RevoluteJoint("pin1", "ground", b1.nodes[0], at=(-A, 0, 0), axis=(0, 0, 1)))
    m.add(RevoluteJoint("pin2", "ground", b2.nodes[0], at=(A, 0, 0), axis=(0, 0, 1)))
    m.add(RevoluteJoint("apex", b1.nodes[-1], b2.nodes[-1], at=(0, H, 0), axis=(0, 0, 1)))
    if load:
        m.add(SpatialForce("P", b1.nodes[-1], (0.0, -P_REF, 0.0)))
    return m, b1.nodes[-1].node.name


def planar_truss(n):
    """The same truss from planar Reissner beams, hinged at the supports and the apex."""
    from femb.elements import Force, Hinge, Section, add_beam
    m = Mechanism("von_mises_2d")
    sec = Section(EA, EA, 10.0, rhoA=1.0, rhoI=1e-3)
    b1 = add_beam(m, "bar1", sec, (-A, 0.0), (0.0, H), n, start_joint="hinge")
    b2 = add_beam(m, "bar2", sec, (A, 0.0), (0.0, H), n, start_joint="hinge")
    m.add(Hinge("apex", b1.nodes[-1], b2.nodes[-1], at=(0.0, H)))
    m.add(Force("P", b1.nodes[-1], (0.0, -P_REF)))
    return m, b1.nodes[-1].node.name


@pytest.mark.parametrize("kind", ["spatial", "planar"])
@pytest.mark.parametrize("n", [1, 3])
def test_von_mises_truss_follows_the_exact_path_through_both_limit_points(kind, n):
    m, apex = (spatial_truss if kind == "spatial" else planar_truss)(n)
    model = m.compile()
    res = solve_static(model, method="arc_length")
    assert res.strategy == "arc length" and res.t[0] == 0.0 and res.t[-1] == 1.0
    X = model.node_coordinates(apex, res.q)
    w = H - X[:, 1]
    # every converged point on the exact curve (Newton tolerance: rtol 1e-10 of the bar forces ~ 10 P_max)
    assert np.abs(res.t * P_REF - p_exact(w)).max() <= 1e-8 * P_MAX            # measured 2.4e-10
    assert np.abs(X[:, 0]).max() <= 1e-12 * A                                 # symmetric: the apex moves vertically
    if kind == "spatial":
        assert np.abs(X[:, 2]).max() <= 1e-12 * A
    # through the upper limit point (μ falls), negative loads, the lower limit point, and up to μ = 1
    lp = res.limit_points()
    assert len(lp) == 2 and res.t[lp[0]] > 0.0 > res.t[lp[1]]
    assert np.all(np.diff(res.t[lp[0]:lp[1] + 1]) < 0.0)
    assert res.t.min() < -0.45 and w[-1] > 2.0 * H                           # snapped through: apex below the supports
    mu_lim = res.limit_load_factors()
    assert np.abs(mu_lim - np.array([0.5, -0.5])).max() < 1e-3                 # exact: ±P_max / P_REF
    assert w.max() == w[-1] and np.all(np.diff(w) > 0.0)                       # displacement grows monotonically


def test_snap_back_of_the_truss_loaded_through_a_soft_spring():
    """The load acts on a node above the apex, joined to it by a spring k (the node moves vertically
    only). Its deflection u = w + P/k turns back (du/dw = 1 + P'(w)/k < 0 where P' < −k): a snap-back,
    which neither load nor displacement control can follow. Every point on the exact curve (P(w), u(w))."""
    from femb.elements.spatial_beam import SpatialBeamNode
    from femb.elements.spatial_forces import PointSpringDamper, SpatialForce
    k, d = 2000.0, 0.5
    m, apex = spatial_truss(1, load=False)
    top = m.add(SpatialBeamNode("top", (0.0, H + d, 0.0), fixed_translation=(True, False, True),
                                fixed_rotation=True))
    m.add(PointSpringDamper("spring", top, m[apex], k))
    m.add(SpatialForce("Q", top, (0.0, -P_REF, 0.0)))
    model = m.compile()
    res = solve_static(model, method="arc_length")
    assert res.t[-1] == 1.0
    w = H - model.node_coordinates(apex, res.q)[:, 1]
    u = H + d - model.node_coordinates("top", res.q)[:, 1]
    P = res.t * P_REF
    assert np.abs(P - p_exact(w)).max() <= 1e-8 * P_MAX
    assert np.abs(u - (w + P / k)).max() <= 1e-9 * d
    du = np.diff(u)
    assert np.any(du < 0.0) and u[-1] > u.max() * 0.999                      # u turns back, then on again
    assert len(res.limit_points()) == 2 and np.all(np.diff(w) > 0.0)


def test_spatial_truss_bar_strain_and_forces_from_result_beam():
    """Result.beam on the arc-length path: each bar straight, Γ1 = (l − L)/L, N = EA Γ1, no shear, no moments."""
    m, apex = spatial_truss(2)
    model = m.compile()
    res = solve_static(model, method="arc_length")
    w = H - model.node_coordinates(apex, res.q)[:, 1]
    l = np.hypot(A, H - w)
    for name in ("bar1", "bar2"):
        bs = res.beam(name)
        assert bs.strains.shape == (len(res.t), 2, 6)
        assert np.abs(bs.strains[:, :, 0] - ((l - L0) / L0)[:, None]).max() <= 1e-12
        assert np.abs(bs.strains[:, :, 1:]).max() <= 1e-11
        assert np.abs(bs.forces[:, :, 0] - EA * ((l - L0) / L0)[:, None]).max() <= 1e-6 * P_MAX


def test_load_stepping_jumps_over_the_unstable_branch_of_the_truss():
    """Load control cannot follow the path past the limit point: it leaves the near branch (w < w_lim)
    for the far one (w > 2h) in one increment, and never shows a falling load."""
    m, apex = spatial_truss(1)
    model = m.compile()
    with pytest.warns(PathJumpWarning, match="jumped between load factors 0.5 and 0.6"):
        res = solve_static(model, load_steps=10)
    w = H - model.node_coordinates(apex, res.q)[:, 1]
    assert np.all(np.diff(res.t) > 0.0)
    assert not np.any((w > W_LIM * 1.001) & (w < 2.0 * H))
    arc = solve_static(model, method="arc_length")
    wa = H - model.node_coordinates(apex, arc.q)[:, 1]
    assert np.count_nonzero((wa > W_LIM * 1.001) & (wa < 2.0 * H)) >= 3


def test_describe_path_and_observer():
    m, _ = spatial_truss(1)
    seen = []
    res = solve_static(m.compile(), method="arc_length", observer=lambda mu, q, lam, it: seen.append(mu))
    assert np.array_equal(np.array(seen), res.t)
    text = res.describe_path()
    assert text.startswith("static solution (arc length):") and "arc length" in text.splitlines()[2]
    assert len(res.arc["s"]) == len(res.t) and np.all(np.diff(res.arc["s"]) > 0.0)
    assert res.settings["method"] == "arc_length"


def test_stopping_rules():
    m, _ = spatial_truss(1)
    model = m.compile()
    r = solve_static(model, method="arc_length", target_load_factor=None, max_steps=7)
    assert len(r.t) == 8 and "max_steps" in r.message
    r = solve_static(model, method="arc_length", target_load_factor=None, max_limit_points=1)
    assert len(r.limit_points()) == 1 and r.t[-1] < r.t[-2]
    r = solve_static(model, method="arc_length", target_load_factor=-0.25)      # reached after the first maximum
    assert r.t[-1] == -0.25 and r.t.max() > 0.49
    r = solve_static(model, method="arc_length", arc_length=0.01, arc_length_max=0.01, target_load_factor=0.2)
    assert r.t[-1] == 0.2 and np.all(np.array([p["arc_length"] for p in r.path[1:] if "arc_length" in p]) == 0.01)


@pytest.mark.parametrize("kw, word", [
    (dict(method="arc"), "method"),
    (dict(method="arc_length", load_steps=4), "load_steps"),
    (dict(method="arc_length", arc_length=-1.0), "arc_length"),
    (dict(method="arc_length", arc_length=float("nan")), "arc_length"),
    (dict(method="arc_length", arc_length_min=1.0, arc_length_max=0.1), "arc_length_min"),
    (dict(method="arc_length", load_weight=-1.0), "load_weight"),
    (dict(method="arc_length", max_steps=0), "max_steps"),
    (dict(method="arc_length", max_limit_points=0.5), "max_limit_points"),
    (dict(method="arc_length", target_load_factor=0.0), "target_load_factor"),
    (dict(method="arc_length", target_load_factor=float("inf")), "target_load_factor"),
    (dict(method="arc_length", desired_iterations=0), "desired_iterations"),
    (dict(arc_length=0.1), "arc_length"),
    (dict(load_steps=3, max_steps=10), "max_steps"),
])
def test_bad_input_is_refused_naming_the_parameter(kw, word):
    m, _ = spatial_truss(1)
    with pytest.raises(ParameterError, match=word):
        solve_static(m.compile(), **kw)


def test_arc_length_needs_loads():
    from femb.elements.spatial_joints import RevoluteJoint
    m, _ = spatial_truss(1)
    with pytest.raises(ParameterError, match="applied loads"):     # no force element is of the load types
        solve_static(m.compile(), method="arc_length", load_types=(RevoluteJoint,))


def test_limit_load_factors_needs_an_arc_length_path():
    m, _ = spatial_truss(1)
    with pytest.warns(PathJumpWarning):
        res = solve_static(m.compile(), load_steps=2)
    with pytest.raises(ParameterError, match="arc_length"):
        res.limit_load_factors()


# --------------------------------------------------------------------------- deep arch
def test_deep_arch_limit_load_against_dadeppo_schmidt():
    """Clamped–hinged 215° arch, crown load: the limit load converges to 8.97 EI/R² (within 1 % from
    40 elements; second order in the element length), and load stepping fails at the limit point."""
    from femb.benchmarks.scenes.beams import deep_arch
    P, mu = {}, {}
    for n in (20, 40, 80):
        model = deep_arch.build(n).compile()
        res = deep_arch.solve(model)
        lim = res.limit_load_factors()
        assert len(lim) == 1 and res.arc["dmu_ds"][-1] < 0.0 < res.arc["dmu_ds"][-2]   # just past the maximum
        mu[n] = lim[0]
        P[n] = lim[0] * deep_arch.P_REF / (deep_arch.DATA["EI"] / deep_arch.DATA["R"] ** 2)
    ref = deep_arch.P_CR
    assert abs(P[40] / ref - 1.0) < 1e-2 and abs(P[80] / ref - 1.0) < 2e-3     # measured 0.51 %, 0.13 %
    assert P[20] > P[40] > P[80] > ref * (1 - 1e-3)                           # from above
    order = math.log2((P[20] - P[40]) / (P[40] - P[80]))
    assert abs(order - 2.0) < 0.1
    model = deep_arch.build(20).compile()
    mu_lim = mu[20]                                         # the limit point of this mesh, found above
    far = solve_static(model, method="arc_length", target_load_factor=None, max_steps=40)   # on past the limit
    k = far.limit_points()[0]
    assert abs(far.t[k] / mu_lim - 1.0) < 1e-3 and np.all(np.diff(far.t[k:]) < 0.0) and len(far.t) - k > 5
    with pytest.raises(ConvergenceError) as err:
        solve_static(model, load_factors=[0.3, 0.6, 0.8, 1.0])
    assert abs(err.value.path[-1]["mu"] / mu_lim - 1.0) < 1e-3                # fails at the limit point


def test_deep_arch_scene_is_registered_and_runs(tmp_path, capsys):
    import json

    from femb.console import cli
    from femb.study import registry
    assert "deep_arch" in registry.static_names() and "deep_arch" not in registry.names()
    sc = registry.load("deep_arch")
    assert sc.module.ANALYSIS == "static" and set(sc.outputs(sc.module.solve(sc.model(n_elements=10)))) == \
        set(sc.module.OUTPUTS)
    assert cli.main(["run", "deep_arch", "--set", "n_elements=20", "--json", str(tmp_path / "a.json")]) == 0
    data = json.loads((tmp_path / "a.json").read_text())
    assert data["analysis"] == "static" and abs(data["outputs"]["limit_load"] / 9.1474 - 1.0) < 1e-4
    assert data["levels"][0] == 0.0 and len(data["levels"]) > 10
    assert cli.main(["list", "deep_arch"]) == 0
    assert "limit_load" in capsys.readouterr().out
    with pytest.raises(ValueError, match="even"):
        sc.model(n_elements=7)

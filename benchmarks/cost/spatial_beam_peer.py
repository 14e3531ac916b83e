"""Per-step cost of femb's SE(3) spatial beam against Exudyn's ObjectBeamGeometricallyExact, same rod, same run.

The cantilever of :mod:`femb.benchmarks.cost.spatial_beam_scaling`: a steel rod
(L = 1 m, d = 20 mm, E = 210 GPa, G = 80.8 GPa, ρ = 7850 kg/m³) along x, clamped at
x = 0, released undeformed from rest under gravity (0, 0, −9.81) m/s², n two-node
elements, fixed steps h = 1e-4 s, generalized-α with ρ∞ = 0.7, index-3 constraints.

femb: :class:`~femb.elements.spatial_beam.SpatialBeam` elements meshed by
:func:`~femb.elements.spatial_beam.spatial_beam` (``start="clamp"``,
``mass="consistent"``), :class:`~femb.elements.spatial_forces.SpatialGravity`,
``femb.simulate(model, t_end, h, rho_inf=0.7, store=False)`` with its default Newton
options (``"default"``: weighted-correction test, refactorization only when the
contraction is slow) and with modified Newton and the force-residual test at a
relative 1e-4 (``"residual"``, the counterpart of Exudyn's headline setting;
:data:`FEMB_SETTINGS`). Timed: the time loop (``Result.wall_time``; consistent
initial values and compilation excluded).

Exudyn (``pip install femb[peers]``; measured with Exudyn 1.13.6): the same rod
built as in Exudyn's own test models of this element
(``main/pythonDev/TestModels/geometricallyExactBeamTest.py`` and
``rightAngleFrame.py`` of github.com/jgerstmayr/EXUDYN, read at commit
e44aca1b4fe3e5f4d820ff407fb3fd30b6581c1c, Exudyn 1.11.0): ``NodeRigidBodyEP``
nodes (Euler parameters), ``ObjectBeamGeometricallyExact`` elements with an
``exu.BeamSection`` of stiffness diag(EA, kGA, kGA, GJ, EI, EI) (k = 6(1+ν)/(7+6ν),
Cowper, ν = E/2G − 1, as femb's ``SpatialSection.circle``), mass per length ρA and
section inertia ρ diag(2I, I, I); the root node clamped to a ground node by a
``GenericJoint`` (all six axes); gravity by ``LoadMassProportional`` on each element.
Scheme: ``MainSolverImplicitSecondOrder`` (generalized-α), ``spectralRadius = 0.7``,
``useIndex2Constraints = False``, ``useNewmark = False``, fixed steps, sparse LU
(``EigenSparse``), one thread, with three Newton settings (:data:`EXUDYN_SETTINGS`):
Exudyn's default modified Newton and residual test with the relative tolerance
raised to 1e-4 (``"residual"``, the headline: the cheapest setting found that runs
every n and still gives the converged answer), the same with the test on the
coordinate increment (``newton.residualMode = 1``, relative 1e-8; ``"increment"``),
and full Newton with the increment test (``"full"``). Timed: ``SolveSteps`` alone
(``Assemble`` and ``InitializeSolver``, which computes the initial accelerations, excluded).

What made Exudyn run (Exudyn 1.13.6; :func:`lie_group_attempt` reproduces the first
point):

* ``NodeRigidBodyRotVecLG`` (Lie-group rotation-vector nodes, the nodes of the
  earlier attempt): with Exudyn's default tolerance Newton stalls on the first step
  (contraction 0.99 per iteration, 25 iterations) for n = 1, 2, 10, with or without
  ``lieGroupAddTangentOperator``, with ``lieGroupSimplifiedKinematicRelations``
  (dense solver), numerical differentiation of the element, Newmark or index 2,
  full or modified Newton, a dense or sparse solver, a tip load or gravity, a
  GenericJoint or coordinate constraints as the clamp, h from 1e-5 to 1e-3 s; the
  increment test fails as well. The iteration does not diverge: the positions
  settle after the first iteration (n = 1: later increments of the tip position
  below 1e-13 m) while the rotation coordinates' accelerations keep changing and
  a part of the residual, about 1 % of the initial one at n = 10, stays
  (contraction 0.99). Accepting it (relative tolerance 0.1, one
  iteration per step) runs every n, and the tip agrees with the Euler-parameter
  run to about 1e-11 m; this is timed as ``"lie-group"``. Exudyn's own test
  models of the element use Euler-parameter nodes (and note that the Lie-group
  nodes did not work in the static solver).
* With ``NodeRigidBodyEP`` Exudyn's default residual test (``relativeTolerance =
  1e-8`` of the step's initial residual) lies below the round-off floor of the
  residual of this stiff rod (EA/l_e up to 7e10 N/m): about 1.8e-8 at n = 10 and
  1.5e-6 at n = 1000, so Newton "fails" on the second or a later step. A relative
  tolerance of 1e-4, or the increment test, runs every n.

What differs between the two models: the beams are the same discrete model (both
the two-node SE(3) element with the constant strain ε = (log(H_A⁻¹H_B) − d0)/L of
Sonneville, Cardona & Brüls 2014, the same section stiffness and loads; their
static deflections agree to all printed digits) except for the rotary inertia:
Exudyn 1.13.6's mass matrix (``exudyn.solver.ComputeLinearizedSystem`` at the
reference configuration) is ρA L/6 [2 1; 1 2] for the translations, as femb's
``mass="consistent"``, and ρJ L/6 [2 1; 1 2] in the nodes' local angular velocities,
where femb lumps ρJ L/2 at each node (the element's source at the 1.11.0 commit
above still lumps both, ρA L/2 and ρJ L/2 per node). The two rotary forms differ by
a term that vanishes as L → 0, and for this slender rod (radius 10 mm) rotary
inertia is a small correction to the bending motion in either form. The rotation parameters and their time
discretization differ (Exudyn: Euler parameters with their norm constraint in
the vector-space generalized-α; femb: unit quaternions updated on the Lie group
with the tangent operator), and so do the Newton tests (above).

Agreement (:func:`compare`): the tip trajectory of both codes at h and at h/2 over
the first ``t_end``; the femb–Exudyn difference is printed next to each code's own
h → h/2 change (an estimate of its time-discretization error at h).

Measured (``--runs 5``, Exudyn 1.13.6, two cores shared with other jobs; docs/beams.md,
"Against Exudyn's geometrically exact beam"): femb default / Exudyn ``"residual"``
0.23, 0.26, 0.30 of the time per step for n = 10, 100, 1000; femb ``"residual"`` / Exudyn
``"residual"`` 0.13 for each n; the tips differ by 9.5e-9 m (n = 10) down to 1e-12 m
(n = 1000) over the first 10 ms, against each code's own h → h/2 change of about
2.2e-7 m.

References
----------
J. Gerstmayr, Exudyn – a C++-based Python package for flexible multibody
systems, Multibody Syst. Dyn. 60 (2024) 533–561; github.com/jgerstmayr/EXUDYN
(``main/src/Objects/CObjectBeamGeometricallyExact.cpp``, the element).
V. Sonneville, A. Cardona, O. Brüls, Geometrically exact beam finite element
formulated on the special Euclidean group SE(3), Comput. Methods Appl. Mech.
Eng. 268 (2014) 451–474.
J. C. Simo, L. Vu-Quoc, A three-dimensional finite-strain rod model. Part II,
Comput. Methods Appl. Mech. Eng. 58 (1986) 79–116.
G. R. Cowper, The shear coefficient in Timoshenko's beam theory, J. Appl. Mech.
33 (1966) 335–340.

Usage::

    python -m femb.benchmarks.cost.spatial_beam_peer [--n 10 100 1000] [--runs 3] [--t-compare 0.01]
        [--no-compare] [--lie-group]
"""
from __future__ import annotations

import argparse
import contextlib
import io
import math
import statistics
import time
import warnings

import numpy as np

# the rod (SI units), its step and ρ∞ are those of the scaling benchmark
from femb.benchmarks.cost.spatial_rod import DATA, H, RHO_INF, build


#: Exudyn's settings timed (generalized-α, sparse LU, one thread; node type ``"node"``, the
#: rest Newton settings): ``"residual"`` its default modified Newton and residual test with the
#: relative tolerance loosened from 1e-8 (below the round-off floor of this stiff rod) to 1e-4,
#: the cheapest setting found that runs every n and still gives the converged answer
#: (``compare``); ``"increment"`` the same with the coordinate-increment test (``residualMode =
#: 1``, relative 1e-8); ``"full"`` the increment test with full Newton (a new Jacobian every
#: iteration); ``"lie-group"`` ``NodeRigidBodyRotVecLG`` nodes with the Lie-group tangent
#: operator and a relative tolerance of 0.1, above the level at which its Newton iteration
#: stalls (one iteration per step is accepted).
EXUDYN_SETTINGS = {"residual": {"node": "EP", "useModifiedNewton": True, "residualMode": 0,
                                "relativeTolerance": 1e-4},
                   "increment": {"node": "EP", "useModifiedNewton": True, "residualMode": 1,
                                 "relativeTolerance": 1e-8},
                   "full": {"node": "EP", "useModifiedNewton": False, "residualMode": 1, "relativeTolerance": 1e-8},
                   "lie-group": {"node": "LG", "useModifiedNewton": True, "residualMode": 0,
                                 "relativeTolerance": 0.1}}

#: The headline setting (the ratio of the docs' table).
HEADLINE = "residual"

#: femb's settings timed: ``"default"`` femb.simulate's Newton options (weighted-correction
#: test, refactorization when the contraction is slow); ``"residual"`` the counterpart of
#: Exudyn's ``"residual"``: modified Newton with the force-residual test at a relative 1e-4
#: (‖W r‖∞ ≤ 1e-4 · F, F the largest force term; Exudyn's test is relative to the step's
#: initial residual instead).
FEMB_SETTINGS = {"default": {},
                 "residual": {"newton_test": "residual", "newton_rtol": 1e-4, "newton": "modified"}}


def steps_for(n):
    """Timed steps for n elements: 40000 // n, between 100 and 400."""
    return int(np.clip(40000 // int(n), 100, 400))


def section_properties():
    """(EA, kGA, GJ, EI, ρA, ρ·(2I, I, I)) of the rod; k = 6(1+ν)/(7+6ν), ν = E/2G − 1."""
    D = DATA
    A = math.pi * D["d"] ** 2 / 4.0
    I = math.pi * D["d"] ** 4 / 64.0
    nu = D["E"] / (2.0 * D["G"]) - 1.0
    k = 6.0 * (1.0 + nu) / (7.0 + 6.0 * nu)
    return (D["E"] * A, k * D["G"] * A, D["G"] * 2.0 * I, D["E"] * I, D["rho"] * A,
            D["rho"] * np.array([2.0 * I, I, I]))


# --------------------------------------------------------------------------
# femb
# --------------------------------------------------------------------------
def femb_tip(model, n, t_end, h, options=None):
    """Tip position (rows t, x, y, z) of a femb run (``options``: keywords of femb.simulate)."""
    import femb

    res = femb.simulate(model, t_end, h, rho_inf=RHO_INF, **(options or {}))
    return np.column_stack([res.t, res.body(f"rod.n{int(n)}")[:, :3]])


# --------------------------------------------------------------------------
# Exudyn
# --------------------------------------------------------------------------
def exudyn_version():
    """Exudyn's version, or None when it is not installed."""
    try:
        import exudyn
    except Exception:       # ImportError or a broken binary
        return None
    return str(getattr(exudyn, "__version__", "unknown"))


def exudyn_build(n, node="EP", record=False):
    """The rod in Exudyn (see the module docstring); returns (SC, mbs, tip node, tip sensor or None).

    ``node``: ``"EP"`` (``NodeRigidBodyEP``, used for all measurements) or ``"LG"``
    (``NodeRigidBodyRotVecLG``, for :func:`lie_group_attempt`).
    """
    import exudyn as exu
    from exudyn import itemInterface as ii

    EA, kGA, GJ, EI, rhoA, rhoJ = section_properties()
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    sec = exu.BeamSection()
    sec.stiffnessMatrix = np.diag([EA, kGA, kGA, GJ, EI, EI]).tolist()
    sec.dampingMatrix = np.zeros((6, 6)).tolist()
    sec.massPerLength = rhoA
    sec.inertia = np.diag(rhoJ).tolist()
    n = int(n)
    le = DATA["L"] / n
    if node == "EP":
        node_class, rot0 = ii.NodeRigidBodyEP, [1.0, 0.0, 0.0, 0.0]
    elif node == "LG":
        node_class, rot0 = ii.NodeRigidBodyRotVecLG, [0.0, 0.0, 0.0]
    else:
        raise ValueError(f"node must be 'EP' or 'LG', got {node!r}")
    nodes = [mbs.AddNode(node_class(referenceCoordinates=[i * le, 0.0, 0.0] + rot0)) for i in range(n + 1)]
    for i in range(n):
        ob = mbs.AddObject(ii.ObjectBeamGeometricallyExact(nodeNumbers=[nodes[i], nodes[i + 1]], length=le,
                                                           sectionData=sec))
        mm = mbs.AddMarker(ii.MarkerBodyMass(bodyNumber=ob))
        mbs.AddLoad(ii.LoadMassProportional(markerNumber=mm, loadVector=list(DATA["g"])))
    ng = mbs.AddNode(ii.NodePointGround(referenceCoordinates=[0.0, 0.0, 0.0]))
    mg = mbs.AddMarker(ii.MarkerNodeRigid(nodeNumber=ng))
    m0 = mbs.AddMarker(ii.MarkerNodeRigid(nodeNumber=nodes[0]))
    mbs.AddObject(ii.GenericJoint(markerNumbers=[mg, m0], constrainedAxes=[1, 1, 1, 1, 1, 1]))
    sensor = None
    if record:
        sensor = mbs.AddSensor(ii.SensorNode(nodeNumber=nodes[-1], storeInternal=True, writeToFile=False,
                                             outputVariableType=exu.OutputVariableType.Position))
    mbs.Assemble()
    return SC, mbs, nodes[-1], sensor


def exudyn_settings(steps, h, newton):
    """SimulationSettings of the generalized-α run (fixed steps, index 3, sparse LU, one thread)."""
    import exudyn as exu

    s = exu.SimulationSettings()
    ti = s.timeIntegration
    ti.numberOfSteps = int(steps)
    ti.endTime = int(steps) * float(h)
    ti.generalizedAlpha.spectralRadius = RHO_INF
    ti.generalizedAlpha.useIndex2Constraints = False
    ti.generalizedAlpha.useNewmark = False
    ti.generalizedAlpha.computeInitialAccelerations = True
    ti.adaptiveStep = False
    ti.verboseMode = 0
    for key, value in (newton or {}).items():
        if key != "node":
            setattr(ti.newton, key, value)
    s.linearSolver.solverType = exu.LinearSolverType.EigenSparse
    s.parallel.numberOfThreads = 1
    s.solution.file.write = False
    s.solution.sensors.writePeriod = float(h)
    s.show.computationTime = False
    s.show.statistics = False
    return s


def exudyn_run(n, steps, h=H, newton=EXUDYN_SETTINGS[HEADLINE], node="EP", record=False):
    """One Exudyn run (``newton["node"]``, when given, overrides ``node``).

    Returns
    -------
    dict
        ``ok``, ``message``, ``wall_s`` (``SolveSteps``), ``steps``, ``newton``
        (iterations in all), ``jacobians``, ``tip`` (rows t, x, y, z; with ``record``).
    """
    import exudyn as exu

    node = (newton or {}).get("node", node)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        SC, mbs, tip, sensor = exudyn_build(n, node=node, record=record)
        s = exudyn_settings(steps, h, newton)
    solver = exu.MainSolverImplicitSecondOrder()
    buf = io.StringIO()
    ok, message, wall = True, "", None
    try:
        with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(buf):
            if not solver.InitializeSolver(mbs, s):
                raise RuntimeError("InitializeSolver failed")
            t0 = time.perf_counter()
            done = solver.SolveSteps(mbs, s)
            wall = time.perf_counter() - t0
            solver.FinalizeSolver(mbs, s)
        if not done:
            ok = False
            message = f"Newton did not converge at t = {solver.it.currentTime:g} s ({steps} steps of {h:g} s asked)"
    except Exception as exc:     # a failing peer is a measurement
        ok = False
        message = f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}"
    log = [ln.strip() for ln in buf.getvalue().splitlines() if "convergence failed" in ln]
    if log and not ok:
        message += f" ({log[0]})"
    out = {"ok": ok, "message": message, "wall_s": wall, "steps": int(steps),
           "newton": int(solver.it.newtonStepsCount), "jacobians": int(solver.it.newtonJacobiCount),
           "tip": None}
    if record and sensor is not None:
        out["tip"] = np.asarray(mbs.GetSensorStoredData(sensor))
    return out


def lie_group_attempt(n=10, steps=3):
    """Exudyn's element on ``NodeRigidBodyRotVecLG`` nodes (Lie-group generalized-α with the tangent
    operator, full and modified Newton, Exudyn's default residual test and the increment test)."""
    out = {}
    for label, newton in (("default residual test, modified Newton", {}),
                          ("default residual test, full Newton", {"useModifiedNewton": False}),
                          ("increment test, full Newton", {"useModifiedNewton": False, "residualMode": 1,
                                                           "relativeTolerance": 1e-8})):
        out[label] = exudyn_run(n, steps, H, newton=newton, node="LG")
    return out


# --------------------------------------------------------------------------
# agreement and timing
# --------------------------------------------------------------------------
def _on_times(tip, times):
    rows = [int(np.argmin(np.abs(tip[:, 0] - t))) for t in times]
    return tip[rows, 1:4]


def compare(n, t_end=0.01, h=H, settings=None):
    """Tip trajectories of femb and Exudyn over [0, t_end]: femb at h and h/2, Exudyn at h in each
    Newton setting and at h/2 with ``"full"`` (the tightest).

    Returns
    -------
    dict
        ``diff`` (setting → max over the steps of h of |x_femb − x_Exudyn| at the
        tip, m; femb with its defaults), ``femb_residual`` (the same between femb's
        two settings of :data:`FEMB_SETTINGS`), ``femb_h2`` and ``exudyn_h2`` (each code's max |x(h) − x(h/2)|,
        m; an estimate of its time-discretization error at h), ``tip_z``
        (femb's tip deflection at t_end, m), ``times``, ``femb`` and ``exudyn``
        (setting → (nt, 3)) tip positions; or ``error``.
    """
    if exudyn_version() is None:
        return {"error": "Exudyn not installed"}
    settings = dict(EXUDYN_SETTINGS) if settings is None else dict(settings)
    steps = int(round(t_end / h))
    times = h * np.arange(steps + 1)
    model = build(n).compile()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        f1 = _on_times(femb_tip(model, n, steps * h, h), times)
        f2 = _on_times(femb_tip(model, n, steps * h, h / 2), times)
        fr = _on_times(femb_tip(model, n, steps * h, h, FEMB_SETTINGS["residual"]), times)
    xe, diff = {}, {}
    for key, nw in settings.items():
        e = exudyn_run(n, steps, h, newton=nw, record=True)
        if not e["ok"]:
            return {"error": f"Exudyn ({key}) failed: {e['message']}"}
        xe[key] = _on_times(e["tip"], times)
        diff[key] = float(np.max(np.linalg.norm(f1 - xe[key], axis=1)))
    e2 = exudyn_run(n, 2 * steps, h / 2, newton=EXUDYN_SETTINGS["full"], record=True)
    if not e2["ok"]:
        return {"error": f"Exudyn (full, h/2) failed: {e2['message']}"}
    x2 = _on_times(e2["tip"], times)
    ref = xe.get("full", next(iter(xe.values())))
    return {"n": int(n), "t_end": steps * h, "h": h, "times": times, "femb": f1, "exudyn": xe, "diff": diff,
            "femb_residual": float(np.max(np.linalg.norm(f1 - fr, axis=1))),
            "femb_h2": float(np.max(np.linalg.norm(f1 - f2, axis=1))),
            "exudyn_h2": float(np.max(np.linalg.norm(ref - x2, axis=1))),
            "tip_z": float(f1[-1, 2])}


def measure(n, runs=3, steps=None, exudyn=True):
    """ms per step of femb and Exudyn on the rod, in this process.

    Each code and setting runs once untimed (compilation, first call), then all
    run in turn ``runs`` times (interleaved, so that load from other processes
    falls on all of them); the medians are reported.

    Returns
    -------
    dict
        ``femb`` and ``exudyn``: setting → {``ms`` (per step; femb: the time
        loop, ``Result.wall_time``), ``runs``, ``newton`` (iterations per step)}
        or {``error``}; femb's also ``total_ms`` (the whole ``simulate`` call per
        step, consistent initial values included), Exudyn's ``jacobians`` (per
        run) and ``ratio`` (femb setting → femb / Exudyn); ``steps``, ``n``,
        ``exudyn_version``.
    """
    import femb

    steps = int(steps or steps_for(n))
    model = build(n).compile()
    version = exudyn_version() if exudyn else None
    settings = dict(EXUDYN_SETTINGS) if version else {}

    def femb_once(opts):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            t0 = time.perf_counter()
            res = femb.simulate(model, steps * H, H, rho_inf=RHO_INF, store=False, **opts)
            return res, 1e3 * (time.perf_counter() - t0) / res.steps

    for opts in FEMB_SETTINGS.values():
        femb_once(opts)                                              # compile / warm up
    for nw in settings.values():
        exudyn_run(n, min(steps, 20), H, newton=nw)
    fb = {k: {"runs": [], "total": [], "newton": None} for k in FEMB_SETTINGS}
    ex = {k: {"runs": [], "newton": None, "jacobians": None, "error": None} for k in settings}
    for _ in range(int(runs)):
        for key, opts in FEMB_SETTINGS.items():
            res, total = femb_once(opts)
            fb[key]["runs"].append(1e3 * res.wall_time / res.steps)
            fb[key]["total"].append(total)
            fb[key]["newton"] = float(np.mean(res.newton_iterations))
        for key, nw in settings.items():
            r = exudyn_run(n, steps, H, newton=nw)
            if not r["ok"]:
                ex[key]["error"] = r["message"]
                continue
            ex[key]["runs"].append(1e3 * r["wall_s"] / steps)
            ex[key]["newton"] = r["newton"] / steps
            ex[key]["jacobians"] = r["jacobians"]
    out = {"n": int(n), "steps": steps, "femb": {}, "exudyn": {}, "exudyn_version": version}
    for key, f in fb.items():
        out["femb"][key] = {"ms": statistics.median(f["runs"]), "runs": f["runs"],
                            "total_ms": statistics.median(f["total"]), "newton": f["newton"]}
    for key, e in ex.items():
        if e["runs"]:
            ms = statistics.median(e["runs"])
            out["exudyn"][key] = {"ms": ms, "runs": e["runs"], "newton": e["newton"], "jacobians": e["jacobians"],
                                  "ratio": {k: f["ms"] / ms for k, f in out["femb"].items()}}
        else:
            out["exudyn"][key] = {"error": e["error"]}
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="+", default=[10, 100, 1000])
    ap.add_argument("--runs", type=int, default=3, help="timed runs per code (median)")
    ap.add_argument("--t-compare", type=float, default=0.01, help="time span of the tip comparison (s)")
    ap.add_argument("--no-compare", action="store_true", help="skip the tip comparison")
    ap.add_argument("--lie-group", action="store_true",
                    help="also show what Exudyn does with NodeRigidBodyRotVecLG nodes (n = 10)")
    a = ap.parse_args(argv)
    version = exudyn_version()
    print(f"spatial beam against Exudyn {version or '(not installed)'}: rod L = {DATA['L']} m, d = {DATA['d']} m, "
          f"clamped, gravity; h = {H:g} s, rho_inf = {RHO_INF}; median of {a.runs} runs (time.perf_counter); "
          f"femb: time loop; Exudyn: SolveSteps, sparse LU, 1 thread, EP nodes (LG in 'lie-group')")
    if a.lie_group and version:
        for label, r in lie_group_attempt().items():
            print(f"  Exudyn on NodeRigidBodyRotVecLG, {label}: "
                  + ("ran" if r["ok"] else f"failed: {r['message']}")
                  + f" ({r['newton']} Newton iterations)")
    fk = list(FEMB_SETTINGS)
    print(f"{'n':>5s} {'steps':>5s}  {'code':<6s} {'setting':<10s} {'ms/step':>9s} {'Newton':>6s}  "
          + "  ".join(f"{'femb ' + k:>13s}" for k in fk) + f"  {'tip diff m':>10s}")
    print(f"{'':>5s} {'':>5s}  {'':<6s} {'':<10s} {'':>9s} {'/step':>6s}  "
          + "  ".join(f"{'/ Exudyn':>13s}" for _ in fk))
    rows = []
    for n in a.n:
        r = measure(n, a.runs, exudyn=version is not None)
        c = {"error": "skipped"} if a.no_compare or not version else compare(n, a.t_compare)
        rows.append((r, c))
        lead = f"{n:5d} {r['steps']:5d}"
        for key, f in r["femb"].items():
            d = c.get("femb_residual") if key == "residual" else None
            ds = f"{d:10.2e}" if d is not None else ""
            print((f"{lead}  {'femb':<6s} {key:<10s} {f['ms']:9.3f} {f['newton']:6.2f}  "
                   + "  ".join(" " * 13 for _ in fk) + f"  {ds}").rstrip())
            lead = " " * 11
        if not r["exudyn"]:
            print(f"{lead}  (Exudyn not installed)")
        for key, e in r["exudyn"].items():
            d = c.get("diff", {}).get(key)
            ds = f"{d:10.2e}" if d is not None else ""
            if "ms" in e:
                print((f"{lead}  {'Exudyn':<6s} {key:<10s} {e['ms']:9.3f} {e['newton']:6.2f}  "
                       + "  ".join(f"{e['ratio'][k]:13.3f}" for k in fk) + f"  {ds}").rstrip())
            else:
                print(f"{lead}  {'Exudyn':<6s} {key:<10s} ({e['error']})")
        if "femb_h2" in c:
            print(f"{'':>11s}  tip over [0, {c['t_end']:g}] s: z(t_end) = {c['tip_z']:.4e} m; h -> h/2 change: "
                  f"femb {c['femb_h2']:.2e} m, Exudyn {c['exudyn_h2']:.2e} m")
        elif "error" in c and c["error"] != "skipped":
            print(f"{'':>11s}  comparison: {c['error']}")
    if not a.no_compare and version:
        print("tip diff: max over the steps of |x - x_femb default| at the tip (Exudyn rows: at h in that setting)")
    return rows


if __name__ == "__main__":
    main()

"""Bouncing ball: femb's contact against Exudyn's penalty contact, same model, same run.

``python -m femb.benchmarks.cost.contact_peer`` prints, for the bouncing ball of
:mod:`femb.benchmarks.scenes.contact.contact_ball` (m = 1 kg, R = 0.1 m, dropped from centre
height 1 m, e_N = 0.5; impact times t_k in closed form, t₁ = 0.428353 s, t∞ = 1.285059 s)
integrated to ``T_END`` = 1.2 s (four impacts), for each code and step size:

* wall time, median of ``repeats`` runs (``time.perf_counter``, model construction and compile
  excluded; femb is run once before the timed runs so that no numba compile is timed);
* the largest error of the first three impact (contact closing) times against the closed form;
* the largest error of the height at the sample times ``T_SAMPLE`` (in flight) against the
  closed-form parabolas;

then, for each accuracy in ``TOLERANCES``, the least wall time at which each code meets it
(impact times within the tolerance) and the ratio femb / Exudyn.

Codes compared
--------------
* ``femb nonsmooth``: :func:`femb.contact.simulate` (nonsmooth generalized-α, rigid contact,
  Newton impact law e_N = 0.5, impacts located), ρ∞ = 0.8.
* ``femb penalty``: :class:`femb.elements.PenaltySphereOnPlane` in the compiled engine
  (f_N = k δ^{3/2}(1 + α δ̇), k = 1e7 N/m^{3/2}, restitution 0.5 at the first impact speed),
  ρ∞ = 0.9 (the scene's default).
* ``Exudyn``: a mass point (NodePoint) with ObjectContactSphereSphere against a ground sphere of
  radius 1e3 m whose centre lies 1e3 m below the floor (the ball moves on the vertical through
  that centre, so the gap is exactly y − R), Hertz law f = k δ^{3/2} with the same
  k = 1e7, ``impactModel = 2`` (Gonthier et al. / Carvalho–Martins, which Exudyn's item
  documentation calls the most accurate for the restitution coefficient) with
  ``restitutionCoefficient = 0.5``, ``contactDamping = 0``, data node
  NodeGenericData(initialCoordinates = [0.1, 0, 0, 0], 4 coordinates) and modified Newton: the
  settings of Exudyn's example ``newtonsCradle.py`` (Gerstmayr, 2025). Its default solver
  (generalized-α, default spectral radius 0.9) with its default step control: the given step,
  which ``adaptiveStep = True`` with ``discontinuous.useRecommendedStepSize`` shrinks at contact
  switches (down to 1e-8 s where the contact closes; with ``adaptiveStep = False`` it stops at
  the first impact). Timing of ``SolveDynamic`` only (construction and ``Assemble`` excluded).

A penalty model's contact lasts a finite time (about 3.8 ms for k = 1e7 at the first impact),
so its later closing times differ from the rigid closed form by a model error that no step
size removes; the tables show that floor.

A missing Exudyn is never an error: its rows say "not installed".

References
----------
G. Capobianco, J. Harsch, S. R. Eugster, R. I. Leine, A nonsmooth generalized-alpha method for
mechanical systems with frictional contact, IJNME 122 (2021) 6497–6526, §10.1 (the scene).
J. Gerstmayr, Exudyn – a C++-based Python package for flexible multibody systems, Multibody
Syst. Dyn. 60 (2024) 533–561.
"""
from __future__ import annotations

import contextlib
import io
import math
import statistics
import time
import warnings

import numpy as np

from femb.benchmarks.scenes.contact import contact_ball, penalty_ball

T_END = 1.2
T_SAMPLE = (0.3, 0.65, 0.95)
TOLERANCES = (1e-2, 5e-3, 1e-3, 1e-4)
#: step sizes of each code, from the largest at which it still meets the loosest accuracy (femb's located
#: impacts keep the impact times to 2e-5 s at h = 0.1 s; Exudyn's step control refines at every contact
#: switch, so its larger steps cost less at the same accuracy)
STEPS = {"femb nonsmooth": (1e-1, 5e-2, 2e-2, 1e-2, 5e-3, 2e-3),
         "femb penalty": (4e-4, 2e-4, 1e-4, 5e-5),
         "Exudyn": (4e-3, 2e-3, 1e-3, 4e-4, 2e-4, 1e-4, 5e-5)}
P = contact_ball.PARAMS
K_HERTZ = penalty_ball.PARAMS["stiffness"]
R_GROUND = 1e3


def exudyn_version():
    """Exudyn's version string, or None when it is not importable."""
    try:
        import exudyn
    except Exception:   # ImportError, or a broken binary
        return None
    return str(getattr(exudyn, "__version__", "unknown"))


def exact_height(t):
    """Closed-form centre height of the rigid bouncing ball at the times t (array), shape of t."""
    t = np.asarray(t, dtype=float)
    g, r, e = P["g"], P["radius"], P["e_N"]
    tk = contact_ball.impact_times(40)
    v1 = g * tk[0]
    y = P["y0"] - 0.5 * g * t * t
    for k in range(len(tk) - 1):
        v = v1 * e ** (k + 1)
        s = t - tk[k]
        inside = (t >= tk[k]) & (t < tk[k + 1])
        y = np.where(inside, r + v * s - 0.5 * g * s * s, y)
    return np.where(t >= contact_ball.accumulation_time(), r, y)


def closing_times(t, gap, n=3):
    """The first n times the gap goes from ≥ 0 to < 0, interpolated linearly; shape (≤ n,)."""
    idx = np.nonzero((gap[:-1] >= 0.0) & (gap[1:] < 0.0))[0][:n]
    s = gap[idx] / (gap[idx] - gap[idx + 1])
    return t[idx] + s * (t[idx + 1] - t[idx])


def errors(t_imp, t, y):
    """(max impact-time error over the first three, max height error at T_SAMPLE)."""
    ref = contact_ball.impact_times(3)
    e_t = float(np.max(np.abs(t_imp[:3] - ref))) if len(t_imp) >= 3 else math.inf
    ys = np.interp(T_SAMPLE, t, y)
    return e_t, float(np.max(np.abs(ys - exact_height(T_SAMPLE))))


def _time(fn, repeats):
    walls, out = [], None
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        walls.append(time.perf_counter() - t0)
    return statistics.median(walls), out


def run_femb_nonsmooth(h, repeats):
    """(wall s, impact error s, height error m) of :func:`femb.contact.simulate`."""
    from femb.contact import simulate
    model = contact_ball.build().compile()
    simulate(model, 2 * h, h, rho_inf=0.8)                       # compile outside the timing
    wall, res = _time(lambda: simulate(model, T_END, h, rho_inf=0.8), repeats)
    t_imp = np.array([ev["t"] for ev in res.events])
    return (wall,) + errors(t_imp, res.t, contact_ball.outputs(res)["y"])


def run_femb_penalty(h, repeats):
    """(wall s, impact error s, height error m) of the compiled penalty element."""
    import femb
    model = penalty_ball.build().compile()
    femb.simulate(model, t_end=2 * h, h=h, rho_inf=0.9)          # compile outside the timing
    wall, res = _time(lambda: femb.simulate(model, t_end=T_END, h=h, rho_inf=0.9), repeats)
    out = penalty_ball.outputs(res)
    return (wall,) + errors(closing_times(res.t, out["gN"]), res.t, out["y"])


def _exudyn_model():
    import exudyn as exu
    from exudyn import itemInterface as ii
    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    ground = mbs.AddObject(ii.ObjectGround(referencePosition=[0.0, 0.0, 0.0]))
    m_g = mbs.AddMarker(ii.MarkerBodyPosition(bodyNumber=ground, localPosition=[0.0, -R_GROUND, 0.0]))
    nd = mbs.AddNode(ii.NodePoint(referenceCoordinates=[0.0, P["y0"], 0.0]))
    ob = mbs.AddObject(ii.ObjectMassPoint(nodeNumber=nd, mass=P["mass"]))
    m_b = mbs.AddMarker(ii.MarkerNodePosition(nodeNumber=nd))
    mbs.AddLoad(ii.LoadMassProportional(markerNumber=mbs.AddMarker(ii.MarkerBodyMass(bodyNumber=ob)),
                                        loadVector=[0.0, -P["g"], 0.0]))
    data = mbs.AddNode(ii.NodeGenericData(initialCoordinates=[0.1, 0.0, 0.0, 0.0], numberOfDataCoordinates=4))
    mbs.AddObject(ii.ObjectContactSphereSphere(markerNumbers=[m_g, m_b], nodeNumber=data,
                                               spheresRadii=[R_GROUND, P["radius"]], contactStiffness=K_HERTZ,
                                               contactStiffnessExponent=1.5, contactDamping=0.0, impactModel=2,
                                               restitutionCoefficient=P["e_N"]))
    sensor = mbs.AddSensor(ii.SensorNode(nodeNumber=nd, storeInternal=True, writeToFile=False,
                                         outputVariableType=exu.OutputVariableType.Position))
    mbs.Assemble()
    return exu, mbs, sensor


def exudyn_settings(exu, h, t_end, sensor_period):
    """Exudyn's settings of both peer comparisons: steps of h to t_end (adaptive, Exudyn's default: steps
    shrink at contact switches), modified Newton, sensors every ``sensor_period``, nothing printed or written."""
    s = exu.SimulationSettings()
    ti = s.timeIntegration
    ti.numberOfSteps = int(round(t_end / h))
    ti.endTime = t_end
    ti.newton.useModifiedNewton = True
    ti.adaptiveStep = True
    ti.verboseMode = 0
    s.solutionSettings.writeSolutionToFile = False
    s.solutionSettings.sensorsWritePeriod = sensor_period
    s.displayComputationTime = False
    s.displayStatistics = False
    return s


def run_exudyn(h, repeats):
    """(wall s, impact error s, height error m) of Exudyn's SolveDynamic (median over repeats)."""
    walls, arr = [], None
    for _ in range(repeats):
        with warnings.catch_warnings():             # Exudyn's renamed-setting notices
            warnings.simplefilter("ignore", DeprecationWarning)
            exu, mbs, sensor = _exudyn_model()
            s = exudyn_settings(exu, h, T_END, h)
        buf = io.StringIO()
        t0 = time.perf_counter()
        with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(buf):
            ok = mbs.SolveDynamic(s)
        walls.append(time.perf_counter() - t0)
        if ok is False:
            raise RuntimeError(f"Exudyn SolveDynamic failed at h = {h:g}")
        arr = np.asarray(mbs.GetSensorStoredData(sensor))
    t, y = arr[:, 0], arr[:, 2]
    return (statistics.median(walls),) + errors(closing_times(t, y - P["radius"]), t, y)


RUNNERS = {"femb nonsmooth": run_femb_nonsmooth, "femb penalty": run_femb_penalty, "Exudyn": run_exudyn}


def measure(repeats=3, steps=None):
    """Rows (code, h, wall s, impact error s, height error m); Exudyn rows have None when missing."""
    steps = STEPS if steps is None else steps
    have_exudyn = exudyn_version() is not None
    rows = []
    for code, hs in steps.items():
        for h in hs:
            if code == "Exudyn" and not have_exudyn:
                rows.append((code, h, None, None, None))
                continue
            rows.append((code, h) + RUNNERS[code](h, repeats))
    return rows


def time_to_accuracy(rows, tol):
    """{code: least wall time (s) among the rows whose impact-time error ≤ tol, or None}."""
    out = {}
    for code, _h, wall, e_t, _e_y in rows:
        if wall is not None and e_t <= tol:
            out[code] = wall if out.get(code) is None else min(out[code], wall)
        else:
            out.setdefault(code, None)
    return out


def report(rows, tolerances=TOLERANCES):
    """The two tables as text lines."""
    ver = exudyn_version()
    lines = [f"Exudyn: {ver if ver else 'not installed'}", "",
             "| code | h (s) | wall (s, median) | max error t_1..t_3 (s) | max height error (m) |",
             "|---|---|---|---|---|"]
    for code, h, wall, e_t, e_y in rows:
        if wall is None:
            lines.append(f"| {code} | {h:g} | not installed | - | - |")
        else:
            lines.append(f"| {code} | {h:g} | {wall:.4f} | {e_t:.2e} | {e_y:.2e} |")
    lines += ["", "| impact times within | femb nonsmooth (s) | femb penalty (s) | Exudyn (s) "
              "| nonsmooth / Exudyn | penalty / Exudyn |", "|---|---|---|---|---|---|"]
    for tol in tolerances:
        best = time_to_accuracy(rows, tol)
        cells = [("-" if c not in best else "not reached") if best.get(c) is None else f"{best[c]:.4f}"
                 for c in RUNNERS]
        ex = best.get("Exudyn")
        ratios = [f"{best[c] / ex:.3f}" if ex and best.get(c) is not None else "-"
                  for c in ("femb nonsmooth", "femb penalty")]
        lines.append(f"| {tol:g} s | " + " | ".join(cells + ratios) + " |")
    lines += ["", "| h (s) | femb penalty / Exudyn, wall at the same h |", "|---|---|"]
    pen = {h: w for c, h, w, _et, _ey in rows if c == "femb penalty"}
    for c, h, w, _et, _ey in rows:
        if c == "Exudyn" and w and pen.get(h):
            lines.append(f"| {h:g} | {pen[h] / w:.3f} |")
    return lines


def main(repeats=3):
    for line in report(measure(repeats)):
        print(line)


if __name__ == "__main__":
    main()

"""Heavy top: error against the quaternion-ODE reference, orders and cost, femb beside Exudyn.

The protocol of docs/spatial.md §7.1: errors at t = 1 s for h = 2⁻⁸ … 2⁻¹³,
ρ∞ = 0.9, in the centre of mass x_cm (m), the body angular velocity Ω (rad/s)
and the support force λ (N), each the largest component error; fitted orders
over the four finest steps; µs per step as the median of several runs
(``time.perf_counter`` around the whole ``simulate``, compilation excluded by
a first run). When Exudyn is installed (``pip install femb[peers]``), the same
top in Exudyn (Euler parameters, index-3 generalized-α, ``CreateRigidBody`` and
``CreateSphericalJoint``) is timed and its x_cm error printed beside femb's.

Run: ``python -m femb.benchmarks.accuracy.heavy_top_study [--repeats 5] [--formulation index2] [--rho-inf 1]``
(Exudyn is only run for the protocol's index 3 at ρ∞ = 0.9).
"""
from __future__ import annotations

import argparse
import contextlib
import io
import statistics
import time
import warnings

import numpy as np

import femb
from femb.benchmarks.scenes.spatial import heavy_top

KS = list(range(8, 14))


def femb_run(model, h, repeats, formulation="index3", rho_inf=0.9):
    """(outputs at t = 1, median µs/step, Newton iterations/step)."""
    walls = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", femb.ParameterWarning)      # ρ∞ = 1
            r = femb.simulate(model, 1.0, h, rho_inf=rho_inf, store=False, formulation=formulation)
        walls.append(time.perf_counter() - t0)
    out = {k: float(v[-1]) for k, v in heavy_top.outputs(r).items()}
    return out, statistics.median(walls) / r.steps * 1e6, float(r.newton_iterations.mean())


def exudyn_run(h, repeats):
    """(x_cm error vector at t = 1 as (x, y, z), median µs/step) of the same top in Exudyn, or None."""
    try:
        import exudyn as exu
        from exudyn.utilities import RigidBodyInertia, SensorBody
    except ImportError:
        return None
    P = heavy_top.PARAMS
    X = np.asarray(P["X"], dtype=float)
    W = np.asarray(P["omega0"], dtype=float)
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    ground = mbs.CreateGround(referencePosition=[0.0, 0.0, 0.0])
    body = mbs.CreateRigidBody(inertia=RigidBodyInertia(mass=P["mass"], inertiaTensor=np.diag(P["inertia"])),
                               referencePosition=X, initialVelocity=np.cross(W, X), initialAngularVelocity=W,
                               gravity=list(P["g"]), nodeType=exu.NodeType.RotationEulerParameters)
    mbs.CreateSphericalJoint(bodyNumbers=[ground, body], position=[0.0, 0.0, 0.0])
    sensor = mbs.AddSensor(SensorBody(bodyNumber=body, storeInternal=True,
                                      outputVariableType=exu.OutputVariableType.Position))
    mbs.Assemble()
    s = exu.SimulationSettings()
    ti = s.timeIntegration
    ti.endTime = 1.0
    ti.numberOfSteps = int(round(1.0 / h))
    ti.generalizedAlpha.spectralRadius = 0.9
    ti.generalizedAlpha.useIndex2Constraints = False
    ti.generalizedAlpha.useNewmark = False
    ti.generalizedAlpha.computeInitialAccelerations = True
    ti.verboseMode = 0
    s.solutionSettings.writeSolutionToFile = False
    s.solutionSettings.sensorsWritePeriod = 1.0
    walls = []
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for _ in range(repeats):
            buf = io.StringIO()
            t0 = time.perf_counter()
            with contextlib.redirect_stdout(buf):
                mbs.SolveDynamic(s)
            walls.append(time.perf_counter() - t0)
    pos = np.asarray(mbs.GetSensorStoredData(sensor))[-1, 1:4]
    return pos, statistics.median(walls) / ti.numberOfSteps * 1e6


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--formulation", choices=("index3", "index2"), default="index3")
    ap.add_argument("--rho-inf", type=float, default=0.9)
    a = ap.parse_args(argv)
    model = heavy_top.build().compile()
    with_peer = a.formulation == "index3" and a.rho_inf == 0.9
    femb_run(model, 2.0 ** -8, 1, a.formulation, a.rho_inf)     # compile (or load) before timing
    ref = {k: float(np.atleast_1d(v)[-1]) for k, v in heavy_top.reference(np.array([1.0])).items()
           if k != "description"}
    groups = {"x_cm": ("x_cm", "y_cm", "z_cm"), "Omega": ("omega_x", "omega_y", "omega_z"),
              "lambda": ("lambda_x", "lambda_y", "lambda_z")}
    rows, errs = [], {g: [] for g in groups}
    for k in KS:
        h = 2.0 ** -k
        try:
            out, us, it = femb_run(model, h, a.repeats, a.formulation, a.rho_inf)
        except femb.ConvergenceError as exc:
            print(f"h = 2^-{k}: {str(exc).splitlines()[0]}")
            continue
        e = {g: max(abs(out[n] - ref[n]) for n in names) for g, names in groups.items()}
        for g in groups:
            errs[g].append(e[g])
        ex = exudyn_run(h, a.repeats) if with_peer else None
        ex_err = (float(np.abs(ex[0] - np.array([ref["x_cm"], ref["y_cm"], ref["z_cm"]])).max()) if ex else None)
        rows.append((k, e, us, it, ex_err, ex[1] if ex else None))
    print(f"heavy top, t = 1 s, rho_inf = {a.rho_inf:g}, {a.formulation}, errors against the quaternion-ODE "
          f"reference (DOP853, 1e-13)")
    print(f"{'h':>7} {'x_cm err (m)':>13} {'Omega err':>11} {'lambda err (N)':>15} {'us/step':>9} "
          f"{'Newton':>7} {'Exudyn x err':>13} {'Exudyn us/step':>15}")
    for k, e, us, it, exe, exus in rows:
        print(f"{'2^-' + str(k):>7} {e['x_cm']:13.3e} {e['Omega']:11.3e} {e['lambda']:15.3e} {us:9.2f} {it:7.2f} "
              + (f"{exe:13.3e} {exus:15.2f}" if exe is not None else f"{'-':>13} {'-':>15}"))
    hs = np.array([2.0 ** -row[0] for row in rows])
    if len(hs) < 4:
        return
    for g in groups:
        p = np.polyfit(np.log(hs[-4:]), np.log(errs[g][-4:]), 1)[0]
        print(f"fitted order over h = 2^-10 ... 2^-13, {g}: {p:.2f}")


if __name__ == "__main__":
    main()

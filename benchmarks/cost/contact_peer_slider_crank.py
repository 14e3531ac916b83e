"""Slider–crank with translational clearance: femb's nonsmooth contact against Exudyn's penalty contact, same run.

``python -m femb.benchmarks.cost.contact_peer_slider_crank`` integrates the slider–crank of
:mod:`femb.benchmarks.scenes.contact.contact_slider_crank` (Flores, Leine & Glocker, Multibody Syst.
Dyn. 23 (2010) 165–190, Table 1: l₁ = 0.153, l₂ = 0.306 m, slider 0.1 × 0.05 m, clearance 1 mm on
each side, e_N = 0.4, μ = 0.01, ω₁(0) = 150 rad/s, gravity) to ``T_END`` in both codes and prints,
per code and step size, the wall time (median of ``repeats`` runs interleaved in one process,
``time.perf_counter``, model construction and compile excluded) and the error of the crank angle at ``T_END`` against

* ``REF_H``: femb's nonsmooth run at a small step (the rigid model's converged solution; its own
  step-size error is printed beside it), and
* Exudyn's own run at its smallest step (how far Exudyn is from its own converged solution),

then, for each accuracy in ``TOLERANCES``, the least wall time at which each code meets it against
the rigid reference, and the ratio femb / Exudyn.

Codes compared
--------------
* ``femb nonsmooth``: :func:`femb.contact.simulate`, the scene as it is (three hinges, four corner
  contacts), ρ∞ = 0.8, impacts located.
* ``Exudyn``: the same bodies (``NodeRigidBody2D``/``ObjectRigidBody2D``, masses and inertias of the
  scene), ``ObjectJointRevolute2D`` hinges, and per slider corner an ``ObjectContactSphereSphere``
  between a sphere of radius ``R_CORNER`` = 1e-5 m whose surface passes through the corner and a
  ground sphere of radius ``R_GUIDE`` = 1e4 m whose surface is the guide (centre above the upper
  guide, below the lower one, at x = ``X_GUIDE`` = 0.306 m, mid-stroke: over the slider's travel
  x ∈ [0.103, 0.509] m the sphere departs from the plane by at most (0.203 m)²/(2 R_GUIDE) =
  2.1e-6 m, 0.2 % of the clearance), Hertz law f = k δ^{3/2} with
  ``K_HERTZ`` = 1e8 N/m^{3/2} (the stiffest decade that runs: with 1e9 and 1e10 Exudyn's step control
  reaches its minimum step 1e-8 s at the first impact, t = 0.00269 s, and stops, with modified and
  with full Newton; at 1e8 the slider's largest overlap at 0.5 m/s is about
  (5 m v²/(4 k))^{2/5} = 0.14 mm, 14 % of the clearance), ``impactModel = 2`` (Gonthier/Carvalho–Martins, the model Exudyn's documentation
  calls the most accurate for the restitution coefficient) with ``restitutionCoefficient = 0.4``,
  ``contactDamping = 0``, ``dynamicFriction = 0.01`` with the default regularization zone 1e-3 m/s,
  modified Newton, Exudyn's default generalized-α (ρ∞ = 0.9) and default step control, which cuts
  the step at contact switches (the settings of Exudyn's ``newtonsCradle.py`` example, as for the
  ball in :mod:`femb.benchmarks.cost.contact_peer`). Timing of ``SolveDynamic`` only.

The penalty model is a different model: its contacts last a finite time and its restitution
depends on k and the impact speed, so its crank angle converges to another value than the rigid
model's; the tables give that difference (the floor of Exudyn's error against the rigid reference).
"""
from __future__ import annotations

import contextlib
import io
import math
import statistics
import time
import warnings

import numpy as np

from femb.benchmarks.cost.contact_peer import exudyn_settings, exudyn_version
from femb.benchmarks.scenes.contact import contact_slider_crank as scene

T_END = 0.02
REF_H = 2.5e-5
TOLERANCES = (1e-2, 3e-3, 1e-3, 3e-4, 1e-4)
STEPS = {"femb nonsmooth": (4e-4, 2e-4, 1e-4, 5e-5),
         "Exudyn": (1e-4, 5e-5, 2e-5, 1e-5)}
K_HERTZ = 1e8
R_CORNER = 1e-5
R_GUIDE = 1e4
P = scene.PARAMS
X_GUIDE = P["l2"]


def femb_runner(h):
    """A function running femb's scene to T_END at step h and returning (wall s, crank angle); compiled."""
    from femb.contact import simulate
    model = scene.build().compile()
    simulate(model, 2 * h, h)                                    # compile outside the timing

    def run():
        t0 = time.perf_counter()
        res = simulate(model, T_END, h, rho_inf=0.8)
        return time.perf_counter() - t0, float(res.series("crank.theta")[0][-1])
    return run


def _exudyn_bodies(mbs, ii):
    """The three bodies (crank, rod, slider) with the scene's initial state; returns their object numbers."""
    l1, l2, w1 = P["l1"], P["l2"], P["omega1"]
    w2 = -w1 * l1 / l2
    init = {"crank": ([0.5 * l1, 0.0], [0.0, 0.5 * l1 * w1, w1]),
            "rod": ([l1 + 0.5 * l2, 0.0], [0.0, l1 * w1 + 0.5 * l2 * w2, w2]),
            "slider": ([l1 + l2, 0.0], [0.0, 0.0, 0.0])}
    objs = {}
    for name, (pos, vel) in init.items():
        m, J = scene.MASSES[name]
        nd = mbs.AddNode(ii.NodeRigidBody2D(referenceCoordinates=pos + [0.0], initialVelocities=vel))
        objs[name] = mbs.AddObject(ii.ObjectRigidBody2D(nodeNumber=nd, physicsMass=m, physicsInertia=J))
        mk = mbs.AddMarker(ii.MarkerBodyMass(bodyNumber=objs[name]))
        mbs.AddLoad(ii.LoadMassProportional(markerNumber=mk, loadVector=[0.0, -P["g"], 0.0]))
    return objs, nd


def _exudyn_joints(mbs, ii, ground, objs):
    l1, l2 = P["l1"], P["l2"]
    pairs = (((ground, [0.0, 0.0, 0.0]), (objs["crank"], [-0.5 * l1, 0.0, 0.0])),
             ((objs["crank"], [0.5 * l1, 0.0, 0.0]), (objs["rod"], [-0.5 * l2, 0.0, 0.0])),
             ((objs["rod"], [0.5 * l2, 0.0, 0.0]), (objs["slider"], [0.0, 0.0, 0.0])))
    for (a, pa), (b, pb) in pairs:
        ma = mbs.AddMarker(ii.MarkerBodyPosition(bodyNumber=a, localPosition=pa))
        mb = mbs.AddMarker(ii.MarkerBodyPosition(bodyNumber=b, localPosition=pb))
        mbs.AddObject(ii.ObjectJointRevolute2D(markerNumbers=[ma, mb]))


def _exudyn_contacts(exu, mbs, ii, ground, slider):
    """Four corners, each a small sphere against a ground sphere of radius R_GUIDE whose surface is the guide."""
    a, b, c = P["a"], P["b"], P["c"]
    for side in (1.0, -1.0):
        centre = [X_GUIDE, side * (b + c + R_GUIDE), 0.0]
        m_guide = mbs.AddMarker(ii.MarkerBodyRigid(bodyNumber=ground, localPosition=centre))
        for x in (-a, a):
            mk = mbs.AddMarker(ii.MarkerBodyRigid(bodyNumber=slider, localPosition=[x, side * (b - R_CORNER), 0.0]))
            data = mbs.AddNode(ii.NodeGenericData(initialCoordinates=[0.1, 0.0, 0.0, 0.0],
                                                  numberOfDataCoordinates=4))
            mbs.AddObject(ii.ObjectContactSphereSphere(
                markerNumbers=[m_guide, mk], nodeNumber=data, spheresRadii=[R_GUIDE, R_CORNER],
                dynamicFriction=P["mu"], contactStiffness=K_HERTZ, contactStiffnessExponent=1.5,
                contactDamping=0.0, impactModel=2, restitutionCoefficient=P["e_N"]))


def exudyn_model(contacts=True):
    """(exu, mbs, sensor of the crank's node, system container) of the slider–crank in Exudyn, assembled
    (``contacts=False``: without the corner contacts, the check of bodies and hinges)."""
    import exudyn as exu
    from exudyn import itemInterface as ii
    sc = exu.SystemContainer()
    mbs = sc.AddSystem()
    ground = mbs.AddObject(ii.ObjectGround(referencePosition=[0.0, 0.0, 0.0]))
    objs, _ = _exudyn_bodies(mbs, ii)
    _exudyn_joints(mbs, ii, ground, objs)
    if contacts:
        _exudyn_contacts(exu, mbs, ii, ground, objs["slider"])
    crank_node = mbs.GetObject(objs["crank"])["nodeNumber"]
    sensor = mbs.AddSensor(ii.SensorNode(nodeNumber=crank_node, storeInternal=True, writeToFile=False,
                                         outputVariableType=exu.OutputVariableType.Coordinates))
    mbs.Assemble()
    return exu, mbs, sensor, sc


def exudyn_runner(h, contacts=True):
    """A function running Exudyn's model to T_END at step h and returning (wall s of SolveDynamic, crank angle)."""
    def run():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)
            exu, mbs, sensor, _sc = exudyn_model(contacts)
            s = exudyn_settings(exu, h, T_END, T_END / 20)
        buf = io.StringIO()
        t0 = time.perf_counter()
        try:
            with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(buf):
                mbs.SolveDynamic(s)
        except Exception as err:                # exudyn.SolverError: the step control gave up
            raise RuntimeError(f"Exudyn SolveDynamic failed at h = {h:g}: {buf.getvalue()[-300:]}") from err
        wall = time.perf_counter() - t0
        arr = np.asarray(mbs.GetSensorStoredData(sensor))
        if abs(arr[-1, 0] - T_END) > 1e-9:
            raise RuntimeError(f"Exudyn stopped at t = {arr[-1, 0]:g} s, not {T_END:g} s (h = {h:g})")
        return wall, float(arr[-1, 3])                          # columns t, x, y, θ of the crank's node
    return run


def measure(repeats=3, steps=None):
    """Rows (code, h, wall s median, crank angle at T_END) and the rigid reference angles (femb at 2 REF_H, REF_H).

    The runs are interleaved: each repeat runs every (code, h) once, so that the machine's load
    moves all of them alike.
    """
    steps = STEPS if steps is None else steps
    refs = [femb_runner(h)()[1] for h in (2 * REF_H, REF_H)]
    have_exudyn = exudyn_version() is not None
    configs = [(code, h) for code, hs in steps.items() for h in hs]
    runners = {(c, h): (femb_runner(h) if c == "femb nonsmooth" else exudyn_runner(h))
               for c, h in configs if c != "Exudyn" or have_exudyn}
    walls = {k: [] for k in runners}
    angle = {}
    for _ in range(repeats):
        for k, run in runners.items():
            w, angle[k] = run()
            walls[k].append(w)
    rows = [(c, h, statistics.median(walls[(c, h)]), angle[(c, h)]) if (c, h) in runners else (c, h, None, None)
            for c, h in configs]
    return rows, refs


def report(rows, refs, tolerances=TOLERANCES):
    """The tables as text lines."""
    ref = refs[-1]
    ex = [r for r in rows if r[0] == "Exudyn" and r[3] is not None]
    ex_conv = ex[-1][3] if ex else None
    lines = [f"Exudyn: {exudyn_version() or 'not installed'}",
             f"rigid reference: femb h = {REF_H:g}: crank angle {ref:.7f} rad at {T_END:g} s "
             f"(h = {2 * REF_H:g}: {refs[0]:.7f}, difference {abs(refs[0] - ref):.1e})", "",
             "| code | h (s) | wall (s, median) | crank angle (rad) | error vs rigid ref. | error vs own smallest h |",
             "|---|---|---|---|---|---|"]
    for code, h, wall, th in rows:
        if wall is None:
            lines.append(f"| {code} | {h:g} | not installed | - | - | - |")
            continue
        own = ex_conv if code == "Exudyn" else ref
        lines.append(f"| {code} | {h:g} | {wall:.3f} | {th:.6f} | {abs(th - ref):.1e} | {abs(th - own):.1e} |")
    lines += ["", "| crank angle within (vs rigid ref.) | femb (s) | Exudyn (s) | femb / Exudyn |", "|---|---|---|---|"]
    for tol in tolerances:
        best = {}
        for code, _h, wall, th in rows:
            if wall is not None and abs(th - ref) <= tol:
                best[code] = min(best.get(code, math.inf), wall)
        f, e = best.get("femb nonsmooth"), best.get("Exudyn")
        ratio = f"{f / e:.3f}" if f and e else "-"
        lines.append(f"| {tol:g} rad | {f'{f:.3f}' if f else 'not reached'} | {f'{e:.3f}' if e else 'not reached'} "
                     f"| {ratio} |")
    return lines


def main(repeats=3):
    rows, refs = measure(repeats)
    for line in report(rows, refs):
        print(line)


if __name__ == "__main__":
    main()

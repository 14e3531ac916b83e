"""The Whipple bicycle from femb's spatial rigid bodies, revolute joints and rolling discs.

Four :class:`~femb.elements.spatial_bodies.SpatialRigidBody` (rear wheel R, rear frame B, front
frame H, front wheel F), three :class:`~femb.elements.spatial_joints.RevoluteJoint` (rear hub,
steer axis, front hub), two :class:`~femb.elements.rolling.RollingDisc` (each wheel on the
ground plane z = 0) and gravity g along +z. Coordinates and
data of Meijaard, Papadopoulos, Ruina & Schwab, Proc. R. Soc. A 463 (2007) 1955–1982, Table 1:
x forward, y right, z down, the rear contact at the origin, the steer axis through
(w + c, 0, 0) tilted back by λ. Not the published linear equations: the reference for them is
:mod:`femb.benchmarks.references.whipple_linear`.

Upright straight running at speed v is a steady motion, one of a family (the speed). :func:`linearized`
linearizes it with :func:`femb.analysis.linearize.linearize` and eliminates the drift — position (x, y),
heading (rotation about z) and the two wheel angles, five symmetries — and the change of speed
along the family (a direction the linearization maps into the drift); the four states left are
lean φ, steer δ and their rates (named states). The model is compiled once; each speed is a
state of it.

Run ``python -m femb.benchmarks.scenes.spatial.whipple_bicycle`` for the eigenvalues at 0, 5 and 10 m/s against
Table 2 of the paper, the weave and capsize speeds, and the time of the whole study
(eigenvalues at 101 speeds), and ``--plot FILE`` for the root locus against speed.

**The nonlinear run** (the IFToMM uncontrolled-bicycle benchmark): ``build(v, roll_rate=φ̇₀)``
starts the bicycle upright at speed v with a lean rate φ̇₀, and ``femb.simulate`` integrates the
full 3-D model, its rolling contacts as velocity-level constraints. Inside the self-stable range
(4.292–6.024 m/s) the lean decays, below it the weave grows; :func:`roll_perturbation` runs it and
fits the lean to the modes of the linearization (:func:`fit_lean`), so that the growth or decay
rate measured in the nonlinear run is compared with the real part of the weave eigenvalue.
``--run`` prints that table. The scene is registered: ``femb list whipple_bicycle``, ``femb run
whipple_bicycle --set v=3 --set roll_rate=0.1 --t-end 2`` (outputs lean, steer, speed and the
normal contact forces).
"""
from __future__ import annotations

import argparse
import sys
import time

import numpy as np

from femb import Mechanism
from femb.analysis import linearize as fl
from femb.elements.rolling import RollingDisc
from femb.elements.spatial_bodies import SpatialRigidBody
from femb.elements.spatial_forces import SpatialGravity
from femb.elements.spatial_joints import RevoluteJoint

from femb.benchmarks.references.whipple_linear import BENCHMARK

#: run settings of the nonlinear run (the scene protocol of femb.study.registry; ``femb run whipple_bicycle``)
DEFAULTS = {"t_end": 5.0, "h": 1e-3, "rho_inf": 0.7}
PARAMETERS = {"v": ("forward speed", "m/s"), "roll_rate": ("initial lean rate", "rad/s"),
              "p": ("parameter set, a dict (default: the benchmark bicycle of Meijaard et al. 2007)", "-")}
OUTPUTS = {"lean": ("lean angle φ of the rear frame (right positive)", "rad"),
           "steer": ("steer angle δ of the front frame relative to the rear frame", "rad"),
           "speed": ("forward speed of the rear wheel centre", "m/s"),
           "N_rear": ("normal force of the ground on the rear wheel", "N"),
           "N_front": ("normal force of the ground on the front wheel", "N")}
#: the h-convergence study (femb bench convergence whipple_bicycle): femb's own run at the smallest
#: step is the reference (no independent solution of the nonlinear 3-D bicycle)
CONVERGENCE = {"t_end": 1.0, "h": [4e-3, 2e-3, 1e-3, 5e-4], "q": ["lean", "steer"], "lambda": ["N_rear", "N_front"]}

#: Table 2 of Meijaard et al. (2007)
TABLE2 = {"weave_speed": 4.29238253634111, "capsize_speed": 6.02426201538837,
          5.0: [-14.07838969279822, -0.77534188219585 - 4.46486771378823j,
                -0.77534188219585 + 4.46486771378823j, -0.32286642900409],
          0.0: [-5.53094371765393, -3.13164324790656, 3.13164324790656, 5.53094371765393],
          10.0: [-24.62459635017404, -3.72016840437287 - 10.90681139476287j,
                 -3.72016840437287 + 10.90681139476287j, 0.16105338653172]}


def _inertia(xx, yy, zz, xz=0.0):
    return np.array([[xx, 0.0, xz], [0.0, yy, 0.0], [xz, 0.0, zz]])


def build(v=4.6, p=None, roll_rate=0.5):
    """The bicycle upright and running straight at speed ``v`` (m/s), as a :class:`~femb.Mechanism`.

    The defaults are a run inside the self-stable speed range (4.292–6.024 m/s) started with a
    lean rate of 0.5 rad/s: the weave decays.

    Parameters
    ----------
    v : float
        Forward speed (m/s).
    p : dict, optional
        Parameters (keys of ``BENCHMARK`` in :mod:`femb.benchmarks.references.whipple_linear`).
    roll_rate : float
        An initial lean rate φ̇₀ (rad/s, positive: leaning right): the whole bicycle turns about
        the line of its ground contacts (the x axis), every body with the angular velocity φ̇₀ e_x
        and its centre with φ̇₀ e_x × r (a motion the joints and the rolling contacts allow).
    """
    p = dict(BENCHMARK if p is None else p)
    w, c, lam, rR, rF = p["w"], p["c"], p["lam"], p["rR"], p["rF"]
    ex = np.array([1.0, 0.0, 0.0])

    def vel(r):
        return tuple(v * ex + roll_rate * np.cross(ex, r))

    m = Mechanism("whipple_bicycle")
    rear, front = np.array([0.0, 0.0, -rR]), np.array([w, 0.0, -rF])
    xB, xH = np.array([p["xB"], 0.0, p["zB"]]), np.array([p["xH"], 0.0, p["zH"]])
    m.add(SpatialRigidBody("rear_wheel", p["mR"], _inertia(p["IRxx"], p["IRyy"], p["IRxx"]),
                           position=tuple(rear), velocity=vel(rear), omega=(roll_rate, -v / rR, 0.0)))
    m.add(SpatialRigidBody("rear_frame", p["mB"], _inertia(p["IBxx"], p["IByy"], p["IBzz"], p["IBxz"]),
                           position=tuple(xB), velocity=vel(xB), omega=(roll_rate, 0.0, 0.0)))
    m.add(SpatialRigidBody("front_frame", p["mH"], _inertia(p["IHxx"], p["IHyy"], p["IHzz"], p["IHxz"]),
                           position=tuple(xH), velocity=vel(xH), omega=(roll_rate, 0.0, 0.0)))
    m.add(SpatialRigidBody("front_wheel", p["mF"], _inertia(p["IFxx"], p["IFyy"], p["IFxx"]),
                           position=tuple(front), velocity=vel(front), omega=(roll_rate, -v / rF, 0.0)))
    m.add(RevoluteJoint("rear_hub", "rear_frame", "rear_wheel", at=(0.0, 0.0, -rR), axis=(0.0, 1.0, 0.0)))
    m.add(RevoluteJoint("steer", "rear_frame", "front_frame", at=(w + c, 0.0, 0.0), axis=steer_axis(p)))
    m.add(RevoluteJoint("front_hub", "front_frame", "front_wheel", at=(w, 0.0, -rF), axis=(0.0, 1.0, 0.0)))
    for name, body, r in (("rear_contact", "rear_wheel", rR), ("front_contact", "front_wheel", rF)):
        m.add(RollingDisc(name, body, r, (0.0, 1.0, 0.0), normal=(0.0, 0.0, -1.0), tangent=(1.0, 0.0, 0.0)))
    m.add(SpatialGravity((0.0, 0.0, p["g"])))
    return m


def steer_axis(p=None):
    """The steer axis, pointing down (positive steer δ turns right), space axes."""
    lam = (BENCHMARK if p is None else p)["lam"]
    return (np.sin(lam), 0.0, np.cos(lam))


def symmetries(model, p=None):
    """The drift of straight running (position, heading, wheel angles) and the speed family."""
    p = dict(BENCHMARK if p is None else p)
    return [fl.translation((1.0, 0.0, 0.0), "x"), fl.translation((0.0, 1.0, 0.0), "y"),
            fl.rotation((0.0, 0.0, 1.0), name="heading"),
            fl.spin("rear_wheel", (0.0, 1.0, 0.0), "rear wheel angle"),
            fl.spin("front_wheel", (0.0, 1.0, 0.0), "front wheel angle"),
            fl.direction(np.zeros(model.nq), velocities(model, 1.0, p), "speed")]


def velocities(model, v, p=None):
    """The velocities (nq,) of straight running at speed ``v``: every body at v along x, wheels spinning."""
    p = dict(BENCHMARK if p is None else p)
    qd = np.zeros(model.nq)
    for body, r in (("rear_wheel", p["rR"]), ("rear_frame", None), ("front_frame", None), ("front_wheel", p["rF"])):
        idx = model.node_vindex[body]
        qd[idx[0]] = v
        if r is not None:
            qd[idx[4]] = -v / r
    return qd


_MODELS = {}


def model_for(p=None):
    """The compiled bicycle for parameters ``p`` (compiled once per parameter set)."""
    key = tuple(sorted(dict(BENCHMARK if p is None else p).items()))
    if key not in _MODELS:
        _MODELS[key] = build(0.0, p).compile()
    return _MODELS[key]


def linearized(v=5.0, p=None, model=None):
    """The lateral dynamics at speed ``v``: a :class:`femb.analysis.linearize.LinearModel` of (φ, δ, φ̇, δ̇).

    Inputs: the lean torque T_φ (on the rear frame about x) and the steer torque T_δ (front frame
    on rear frame about the steer axis); outputs φ and δ.
    """
    model = model_for(p) if model is None else model
    q = model.q0
    phi = fl.angle(model, q, "rear_frame", (1.0, 0.0, 0.0), name="lean")
    delta = fl.angle(model, q, "front_frame", steer_axis(p), relative_to="rear_frame", name="steer")
    states = [phi, delta, fl.Output("lean_d", "rad/s", phi.cq, phi.cv, True),
              fl.Output("steer_d", "rad/s", delta.cq, delta.cv, True)]
    inputs = [fl.torque(model, q, "rear_frame", (1.0, 0.0, 0.0), name="T_lean"),
              fl.torque(model, q, "front_frame", steer_axis(p), reaction="rear_frame", name="T_steer")]
    return fl.linearize(model, (model.q0, velocities(model, v, p)), about="steady",
                        symmetries=symmetries(model, p), inputs=inputs, outputs=[phi, delta], states=states)


def eigenvalues(v, p=None):
    """The four eigenvalues at speed ``v`` (sorted by real part, then imaginary part)."""
    ev = np.linalg.eigvals(linearized(v, p).A)
    return ev[np.lexsort((ev.imag, ev.real))]


def weave_speed(p=None, bracket=(3.0, 5.0)):
    """The speed where the weave pair crosses the imaginary axis (m/s)."""
    from scipy.optimize import brentq      # here: scipy.optimize takes a second to import
    return brentq(lambda v: max(e.real for e in eigenvalues(v, p) if abs(e.imag) > 1e-9), *bracket, xtol=1e-13)


def capsize_speed(p=None, bracket=(5.0, 8.0)):
    """The speed where the real capsize root crosses zero (m/s)."""
    from scipy.optimize import brentq
    return brentq(lambda v: max(e.real for e in eigenvalues(v, p) if abs(e.imag) <= 1e-9), *bracket, xtol=1e-13)


def study(speeds=None, p=None):
    """Eigenvalues at ``speeds`` (default 101 speeds in [0, 10] m/s): (speeds, (n, 4) complex)."""
    speeds = np.linspace(0.0, 10.0, 101) if speeds is None else np.asarray(speeds, dtype=float)
    return fl.eigenvalue_sweep(lambda v: linearized(v, p), speeds)


def lean_steer(model, q, p=None):
    """Lean φ and steer δ (rad) of the configurations ``q`` (nt, nx).

    φ = asin(e_z · R_B e_y) (R_B the rear frame: heading ψ, then lean φ about the heading's x axis);
    δ: the rotation of the front frame relative to the rear frame about the steer axis s,
    sin δ = s · vee(R_rel − R_relᵀ)/2, cos δ = (tr R_rel − 1)/2 with R_rel = R_Bᵀ R_H.
    """
    from femb.base.rotations import quat_to_matrix
    s_ax = np.asarray(steer_axis(p))
    q = np.atleast_2d(q)
    xb, xh = model.node_index["rear_frame"][3:7], model.node_index["front_frame"][3:7]
    lean, steer = np.empty(len(q)), np.empty(len(q))
    for k, qk in enumerate(q):
        RB, RH = quat_to_matrix(qk[xb]), quat_to_matrix(qk[xh])
        lean[k] = np.arcsin(RB[2, 1])
        Rr = RB.T @ RH
        sv = 0.5 * np.array([Rr[2, 1] - Rr[1, 2], Rr[0, 2] - Rr[2, 0], Rr[1, 0] - Rr[0, 1]])
        steer[k] = np.arctan2(s_ax @ sv, 0.5 * (np.trace(Rr) - 1.0))
    return lean, steer


def outputs(result):
    """Lean, steer and speed over the stored steps (the scene protocol)."""
    m = result.model
    lean, steer = lean_steer(m, result.q)
    lam = np.asarray(result.lam)
    return {"lean": lean, "steer": steer, "speed": result.qd[:, m.node_vindex["rear_wheel"][0]].copy(),
            "N_rear": -lam[:, m.lam_indices("rear_contact")[0]], "N_front": -lam[:, m.lam_indices("front_contact")[0]]}


def roll_perturbation(v, roll_rate=0.1, t_end=5.0, h=1e-3, p=None):
    """The nonlinear run: the bicycle at speed ``v`` started with the lean rate ``roll_rate``.

    Returns
    -------
    (t, lean, steer, result, velocity_residual)
        The lean and steer angles (rad) over time, the femb Result and the largest |A q̇ + a| of
        the rolling contacts over the stored steps (m/s).
    """
    import femb
    from femb.system.assembly import velocity_constraints
    model = build(v, p, roll_rate=roll_rate).compile()
    res = femb.simulate(model, t_end, h=h)
    lean, steer = lean_steer(model, res.q, p)
    psi = max(float(np.abs(velocity_constraints(model, t, q, qd)[0]).max())
              for t, q, qd in zip(res.t, res.q, res.qd))
    return res.t, lean, steer, res, psi


def fit_lean(t, lean, ev, t_from=1.0, small=0.01):
    """The growth or decay rate of the weave in a lean history: (σ, ω, rms of the fit's residual).

    Fits lean(t) = Re(c e^{(σ + iω)t}) + b e^{s t} on ``t_from`` ≤ t ≤ the first time |lean| exceeds
    ``small`` (rad; the early, nearly linear part of a growing motion) by nonlinear least
    squares, with σ and ω free and the slowest real eigenvalue s (capsize) of the linearization
    ``ev`` fixed; σ, ω start from the weave eigenvalue of ``ev``. The castering mode has died
    out by ``t_from`` at the speeds of the benchmark (its rate is −10 s⁻¹ or faster).
    """
    from scipy.optimize import least_squares
    ev = np.asarray(ev)
    weave = ev[np.argmax(np.abs(ev.imag))]
    reals = np.sort(ev[np.abs(ev.imag) <= 1e-9].real)[::-1][:1]     # the slowest real mode (capsize)
    big = np.nonzero(np.abs(lean) > small)[0]
    t_to = t[big[0]] if big.size else t[-1]
    sel = (t >= t_from) & (t <= t_to)
    ts, ys = t[sel] - t_from, lean[sel]

    def basis(sig, om):
        cols = [np.exp(sig * ts) * np.cos(om * ts), np.exp(sig * ts) * np.sin(om * ts)]
        cols += [np.exp(s_ * ts) for s_ in reals]
        return np.stack(cols, axis=1)

    def resid(x):
        B = basis(*x)
        c = np.linalg.lstsq(B, ys, rcond=None)[0]
        return B @ c - ys

    sol = least_squares(resid, [weave.real, abs(weave.imag)], xtol=1e-15, ftol=1e-15, gtol=1e-15)
    return float(sol.x[0]), float(sol.x[1]), float(np.sqrt(np.mean(sol.fun ** 2)))


def run_table(speeds=(3.0, 4.6), roll_rate=1e-3, t_end=5.0, h=1e-3):
    """The nonlinear runs at ``speeds``: one row each (speed, weave eigenvalue, fitted σ and ω,
    lean amplitude at the start and at the end, velocity residual), printed."""
    rows = []
    for v in speeds:
        ev = eigenvalues(v)
        t, lean, _, res, psi = roll_perturbation(v, roll_rate, t_end, h)
        sig, om, rms = fit_lean(t, lean, ev)
        weave = ev[np.argmax(np.abs(ev.imag))]
        early = np.abs(lean[(t >= 0.5) & (t <= 1.5)]).max()
        late = np.abs(lean[t >= t_end - 1.0]).max()
        rows.append((v, weave, sig, om, rms, early, late, psi))
        print(f"v = {v:.2f} m/s: weave eigenvalue {weave.real:+.5f} ± {abs(weave.imag):.5f}i; nonlinear run: "
              f"σ = {sig:+.5f}, ω = {om:.5f} (fit rms {rms:.1e} rad); max |lean| in [0.5, 1.5] s {early:.3e}, "
              f"in the last second {late:.3e} rad ({'grows' if late > early else 'decays'}); "
              f"max |A q̇ + a| {psi:.1e} m/s")
    return rows


def convergence(v=4.6, roll_rate=0.5, t_end=2.0, hs=(8e-3, 4e-3, 2e-3, 1e-3), h_ref=1.25e-4):
    """Fitted orders of the nonlinear run in q and in the multipliers [λ; μ] at ``t_end``.

    The reference is femb's own run at ``h_ref`` (no independent solution of the nonlinear 3-D
    bicycle is at hand; the rolling disc and the sleigh are checked against independent ones in
    ``tests/test_nonholonomic_run.py``). Errors: max |Δq| over the configuration entries and
    max |Δλ| / max |λ| over the multipliers. Returns (hs, err_q, err_lam, order_q, order_lam),
    printed.
    """
    import femb
    model = build(v, roll_rate=roll_rate).compile()
    ref = femb.simulate(model, t_end, h=h_ref, store=False)
    eq, el = [], []
    for h in hs:
        r = femb.simulate(model, t_end, h=h, store=False)
        eq.append(float(np.abs(r.q[-1] - ref.q[-1]).max()))
        el.append(float(np.abs(r.lam[-1] - ref.lam[-1]).max() / np.abs(ref.lam[-1]).max()))
    oq = float(np.polyfit(np.log(hs), np.log(eq), 1)[0])
    ol = float(np.polyfit(np.log(hs), np.log(el), 1)[0])
    print(f"bicycle v = {v} m/s, lean rate {roll_rate} rad/s, t = {t_end} s, reference h = {h_ref:g} s:")
    for h, a, b in zip(hs, eq, el):
        print(f"  h = {h:.0e}: max |Δq| = {a:.3e}, max |Δ[λ; μ]| / max |[λ; μ]| = {b:.3e}")
    print(f"  fitted order: q {oq:.3f}, multipliers {ol:.3f}")
    return hs, eq, el, oq, ol


def plot(path, speeds, ev):
    """Root locus against speed (real and imaginary parts), saved to ``path``."""
    return fl.campbell_plot(speeds, ev, path, xlabel="forward speed v (m/s)", ylim=(-10, 10),
                            title="Whipple bicycle from femb's 3-D model")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plot", help="write the root locus against speed to this image file")
    ap.add_argument("--run", action="store_true",
                    help="the nonlinear run: a lean-rate perturbation at 3 and 4.6 m/s, its rate against the weave, "
                         "and its convergence order")
    ap.add_argument("--whole", action="store_true",
                    help="time the whole process (interpreter, imports, compile, 101 speeds) in fresh subprocesses")
    args = ap.parse_args(argv)
    if args.whole:
        return _time_whole()
    if args.run:
        run_table()
        convergence()
        return 0
    t0 = time.perf_counter()
    speeds, ev = study()
    t_study = time.perf_counter() - t0
    worst = 0.0
    for v in (0.0, 5.0, 10.0):
        got = ev[int(round(v * 10))]
        want = np.array(TABLE2[v])
        want = want[np.lexsort((want.imag, want.real))]
        err = float(np.max(np.abs(got - want)))
        worst = max(worst, err)
        print(f"v = {v:4.1f} m/s: " + ", ".join(f"{e.real:.14f}{e.imag:+.14f}i" for e in got)
              + f"   max |Δ| vs Table 2 = {err:.2e}")
    vw, vc = weave_speed(), capsize_speed()
    print(f"weave speed   {vw:.14f} m/s  (Table 2: {TABLE2['weave_speed']:.14f}, Δ = {vw - TABLE2['weave_speed']:.2e})")
    print(f"capsize speed {vc:.14f} m/s  (Table 2: {TABLE2['capsize_speed']:.14f}, Δ = {vc - TABLE2['capsize_speed']:.2e})")
    print(f"eigenvalues at {speeds.size} speeds (build and compile once; linearize and eig each): {t_study:.2f} s")
    print(f"whole process (imports included) until now: {time.perf_counter() - _T_START:.2f} s")
    if args.plot:
        plot(args.plot, speeds, ev)
        print(f"wrote {args.plot}")
    return 0 if worst < 1e-9 else 1


def _time_whole(runs=3):
    """Median wall time of a fresh ``python -c`` that imports femb, compiles the bicycle and computes
    its eigenvalues at 101 speeds (the numba cache warm, as after the first run)."""
    import resource
    import subprocess
    code = "from femb.benchmarks.scenes.spatial import whipple_bicycle as wb; wb.study()"
    times, cpu = [], []
    for _ in range(runs):
        r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-c", code], check=True)
        times.append(time.perf_counter() - t0)
        r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
        cpu.append(r1.ru_utime - r0.ru_utime + r1.ru_stime - r0.ru_stime)
    print(f"whole process, eigenvalues at 101 speeds: median wall {np.median(times):.2f} s "
          f"(runs: {', '.join(f'{t:.2f}' for t in times)}); median CPU (user + sys) {np.median(cpu):.2f} s")
    return 0


_T_START = time.perf_counter()

if __name__ == "__main__":
    sys.exit(main())

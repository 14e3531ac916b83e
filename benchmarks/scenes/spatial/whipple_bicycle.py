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
"""
from __future__ import annotations

import argparse
import sys
import time

import numpy as np
from scipy.optimize import brentq

from femb import Mechanism
from femb.analysis import linearize as fl
from femb.elements.rolling import RollingDisc
from femb.elements.spatial_bodies import SpatialRigidBody
from femb.elements.spatial_forces import SpatialGravity
from femb.elements.spatial_joints import RevoluteJoint

from femb.benchmarks.references.whipple_linear import BENCHMARK

#: Table 2 of Meijaard et al. (2007)
TABLE2 = {"weave_speed": 4.29238253634111, "capsize_speed": 6.02426201538837,
          5.0: [-14.07838969279822, -0.77534188219585 - 4.46486771378823j,
                -0.77534188219585 + 4.46486771378823j, -0.32286642900409],
          0.0: [-5.53094371765393, -3.13164324790656, 3.13164324790656, 5.53094371765393],
          10.0: [-24.62459635017404, -3.72016840437287 - 10.90681139476287j,
                 -3.72016840437287 + 10.90681139476287j, 0.16105338653172]}


def _inertia(xx, yy, zz, xz=0.0):
    return np.array([[xx, 0.0, xz], [0.0, yy, 0.0], [xz, 0.0, zz]])


def build(v=5.0, p=None):
    """The bicycle upright and running straight at speed ``v`` (m/s), as a :class:`~femb.Mechanism`.

    Parameters
    ----------
    v : float
        Forward speed (m/s).
    p : dict, optional
        Parameters (keys of ``BENCHMARK`` in :mod:`femb.benchmarks.references.whipple_linear`).
    """
    p = dict(BENCHMARK if p is None else p)
    w, c, lam, rR, rF = p["w"], p["c"], p["lam"], p["rR"], p["rF"]
    vel = (v, 0.0, 0.0)
    m = Mechanism("whipple_bicycle")
    m.add(SpatialRigidBody("rear_wheel", p["mR"], _inertia(p["IRxx"], p["IRyy"], p["IRxx"]),
                           position=(0.0, 0.0, -rR), velocity=vel, omega=(0.0, -v / rR, 0.0)))
    m.add(SpatialRigidBody("rear_frame", p["mB"], _inertia(p["IBxx"], p["IByy"], p["IBzz"], p["IBxz"]),
                           position=(p["xB"], 0.0, p["zB"]), velocity=vel))
    m.add(SpatialRigidBody("front_frame", p["mH"], _inertia(p["IHxx"], p["IHyy"], p["IHzz"], p["IHxz"]),
                           position=(p["xH"], 0.0, p["zH"]), velocity=vel))
    m.add(SpatialRigidBody("front_wheel", p["mF"], _inertia(p["IFxx"], p["IFyy"], p["IFxx"]),
                           position=(w, 0.0, -rF), velocity=vel, omega=(0.0, -v / rF, 0.0)))
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
    return brentq(lambda v: max(e.real for e in eigenvalues(v, p) if abs(e.imag) > 1e-9), *bracket, xtol=1e-13)


def capsize_speed(p=None, bracket=(5.0, 8.0)):
    """The speed where the real capsize root crosses zero (m/s)."""
    return brentq(lambda v: max(e.real for e in eigenvalues(v, p) if abs(e.imag) <= 1e-9), *bracket, xtol=1e-13)


def study(speeds=None, p=None):
    """Eigenvalues at ``speeds`` (default 101 speeds in [0, 10] m/s): (speeds, (n, 4) complex)."""
    speeds = np.linspace(0.0, 10.0, 101) if speeds is None else np.asarray(speeds, dtype=float)
    return fl.eigenvalue_sweep(lambda v: linearized(v, p), speeds)


def plot(path, speeds, ev):
    """Root locus against speed (real and imaginary parts), saved to ``path``."""
    return fl.campbell_plot(speeds, ev, path, xlabel="forward speed v (m/s)", ylim=(-10, 10),
                            title="Whipple bicycle from femb's 3-D model")


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plot", help="write the root locus against speed to this image file")
    ap.add_argument("--whole", action="store_true",
                    help="time the whole process (interpreter, imports, compile, 101 speeds) in fresh subprocesses")
    args = ap.parse_args(argv)
    if args.whole:
        return _time_whole()
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
    code = "from femb.benchmarks import whipple_bicycle as wb; wb.study()"
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

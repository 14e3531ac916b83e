"""Peer integrators for the benchmark suite: scipy on minimal coordinates, Exudyn on absolute ones.

Two kinds of peers solve the same mechanisms as femb, in the same process and
run, so that their timings are comparable:

* **scipy** :func:`scipy.integrate.solve_ivp` (Radau, BDF, LSODA, DOP853) on
  the independent reference models of the scenes, which share no code with
  femb: Andrews' mechanism in Hairer's relative coordinates (7 angles, 6
  loop-closure constraints, integrated in index-1 form;
  :mod:`femb.benchmarks.references.andrews`) and the slider–crank in minimal
  coordinates (θ, x4; :mod:`femb.benchmarks.references.slider_crank_minimal`).
  Tolerances rtol = atol = tol.
* **Exudyn** (optional, ``pip install exudyn`` or ``pip install femb[peers]``):
  the *same absolute-coordinate models* as femb's scenes (planar rigid bodies
  at their centres of mass, revolute joints, the spring, the torque), built
  with Exudyn's items and integrated with its index-3 generalized-α solver
  (``useIndex2Constraints = False``, ``useNewmark = False``) at the same ρ∞ and
  the same fixed step, with step-size adaptation switched off so that a
  failing step is reported rather than hidden, and Newton tolerances tightened
  (relative 1e-10, absolute 1e-12) so that they sit below the discretization
  error. Exudyn is a C++ code driven from Python; its timing is that of
  ``SolveDynamic`` (model construction and ``Assemble`` excluded, as femb's
  compile is excluded from femb's timing).

A missing peer is never an error: :func:`status` says "not installed" and the
suite prints that in the peer's rows.

Every solver returns a :class:`PeerRun`-like dict: ``outputs`` (name →
array over the requested sample times, the names of the femb scene's
``outputs``), ``wall_s``, ``ok``, ``message`` and a cost counter.

References
----------
P. Virtanen et al., SciPy 1.0: fundamental algorithms for scientific computing
in Python, Nature Methods 17 (2020) 261–272 (solve_ivp).
J. Gerstmayr, Exudyn – a C++-based Python package for flexible multibody
systems, Multibody Syst. Dyn. 60 (2024) 533–561.
"""
from __future__ import annotations

import contextlib
import io
import math
import time
import warnings

import numpy as np

#: solve_ivp methods compared
SCIPY_METHODS = ("Radau", "BDF", "LSODA", "DOP853")

#: Newton tolerances given to Exudyn (its defaults are 1e-8 relative, 1e-10 absolute)
EXUDYN_NEWTON = {"relativeTolerance": 1e-10, "absoluteTolerance": 1e-12}


# --------------------------------------------------------------------------
# availability
# --------------------------------------------------------------------------
def status():
    """Which peers are installed.

    Returns
    -------
    dict
        ``{"scipy": {"installed": bool, "version": str}, "exudyn": {...}}``;
        a missing package has ``"version": "not installed"``.
    """
    import scipy

    out = {"scipy": {"installed": True, "version": scipy.__version__}}
    try:
        import exudyn
    except Exception:   # ImportError, or a broken binary
        out["exudyn"] = {"installed": False, "version": "not installed"}
    else:
        out["exudyn"] = {"installed": True, "version": str(getattr(exudyn, "__version__", "unknown"))}
    return out


def scipy_scenes():
    """Scenes with a scipy minimal-coordinate peer model."""
    return tuple(_SCIPY)


def exudyn_scenes():
    """Scenes with an Exudyn absolute-coordinate peer model."""
    return tuple(_EXUDYN)


# --------------------------------------------------------------------------
# scipy peers
# --------------------------------------------------------------------------
def _scipy_andrews(t, method, tol):
    from femb.benchmarks.references import andrews as ref
    from femb.benchmarks.scenes.planar.andrews import ANGLE_NAMES, LAMBDA_NAMES

    t0 = time.perf_counter()
    sol = ref.solve(t, rtol=tol, atol=tol, method=method)
    wall = time.perf_counter() - t0
    out = {}
    for k, name in enumerate(ANGLE_NAMES):
        out[name] = sol["angles"][:, k]
        out[name + "_d"] = sol["rates"][:, k]
    for k, name in enumerate(LAMBDA_NAMES):
        out[name] = sol["lam"][:, k]
    return out, wall, int(sol["nfev"])


def _scipy_slider_crank(t, method, tol):
    from femb.benchmarks.references import slider_crank_minimal as ref

    t0 = time.perf_counter()
    sol = ref.solve(t, rtol=tol, atol=tol, method=method)
    wall = time.perf_counter() - t0
    out = {k: sol[k] for k in ("theta", "x3", "x4", "theta_d", "x3_d", "x4_d")}
    out["R_pivot_x"] = sol["R_pivot"][:, 0]
    out["R_pivot_y"] = sol["R_pivot"][:, 1]
    return out, wall, int(sol["nfev"])


_SCIPY = {"andrews": _scipy_andrews, "slider_crank": _scipy_slider_crank}


def scipy_solve(scene, method, tol, t):
    """Integrate a scene's minimal-coordinate model with ``solve_ivp``.

    Parameters
    ----------
    scene : str
        ``"andrews"`` or ``"slider_crank"`` (see :func:`scipy_scenes`).
    method : str
        One of :data:`SCIPY_METHODS`.
    tol : float
        rtol = atol.
    t : array_like, shape (ns,)
        Output times, starting at 0.

    Returns
    -------
    dict
        ``outputs`` (name → (ns,)), ``wall_s`` (the ``solve`` call), ``ok``,
        ``message``, ``nfev``.
    """
    fn = _SCIPY[scene]
    t = np.asarray(t, dtype=float)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            outs, wall, nfev = fn(t, method, tol)
    except Exception as exc:    # a peer failing is a measurement, not a crash
        return {"outputs": None, "wall_s": None, "ok": False,
                "message": f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}", "nfev": None}
    return {"outputs": outs, "wall_s": wall, "ok": True, "message": "", "nfev": nfev}


# --------------------------------------------------------------------------
# Exudyn peers: the same absolute-coordinate models
# --------------------------------------------------------------------------
class _ExudynModel:
    """A small builder over Exudyn's item interface (planar bodies, hinges)."""

    def __init__(self):
        import exudyn as exu
        from exudyn import itemInterface as ii

        self.exu, self.ii = exu, ii
        self.SC = exu.SystemContainer()
        self.mbs = self.SC.AddSystem()
        self.ground = self.mbs.AddObject(ii.ObjectGround(referencePosition=[0.0, 0.0, 0.0]))
        self.nodes, self.objects, self.joints, self.sensors = {}, {}, {}, []
        self.reference = {}

    def rigid(self, name, m, J, pos, phi, vel=(0.0, 0.0), omega=0.0):
        ii = self.ii
        nd = self.mbs.AddNode(ii.NodeRigidBody2D(referenceCoordinates=[float(pos[0]), float(pos[1]), float(phi)],
                                                 initialVelocities=[float(vel[0]), float(vel[1]), float(omega)]))
        ob = self.mbs.AddObject(ii.ObjectRigidBody2D(nodeNumber=nd, physicsMass=float(m), physicsInertia=float(J)))
        self.nodes[name], self.objects[name] = nd, ob
        self.reference[name] = np.array([pos[0], pos[1], phi], dtype=float)
        return ob

    def point_mass(self, name, m, pos):
        ii = self.ii
        nd = self.mbs.AddNode(ii.NodePoint2D(referenceCoordinates=[float(pos[0]), float(pos[1])]))
        ob = self.mbs.AddObject(ii.ObjectMassPoint2D(nodeNumber=nd, physicsMass=float(m)))
        self.nodes[name], self.objects[name] = nd, ob
        self.reference[name] = np.array([pos[0], pos[1]], dtype=float)
        return ob

    def marker(self, body, local=(0.0, 0.0)):
        ob = self.ground if body is None else self.objects[body]
        return self.mbs.AddMarker(self.ii.MarkerBodyPosition(bodyNumber=ob,
                                                             localPosition=[float(local[0]), float(local[1]), 0.0]))

    def hinge(self, name, a, pa, b, pb):
        self.joints[name] = self.mbs.AddObject(self.ii.ObjectJointRevolute2D(
            markerNumbers=[self.marker(a, pa), self.marker(b, pb)]))

    def on_x_axis(self, body):
        """Constrain the y coordinate of a point mass to 0 (a guide along x)."""
        ii = self.ii
        ng = self.mbs.AddNode(ii.NodePointGround(referenceCoordinates=[0.0, 0.0, 0.0]))
        mg = self.mbs.AddMarker(ii.MarkerNodeCoordinate(nodeNumber=ng, coordinate=0))
        mb = self.mbs.AddMarker(ii.MarkerNodeCoordinate(nodeNumber=self.nodes[body], coordinate=1))
        self.mbs.AddObject(ii.ObjectConnectorCoordinate(markerNumbers=[mg, mb]))

    def spring(self, a, pa, b, pb, k, length):
        self.mbs.AddObject(self.ii.ObjectConnectorSpringDamper(
            markerNumbers=[self.marker(a, pa), self.marker(b, pb)], stiffness=float(k), damping=0.0,
            referenceLength=float(length)))

    def torque(self, body, value):
        ii = self.ii
        mr = self.mbs.AddMarker(ii.MarkerBodyRigid(bodyNumber=self.objects[body], localPosition=[0.0, 0.0, 0.0]))
        self.mbs.AddLoad(ii.LoadTorqueVector(markerNumber=mr, loadVector=[0.0, 0.0, float(value)]))

    def gravity(self, body, g):
        ii = self.ii
        mm = self.mbs.AddMarker(ii.MarkerBodyMass(bodyNumber=self.objects[body]))
        self.mbs.AddLoad(ii.LoadMassProportional(markerNumber=mm, loadVector=[float(g[0]), float(g[1]), 0.0]))

    def record(self):
        """Sensors on every node's coordinates and velocities and every joint's force."""
        exu, ii = self.exu, self.ii
        self.s_q = {n: self.mbs.AddSensor(ii.SensorNode(nodeNumber=nd, storeInternal=True, writeToFile=False,
                                                        outputVariableType=exu.OutputVariableType.Coordinates))
                    for n, nd in self.nodes.items()}
        self.s_v = {n: self.mbs.AddSensor(ii.SensorNode(nodeNumber=nd, storeInternal=True, writeToFile=False,
                                                        outputVariableType=exu.OutputVariableType.Coordinates_t))
                    for n, nd in self.nodes.items()}
        self.s_f = {n: self.mbs.AddSensor(ii.SensorObject(objectNumber=ob, storeInternal=True, writeToFile=False,
                                                          outputVariableType=exu.OutputVariableType.Force))
                    for n, ob in self.joints.items()}

    def solve(self, t_end, n_steps, rho_inf, n_samples):
        """Assemble, integrate with fixed steps; returns (wall_s, ok, message, data)."""
        exu = self.exu
        self.mbs.Assemble()
        s = exu.SimulationSettings()
        ti = s.timeIntegration
        ti.numberOfSteps = int(n_steps)
        ti.endTime = float(t_end)
        ti.generalizedAlpha.spectralRadius = float(rho_inf)
        ti.generalizedAlpha.useIndex2Constraints = False
        ti.generalizedAlpha.useNewmark = False
        ti.generalizedAlpha.computeInitialAccelerations = True
        ti.newton.relativeTolerance = EXUDYN_NEWTON["relativeTolerance"]
        ti.newton.absoluteTolerance = EXUDYN_NEWTON["absoluteTolerance"]
        ti.adaptiveStep = False
        ti.verboseMode = 0
        s.solutionSettings.writeSolutionToFile = False
        s.solutionSettings.sensorsWritePeriod = float(t_end) / int(n_samples)
        s.displayComputationTime = False
        s.displayStatistics = False
        buf = io.StringIO()
        t0 = time.perf_counter()
        ok, message = True, ""
        try:
            with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(buf):
                res = self.mbs.SolveDynamic(s)
            if res is False:
                ok, message = False, "SolveDynamic returned False"
        except Exception as exc:
            ok = False
            message = f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}".strip()
        wall = time.perf_counter() - t0
        data = {"q": {}, "v": {}, "f": {}}
        for n, sid in self.s_q.items():
            arr = np.asarray(self.mbs.GetSensorStoredData(sid))
            if arr.ndim == 2 and arr.shape[0]:
                arr = arr.copy()
                arr[:, 1:] += self.reference[n][: arr.shape[1] - 1]     # Coordinates are displacements
            data["q"][n] = arr
        for n, sid in self.s_v.items():
            data["v"][n] = np.asarray(self.mbs.GetSensorStoredData(sid))
        for n, sid in self.s_f.items():
            data["f"][n] = np.asarray(self.mbs.GetSensorStoredData(sid))
        return wall, ok, message, data


def _on_grid(arr, t, tol):
    """Rows of a sensor array (time in column 0) at the times ``t`` (NaN where missing)."""
    out = np.full((t.size, arr.shape[1] - 1 if arr.ndim == 2 else 1), np.nan)
    if arr.ndim != 2 or arr.shape[0] == 0:
        return out
    idx = np.searchsorted(arr[:, 0], t - tol)
    for i, (j, tk) in enumerate(zip(idx, t)):
        if j < arr.shape[0] and abs(arr[j, 0] - tk) <= tol:
            out[i] = arr[j, 1:]
    return out


def _exudyn_andrews(t_end, n_steps, rho_inf, n_samples):
    from femb.benchmarks.scenes.planar import andrews as A

    D = A.DATA
    X = _ExudynModel()
    centres, phi = A.initial_centres()
    pts = A.body_points()
    for k in range(7):
        X.rigid(f"b{k + 1}", D["m"][k], D["i"][k], centres[k], phi[k])
    hinges = [("O", None, (0.0, 0.0), "b1", pts[0]["O"]), ("P", "b1", pts[0]["P"], "b2", pts[1]["P"]),
              ("E23", "b2", pts[1]["E"], "b3", pts[2]["E"]), ("E24", "b2", pts[1]["E"], "b4", pts[3]["E"]),
              ("E26", "b2", pts[1]["E"], "b6", pts[5]["E"]), ("B", None, (D["xb"], D["yb"]), "b3", pts[2]["B"]),
              ("A5", None, (D["xa"], D["ya"]), "b5", pts[4]["A"]), ("F", "b4", pts[3]["F"], "b5", pts[4]["F"]),
              ("A7", None, (D["xa"], D["ya"]), "b7", pts[6]["A"]), ("G", "b6", pts[5]["G"], "b7", pts[6]["G"])]
    for name, a, pa, b, pb in hinges:
        X.hinge(name, a, pa, b, pb)
    X.spring("b3", pts[2]["D"], None, (D["xc"], D["yc"]), D["c0"], D["l0"])
    X.torque("b1", D["mom"])
    X.record()
    wall, ok, msg, data = X.solve(t_end, n_steps, rho_inf, n_samples)
    ts = np.linspace(0.0, t_end, n_samples + 1)
    tol = 0.25 * t_end / n_steps
    phi_t = np.stack([_on_grid(data["q"][f"b{k}"], ts, tol)[:, 2] for k in range(1, 8)], axis=1)
    w_t = np.stack([_on_grid(data["v"][f"b{k}"], ts, tol)[:, 2] for k in range(1, 8)], axis=1)
    rel, rel_d = A.relative_angles(phi_t), A.relative_angles(w_t)
    out = {}
    for k, name in enumerate(A.ANGLE_NAMES):
        out[name] = rel[:, k]
        out[name + "_d"] = rel_d[:, k]
    # Exudyn's joint force has the opposite sign of the published multipliers (checked at t = 0)
    lam = np.concatenate([-_on_grid(data["f"][n], ts, tol)[:, :2] for n in A.E_HINGES], axis=1)
    for k, name in enumerate(A.LAMBDA_NAMES):
        out[name] = lam[:, k]
    return out, wall, ok, msg


def _exudyn_slider_crank(t_end, n_steps, rho_inf, n_samples):
    from femb.benchmarks.scenes.planar.slider_crank import PARAMS as P

    l1, l2, th0 = P["l1"], P["l2"], P["theta0"]
    c, s = math.cos(th0), math.sin(th0)
    tip = np.array([l1 * c, l1 * s])
    x3 = l1 * c + math.sqrt(l2 ** 2 - (l1 * s) ** 2)
    slider = np.array([x3, 0.0])
    phi2 = math.atan2(-tip[1], x3 - tip[0])
    X = _ExudynModel()
    X.rigid("crank", P["m1"], P["m1"] * l1 ** 2 / 12.0, 0.5 * tip, th0)
    X.rigid("rod", P["m2"], P["m2"] * l2 ** 2 / 12.0, 0.5 * (tip + slider), phi2)
    X.point_mass("slider", P["m3"], slider)
    X.point_mass("mass", P["m4"], (x3 + P["L0"], 0.0))
    X.hinge("pivot", None, (0.0, 0.0), "crank", (-0.5 * l1, 0.0))
    X.hinge("crank_rod", "crank", (0.5 * l1, 0.0), "rod", (-0.5 * l2, 0.0))
    X.hinge("rod_slider", "rod", (0.5 * l2, 0.0), "slider", (0.0, 0.0))
    X.on_x_axis("slider")
    X.on_x_axis("mass")
    X.spring("slider", (0.0, 0.0), "mass", (0.0, 0.0), P["k"], P["L0"])
    X.torque("crank", P["T"])
    X.record()
    wall, ok, msg, data = X.solve(t_end, n_steps, rho_inf, n_samples)
    ts = np.linspace(0.0, t_end, n_samples + 1)
    tol = 0.25 * t_end / n_steps
    cq, cv = _on_grid(data["q"]["crank"], ts, tol), _on_grid(data["v"]["crank"], ts, tol)
    sq, sv = _on_grid(data["q"]["slider"], ts, tol), _on_grid(data["v"]["slider"], ts, tol)
    mq, mv = _on_grid(data["q"]["mass"], ts, tol), _on_grid(data["v"]["mass"], ts, tol)
    R = _on_grid(data["f"]["pivot"], ts, tol)
    # Exudyn's force of a joint [ground, crank] is the force on the ground marker: minus that on the crank
    out = {"theta": cq[:, 2], "x3": sq[:, 0], "x4": mq[:, 0], "theta_d": cv[:, 2], "x3_d": sv[:, 0],
           "x4_d": mv[:, 0], "R_pivot_x": -R[:, 0], "R_pivot_y": -R[:, 1]}
    return out, wall, ok, msg


def _exudyn_pendulum(t_end, n_steps, rho_inf, n_samples):
    from femb.benchmarks.scenes.planar.pendulum import PARAMS as P

    L, m, g, psi0 = P["length"], P["mass"], P["g"], P["psi0"]
    phi = psi0 - math.pi / 2
    X = _ExudynModel()
    X.rigid("bar", m, m * L * L / 12.0, 0.5 * L * np.array([math.cos(phi), math.sin(phi)]), phi)
    X.hinge("pivot", None, (0.0, 0.0), "bar", (-0.5 * L, 0.0))
    X.gravity("bar", (0.0, -g))
    X.record()
    wall, ok, msg, data = X.solve(t_end, n_steps, rho_inf, n_samples)
    ts = np.linspace(0.0, t_end, n_samples + 1)
    tol = 0.25 * t_end / n_steps
    q, v = _on_grid(data["q"]["bar"], ts, tol), _on_grid(data["v"]["bar"], ts, tol)
    R = _on_grid(data["f"]["pivot"], ts, tol)
    out = {"psi": q[:, 2] + math.pi / 2, "psi_d": v[:, 2], "R_pivot_x": -R[:, 0], "R_pivot_y": -R[:, 1]}
    return out, wall, ok, msg


_EXUDYN = {"andrews": _exudyn_andrews, "slider_crank": _exudyn_slider_crank, "pendulum": _exudyn_pendulum}


def exudyn_solve(scene, t_end, n_steps, rho_inf, n_samples):
    """Integrate a scene's absolute-coordinate model with Exudyn's generalized-α.

    Parameters
    ----------
    scene : str
        See :func:`exudyn_scenes`.
    t_end : float
    n_steps : int
        Fixed steps (h = t_end / n_steps); a multiple of ``n_samples``.
    rho_inf : float
        Spectral radius at infinity.
    n_samples : int
        Outputs are returned at the ``n_samples + 1`` times
        ``linspace(0, t_end, n_samples + 1)`` (NaN where Exudyn stored none,
        e.g. after a failure).

    Returns
    -------
    dict
        ``outputs``, ``wall_s`` (``SolveDynamic``), ``ok``, ``message``, ``steps``;
        ``ok`` is False with ``message`` "not installed" when Exudyn is missing.
    """
    if not status()["exudyn"]["installed"]:
        return {"outputs": None, "wall_s": None, "ok": False, "message": "not installed", "steps": None}
    fn = _EXUDYN[scene]
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            outs, wall, ok, msg = fn(float(t_end), int(n_steps), float(rho_inf), int(n_samples))
    except Exception as exc:
        return {"outputs": None, "wall_s": None, "ok": False,
                "message": f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}",
                "steps": int(n_steps)}
    return {"outputs": outs, "wall_s": wall, "ok": ok, "message": msg, "steps": int(n_steps)}

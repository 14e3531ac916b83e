"""Chain of n twisted bricks on revolute joints under gravity (Exudyn's perf3DRigidBodies), spatial.

A benchmark for scale in 3-D: n :class:`~femb.elements.spatial_bodies.SpatialRigidBody`
bricks ``brick0 … brick{n-1}`` (default n = 400), each hinged to the previous one
(``brick0`` to the ground) by a :class:`~femb.elements.spatial_joints.RevoluteJoint`
``J0 … J{n-1}``, falling from rest under gravity. 6n velocities, 5n constraint
rows, n degrees of freedom.

Model (the data of Exudyn's performance test ``perf3DRigidBodies``, file
``main/pythonDev/TestModels/perf3DRigidBodies.py`` of github.com/jgerstmayr/EXUDYN,
last changed in commit 7de98d35a1c3d23501f9b2a9be3996d5950e45c5, read at
e44aca1b4fe3e5f4d820ff407fb3fd30b6581c1c):

* brick i: a cuboid L × d × d = 0.4 × 0.1 × 0.1 m, density 1000 kg/m³
  (m = 4 kg, J = m/12 diag(2d², L² + d², L² + d²) about its centre, body axes),
  its long side along its body x axis;
* orientations A_0 = I, A_{i+1} = A_i R_x(δ) R_z(2δ) with δ = 0.01π (the twist
  between consecutive bricks; R_x, R_z the elementary rotations);
* the joint J_i at the point P_i with P_0 = 0 and P_{i+1} = P_i + A_i (L, 0, 0),
  the centre of brick i at P_i + A_i (L/2, 0, 0); the axis of J_i is A_i e_z
  (space axes), i.e. the body z axis of brick i;
* gravity g = (0, 0, +9.81) m/s² (as in the Exudyn file), start at rest;
* the performance test integrates t ∈ [0, 1] s with generalized-α, h = 1e-3 s,
  ρ∞ = 0.8 (:data:`DEFAULTS`).

Exudyn's performance log of this test (:data:`EXUDYN_LOG`) gives the last
brick's displacement and rotation angles at t = 1 s; femb's run with the
defaults reproduces them to 8 digits (``tests/test_rigid_chain_3d.py``).

Outputs (:func:`outputs`): ``x{k}_x, x{k}_y, x{k}_z`` (m, centre of brick k) for
the first, middle and last brick (k = 0, n // 2, n − 1; ``femb list`` shows the
names of the default n = 400), ``F0_x, F0_y, F0_z`` (N, the force of the ground
joint J0 on brick 0, space axes: its multipliers λ[0:3]), ``energy`` (J, kinetic + gravitational; it is
conserved by the model, the scheme dissipates a little at ρ∞ < 1) and
``phi_max`` (m, the largest |Φ| over all joint rows at each stored step).

The same model in Exudyn (its items, index-3 generalized-α) is :func:`exudyn_solve`;
:func:`main` (``python -m femb.benchmarks.scenes.spatial.rigid_chain_3d --runs 5``) measures
both codes' ms per step in one process and their agreement.

Registered as ``rigid_chain_3d``.
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

from femb import Mechanism
from femb.elements.spatial_bodies import SpatialRigidBody
from femb.elements.spatial_forces import SpatialGravity
from femb.elements.spatial_joints import RevoluteJoint

#: The data of Exudyn's perf3DRigidBodies (see the module docstring).
PARAMS = dict(n=400, length=0.4, width=0.1, density=1000.0, twist=0.01 * math.pi, g=(0.0, 0.0, 9.81))

PARAMETERS = {"n": ("number of bricks", "-"),
              "length": ("brick length L (body x)", "m"),
              "width": ("brick width and height d (body y, z)", "m"),
              "density": ("density of the bricks", "kg/m^3"),
              "twist": ("angle δ: A_{i+1} = A_i R_x(δ) R_z(2δ)", "rad"),
              "g": ("gravity", "m/s^2")}

#: Exudyn's perf3DRigidBodies: t ∈ [0, 1] s, h = 1e-3 s, ρ∞ = 0.8.
DEFAULTS = {"t_end": 1.0, "h": 1e-3, "rho_inf": 0.8}


#: Exudyn's own result of perf3DRigidBodies (n = 400, t = 1 s, h = 1e-3 s, ρ∞ = 0.8, modified Newton
#: with Exudyn's default tolerances, Exudyn 1.10.0): the last brick's displacement u (m) and the
#: Tait–Bryan xyz angles of its rotation (rad), and the test's result Σ|u| + Σ|angles|, from
#: ``main/pythonDev/PerformanceLogs/performanceLog_V1.10.0_64bitP3.12linux.txt`` of
#: github.com/jgerstmayr/EXUDYN (last changed in commit 490e7a9fc9972f13037ed08f006374a889caf2ac).
EXUDYN_LOG = {"u": (-0.25907236, -0.43030816, 1.09168392), "angles": (0.40213238, 0.8653121, 2.25943439),
              "result": 5.307943301445478}


def rot_xyz(R):
    """Tait–Bryan angles (φ0, φ1, φ2) with R = R_x(φ0) R_y(φ1) R_z(φ2) (Exudyn's ``Rotation`` output)."""
    R = np.asarray(R, dtype=float)
    return np.array([math.atan2(-R[1, 2], R[2, 2]), math.asin(max(-1.0, min(1.0, R[0, 2]))),
                     math.atan2(-R[0, 1], R[0, 0])])


def last_brick_measures(result):
    """The measures of Exudyn's perf3DRigidBodies at the last stored step: displacement u of the
    last brick's centre since t0 (m), the xyz angles of its rotation (rad) and Σ|u| + Σ|angles|."""
    from femb.benchmarks.scenes.spatial.spatial_common import rotation_matrices

    n = sum(1 for k in result.model.bodies if k.startswith("brick"))
    x = result.body(f"brick{n - 1}")
    u = x[-1, :3] - x[0, :3]
    ang = rot_xyz(rotation_matrices(x[-1:])[0])
    return {"u": u, "angles": ang, "result": float(np.abs(u).sum() + np.abs(ang).sum())}


def sample_bricks(n):
    """Indices of the bricks whose centres are outputs: first, middle, last (distinct, sorted)."""
    return sorted({0, n // 2, n - 1})


OUTPUTS = {**{f"x{k}_{a}": (f"centre of brick {k}, space {a} (k = 0, n // 2, n - 1)", "m")
              for k in sample_bricks(PARAMS["n"]) for a in "xyz"},
           **{f"F0_{a}": (f"force of J0 (ground) on brick 0, space {a}", "N") for a in "xyz"},
           "energy": ("kinetic + gravitational energy", "J"),
           "phi_max": ("largest |Φ| over all joint rows", "m")}

#: h-convergence study (``femb bench convergence rigid_chain_3d``): the first 0.2 s, centres of the
#: sampled bricks and the ground joint's force, against femb's own finest run (no independent reference).
#: Steps from 8e-3 s down to 1e-3 s only: below h ≈ 1e-4 s the index-3 multipliers of this heavy,
#: 60 m long chain are dominated by round-off (measured at t = 0.1 s, ρ∞ = 0.7: F0 moves by 0.3 N
#: from h = 1.25e-4 to 6.25e-5 s and 1.2 N more to 3.1e-5 s, while the index-2 form converges
#: at order 2 to 5e-5 N there), so a finer reference run would measure round-off, not the steps.
#: Measured (``femb bench convergence rigid_chain_3d``, reference h = 1.25e-4 s): positions at
#: order 2.01 (3.3e-8 … 5.0e-10 relative); the forces' relative errors, 6.7e-5 at 8e-3 s, are at
#: the reference's round-off floor (2e-6 … 6e-6) from 4e-3 s on, so their fitted order means nothing.
CONVERGENCE = {"t_end": 0.2, "h": [8e-3, 4e-3, 2e-3, 1e-3],
               "q": [f"x{k}_{a}" for k in sample_bricks(PARAMS["n"]) for a in "xyz"],
               "lambda": [f"F0_{a}" for a in "xyz"]}


def _rx(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def _rz(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def chain_geometry(n=PARAMS["n"], length=PARAMS["length"], twist=PARAMS["twist"]):
    """Initial configuration of the chain.

    Parameters
    ----------
    n : int
        Number of bricks.
    length : float
        Brick length L (m).
    twist : float
        δ (rad): A_{i+1} = A_i R_x(δ) R_z(2δ).

    Returns
    -------
    R : ndarray, shape (n, 3, 3)
        Rotation of each brick (body to space).
    centre : ndarray, shape (n, 3)
        Centre of each brick (m).
    joint : ndarray, shape (n, 3)
        Point of joint J_i (between brick i − 1, or the ground, and brick i).
    axis : ndarray, shape (n, 3)
        Axis of J_i in space (the body z axis of brick i).
    """
    n = int(n)
    step = _rx(twist) @ _rz(2.0 * twist)
    R = np.empty((n, 3, 3))
    centre, joint, axis = np.empty((n, 3)), np.empty((n, 3)), np.empty((n, 3))
    A, P = np.eye(3), np.zeros(3)
    for i in range(n):
        R[i], joint[i], axis[i] = A, P, A[:, 2]
        centre[i] = P + A[:, 0] * (0.5 * length)
        P = P + A[:, 0] * length
        A = A @ step
    return R, centre, joint, axis


def brick_inertia(length=PARAMS["length"], width=PARAMS["width"], density=PARAMS["density"]):
    """Mass (kg) and principal inertia about the centre (kg m², body axes) of one L × d × d brick."""
    m = density * length * width * width
    return m, (m / 12.0 * 2.0 * width ** 2, m / 12.0 * (length ** 2 + width ** 2),
               m / 12.0 * (length ** 2 + width ** 2))


def build(n=PARAMS["n"], length=PARAMS["length"], width=PARAMS["width"], density=PARAMS["density"],
          twist=PARAMS["twist"], g=PARAMS["g"]):
    """The chain as a :class:`~femb.Mechanism` (see the module docstring).

    Parameters
    ----------
    n : int
        Number of bricks (≥ 1).
    length, width : float
        Brick length L and width/height d (m).
    density : float
        kg/m³.
    twist : float
        δ (rad), the twist between consecutive bricks.
    g : (3,)
        Gravity (m/s²).

    Returns
    -------
    Mechanism
        Bodies ``brick0 …``, joints ``J0 …`` and ``gravity``.
    """
    n = int(n)
    if n < 1:
        raise ValueError(f"rigid_chain_3d: n must be >= 1, got {n}")
    m, J = brick_inertia(length, width, density)
    R, centre, joint, axis = chain_geometry(n, length, twist)
    mech = Mechanism(f"rigid_chain_3d_{n}")
    box = {"type": "box", "size": (0.96 * length, width, width)}
    prev = "ground"
    for i in range(n):
        b = mech.add(SpatialRigidBody(f"brick{i}", m, J, position=centre[i], rotation=R[i], shape=box))
        mech.add(RevoluteJoint(f"J{i}", prev, b, at=joint[i], axis=axis[i]))
        prev = b
    mech.add(SpatialGravity(g))
    return mech


def outputs(result):
    """Named outputs over the stored steps (see the module docstring), each (nt,)."""
    from femb.system.assembly import constraint_vector

    model = result.model
    names = sorted((k for k in model.bodies if k.startswith("brick")), key=lambda s: int(s[5:]))
    n = len(names)
    g = np.asarray(model.gravity if model.gravity is not None else PARAMS["g"], dtype=float)
    out = {}
    for k in sample_bricks(n):
        x = result.body(f"brick{k}")
        for i, a in enumerate("xyz"):
            out[f"x{k}_{a}"] = x[:, i]
    lam = result.reaction("J0")
    for i, a in enumerate("xyz"):
        out[f"F0_{a}"] = lam[:, i]
    E = np.zeros(result.t.size)
    for name in names:
        body = model.bodies[name]
        x, v = result.body(name), result.body(name, "qd")
        W = v[:, 3:6]
        E += 0.5 * body.m * np.sum(v[:, :3] ** 2, axis=1) + 0.5 * np.einsum("ni,ij,nj->n", W, body.J, W) \
            - body.m * x[:, :3] @ g
    out["energy"] = E
    out["phi_max"] = np.array([np.max(np.abs(constraint_vector(model, t, q))) for t, q in
                               zip(result.t, result.q)])
    return out


# --------------------------------------------------------------------------
# the same model in Exudyn
# --------------------------------------------------------------------------
#: Newton tolerances given to Exudyn in the comparison (as :data:`femb.benchmarks.peers.EXUDYN_NEWTON`).
EXUDYN_NEWTON = {"relativeTolerance": 1e-10, "absoluteTolerance": 1e-12}


def exudyn_solve(n=PARAMS["n"], t_end=1.0, h=1e-3, rho_inf=0.8, record=(), record_every=None,
                 threads=1, modified_newton=True, newton=EXUDYN_NEWTON, node_type="EulerParameters"):
    """Integrate the chain with Exudyn's index-3 generalized-α (same data as :func:`build`).

    The model is built with Exudyn's own items as in perf3DRigidBodies.py: bodies
    by ``CreateRigidBody`` (Euler-parameter nodes, ``InertiaCuboid``, gravity per
    body), joints by ``CreateRevoluteJoint`` at the same points and axes (space
    axes). Scheme: generalized-α, ``spectralRadius = rho_inf``, index 3
    (``useIndex2Constraints = False``, ``useNewmark = False``),
    ``computeInitialAccelerations = True``, fixed steps (``adaptiveStep =
    False``), sparse LU (``EigenSparse``), modified Newton (as in the Exudyn
    file) with the given tolerances. What differs from femb and cannot be
    matched: Exudyn's Newton test (residual norm; femb: weighted correction
    with a contraction-rate test) and its rotation parameters (Euler
    parameters with their norm constraint; femb: quaternions updated on the
    Lie group).

    Parameters
    ----------
    n : int
    t_end, h, rho_inf : float
    record : sequence of int
        Bricks whose centre positions are recorded (sensors stored in memory).
    record_every : float, optional
        Sensor period (s); default h.
    threads : int
        ``parallel.numberOfThreads`` (1: single-threaded, as femb).
    modified_newton : bool
    newton : dict or None
        ``relativeTolerance``, ``absoluteTolerance`` of Exudyn's Newton; None
        keeps Exudyn's defaults (as perf3DRigidBodies.py does).
    node_type : str
        Exudyn's rotation parameters of the body nodes (``exu.NodeType.Rotation<node_type>``);
        perf3DRigidBodies uses ``"EulerParameters"`` (CreateRigidBody's default).

    Returns
    -------
    dict
        ``wall_s`` (``SolveDynamic``, model construction and ``Assemble``
        excluded), ``ok``, ``message``, ``steps``, ``newton`` (Exudyn's Newton
        iteration count when available), ``positions`` (brick → (ns, 4) rows
        t, x, y, z).
    """
    import exudyn as exu
    from exudyn import itemInterface as ii
    from exudyn.utilities import InertiaCuboid

    n = int(n)
    R, centre, joint, axis = chain_geometry(n, PARAMS["length"], PARAMS["twist"])
    SC = exu.SystemContainer()
    mbs = SC.AddSystem()
    ground = mbs.AddObject(ii.ObjectGround(referencePosition=[0.0, 0.0, 0.0]))
    inertia = InertiaCuboid(density=PARAMS["density"], sideLengths=[PARAMS["length"], PARAMS["width"],
                                                                     PARAMS["width"]])
    prev, bodies = ground, []
    for i in range(n):
        b = mbs.CreateRigidBody(inertia=inertia, referencePosition=list(centre[i]),
                                referenceRotationMatrix=R[i], gravity=list(PARAMS["g"]), show=False,
                                nodeType=getattr(exu.NodeType, "Rotation" + node_type))
        mbs.CreateRevoluteJoint(itemNumbers=[prev, b], position=list(joint[i]), axis=list(axis[i]),
                                useGlobalFrame=True, show=False)
        bodies.append(b)
        prev = b
    sensors = {k: mbs.AddSensor(ii.SensorBody(bodyNumber=bodies[k], storeInternal=True, writeToFile=False,
                                              outputVariableType=exu.OutputVariableType.Position))
               for k in record}
    mbs.Assemble()
    steps = int(round(t_end / h))
    s = exu.SimulationSettings()
    warnings.filterwarnings("ignore", category=DeprecationWarning, module=__name__)  # Exudyn 1.13's renames
    ti = s.timeIntegration
    ti.numberOfSteps = steps
    ti.endTime = float(t_end)
    ti.generalizedAlpha.spectralRadius = float(rho_inf)
    ti.generalizedAlpha.useIndex2Constraints = False
    ti.generalizedAlpha.useNewmark = False
    ti.generalizedAlpha.computeInitialAccelerations = True
    ti.newton.useModifiedNewton = bool(modified_newton)
    if newton is not None:
        ti.newton.relativeTolerance = float(newton["relativeTolerance"])
        ti.newton.absoluteTolerance = float(newton["absoluteTolerance"])
    ti.adaptiveStep = False
    ti.verboseMode = 0
    s.linearSolverType = exu.LinearSolverType.EigenSparse
    s.parallel.numberOfThreads = int(threads)
    s.solutionSettings.writeSolutionToFile = False
    s.solutionSettings.sensorsWritePeriod = float(h if record_every is None else record_every)
    s.displayComputationTime = False
    s.displayStatistics = False
    buf = io.StringIO()
    ok, message = True, ""
    t0 = time.perf_counter()
    try:
        with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(buf):
            res = mbs.SolveDynamic(s)
        if res is False:
            ok, message = False, "SolveDynamic returned False"
    except Exception as exc:   # a failing peer is a measurement
        ok, message = False, f"{type(exc).__name__}: {str(exc).splitlines()[0] if str(exc) else ''}"
    wall = time.perf_counter() - t0
    newton_its = None
    with contextlib.suppress(Exception):
        newton_its = int(mbs.sys["dynamicSolver"].it.newtonStepsCount)
    positions = {k: np.asarray(mbs.GetSensorStoredData(sid)) for k, sid in sensors.items()}
    return {"wall_s": wall, "ok": ok, "message": message, "steps": steps, "newton": newton_its,
            "positions": positions}


def exudyn_installed():
    """(installed, version) of Exudyn."""
    from femb.benchmarks import peers

    st = peers.status()["exudyn"]
    return st["installed"], st["version"]


# --------------------------------------------------------------------------
# comparison and timing
# --------------------------------------------------------------------------
def femb_positions(result, bricks, times):
    """Centres (len(times), 3) of ``bricks`` in a femb result at the stored times nearest ``times``."""
    idx = [int(np.argmin(np.abs(result.t - t))) for t in times]
    return {k: result.body(f"brick{k}")[idx, :3] for k in bricks}


def compare(n=PARAMS["n"], t_end=1.0, h=1e-3, rho_inf=0.8, times=None, bricks=None, log=print):
    """femb against Exudyn: positions of a few bricks at a few times, same model, same h and ρ∞.

    Both codes are second-order approximations of one model at the same h, so
    they should differ by at most about the discretization error, estimated
    here by femb at h against h/2. Measured (n = 400, h = 1e-3 s, ρ∞ = 0.8):
    they differ far less (≤ 4.7e-10 m at t = 1 s against up to 4.1e-7 m between
    h and h/2): both apply the same generalized-α coefficients to the same
    equations, and only the small part of the error that depends on the
    rotation parameters differs (Exudyn with Euler parameters, Tait–Bryan
    angles or rotation vectors differs among itself by the same ≤ 1e-8 m at
    t = 1 s on n = 5).

    Returns
    -------
    dict
        ``times``, ``bricks``, ``diff`` (brick → (nt,) |x_femb − x_Exudyn| in m),
        ``max_diff`` (m), ``femb`` and ``exudyn`` positions, ``h_half`` (the
        same femb difference between h and h/2, an estimate of femb's own
        discretization error at h), or ``error`` when Exudyn is missing or fails.
    """
    import femb

    bricks = sample_bricks(n) if bricks is None else list(bricks)
    times = np.array([0.1, 0.25, 0.5, 1.0]) if times is None else np.asarray(times, dtype=float)
    times = times[times <= t_end + 1e-12]
    installed, version = exudyn_installed()
    if not installed:
        return {"error": "Exudyn not installed"}
    model = build(n=n).compile()
    r1 = femb.simulate(model, t_end, h, rho_inf=rho_inf)
    r2 = femb.simulate(model, t_end, h / 2, rho_inf=rho_inf)
    ex = exudyn_solve(n, t_end, h, rho_inf, record=bricks)
    if not ex["ok"]:
        return {"error": f"Exudyn failed: {ex['message']}"}
    f1, f2 = femb_positions(r1, bricks, times), femb_positions(r2, bricks, times)
    xe, diff, dh = {}, {}, {}
    for k in bricks:
        arr = ex["positions"][k]
        rows = [int(np.argmin(np.abs(arr[:, 0] - t))) for t in times]
        xe[k] = arr[rows, 1:4]
        diff[k] = np.linalg.norm(f1[k] - xe[k], axis=1)
        dh[k] = np.linalg.norm(f1[k] - f2[k], axis=1)
    out = {"times": times, "bricks": bricks, "diff": diff, "h_half": dh, "femb": f1, "exudyn": xe,
           "max_diff": max(float(d.max()) for d in diff.values()),
           "max_h_half": max(float(d.max()) for d in dh.values()), "exudyn_version": version}
    log(f"rigid_chain_3d n = {n}, h = {h:g} s, rho_inf = {rho_inf}: |x_femb - x_Exudyn| [m] "
        f"(and femb h against h/2)")
    for k in bricks:
        log(f"  brick {k:4d}: " + ", ".join(f"t={t:g}: {d:.2e} ({e:.2e})"
                                            for t, d, e in zip(times, diff[k], dh[k])))
    return out


#: Exudyn's Newton settings timed by :func:`measure`: the suite's peer tolerances (as for Andrews'
#: headline) and perf3DRigidBodies' own (modified Newton, Exudyn's default tolerances).
EXUDYN_SETTINGS = {"tight": EXUDYN_NEWTON, "default": None}


def measure(n=PARAMS["n"], t_end=None, h=1e-3, rho_inf=0.8, runs=5, exudyn=True, threads=1, log=print):
    """ms per step of femb and of Exudyn on the chain, in this process (median of warm runs).

    femb: ``femb.simulate(model, t_end, h, rho_inf, store=False)`` (default
    Newton options), timed with ``time.perf_counter`` and divided by its steps.
    Exudyn: :func:`exudyn_solve` (``SolveDynamic`` timed, model construction and
    ``Assemble`` excluded) with modified Newton, in both settings of
    :data:`EXUDYN_SETTINGS`. Each code runs once untimed (compilation, first
    call), then the codes are timed in turn ``runs`` times (interleaved, so
    that load from other processes on a shared machine falls on both).

    Parameters
    ----------
    n : int
    t_end : float, optional
        Default: Exudyn's 1 s.
    h, rho_inf : float
    runs : int
        Timed runs per code (≥ 3 for a meaningful median).
    exudyn : bool
        Time Exudyn too (when installed).
    threads : int
        Exudyn's ``parallel.numberOfThreads`` (femb runs on one thread).

    Returns
    -------
    dict
        ``femb_ms``, ``femb_runs``, ``femb_newton`` (iterations per step),
        ``femb_loop_ms`` (the time loop alone per step, ``Result.wall_time``)
        and ``femb_init_ms`` (consistent initial values per run, included in
        ``femb_ms``);
        ``exudyn`` (setting → {``ms``, ``runs``, ``newton`` per step, ``ratio``
        femb / Exudyn}); ``exudyn_ms`` and ``ratio`` of the ``"tight"``
        setting (the headline figure); ``steps``, ``n``, ``h``, ``t_end``,
        ``exudyn_version``, ``message``.
    """
    import femb

    t_end = DEFAULTS["t_end"] if t_end is None else float(t_end)
    model = build(n=n).compile()
    installed, version = exudyn_installed()
    settings = dict(EXUDYN_SETTINGS) if (exudyn and installed) else {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        femb.simulate(model, t_end, h, rho_inf=rho_inf, store=False)     # compile / warm-up
    for nw in settings.values():
        exudyn_solve(n, t_end, h, rho_inf, threads=threads, newton=nw)  # warm-up
    fr, loop, er, its, res = [], [], {k: [] for k in settings}, {}, None
    message = "" if installed else "Exudyn not installed"
    for _ in range(runs):
        t0 = time.perf_counter()
        res = femb.simulate(model, t_end, h, rho_inf=rho_inf, store=False)
        fr.append(1e3 * (time.perf_counter() - t0) / res.steps)
        loop.append((1e3 * res.wall_time / res.steps, 1e3 * res.init_time))
        for key, nw in settings.items():
            ex = exudyn_solve(n, t_end, h, rho_inf, threads=threads, newton=nw)
            if not ex["ok"]:
                message = f"Exudyn ({key}) failed: {ex['message']}"
                continue
            er[key].append(1e3 * ex["wall_s"] / ex["steps"])
            its[key] = None if ex["newton"] is None else ex["newton"] / ex["steps"]
    out = {"n": int(n), "h": h, "t_end": t_end, "steps": res.steps, "rho_inf": rho_inf, "runs": int(runs),
           "femb_ms": statistics.median(fr), "femb_runs": fr,
           "femb_newton": float(np.mean(res.newton_iterations)), "exudyn": {},
           "femb_loop_ms": statistics.median(x for x, _ in loop), "femb_init_ms": statistics.median(y for _, y in loop),
           "exudyn_ms": None, "ratio": None, "exudyn_version": version, "exudyn_threads": int(threads),
           "message": message}
    log(f"femb: {out['femb_ms']:.3f} ms/step (runs {', '.join(f'{x:.3f}' for x in fr)}), "
        f"{out['femb_newton']:.2f} Newton iterations/step; of which time loop {out['femb_loop_ms']:.3f} ms/step, "
        f"consistent initial values {out['femb_init_ms']:.1f} ms per run")
    for key, runs_ in er.items():
        if not runs_:
            continue
        ms = statistics.median(runs_)
        out["exudyn"][key] = {"ms": ms, "runs": runs_, "newton": its.get(key), "ratio": out["femb_ms"] / ms,
                              "newton_tolerances": "Exudyn defaults" if settings[key] is None else
                              f"relative {settings[key]['relativeTolerance']:g}, "
                              f"absolute {settings[key]['absoluteTolerance']:g}"}
        nit = its.get(key)
        log(f"Exudyn {version} ({key}: modified Newton, {out['exudyn'][key]['newton_tolerances']}, "
            f"{threads} thread(s)): {ms:.3f} ms/step (runs {', '.join(f'{x:.3f}' for x in runs_)})"
            + (f", {nit:.2f} Newton iterations/step" if nit is not None else "")
            + f"; ratio femb / Exudyn {out['femb_ms'] / ms:.3f}")
    if "tight" in out["exudyn"]:
        out["exudyn_ms"] = out["exudyn"]["tight"]["ms"]
        out["ratio"] = out["exudyn"]["tight"]["ratio"]
    if message:
        log(message)
    return out


def main(argv=None):
    """``python -m femb.benchmarks.scenes.spatial.rigid_chain_3d [--runs 5] [--n 400] [--t-end 1] [--compare]``."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5, help="timed runs per code (median)")
    ap.add_argument("--n", type=int, default=PARAMS["n"], help="number of bricks")
    ap.add_argument("--t-end", type=float, default=DEFAULTS["t_end"])
    ap.add_argument("--h", type=float, default=DEFAULTS["h"])
    ap.add_argument("--rho-inf", type=float, default=DEFAULTS["rho_inf"])
    ap.add_argument("--threads", type=int, default=1, help="Exudyn's numberOfThreads")
    ap.add_argument("--compare", action="store_true",
                    help="also compare positions of the first, middle and last brick with Exudyn")
    a = ap.parse_args(argv)
    print(f"rigid_chain_3d: n = {a.n} bricks, h = {a.h:g} s, t_end = {a.t_end:g} s, rho_inf = {a.rho_inf}; "
          f"median of {a.runs} warm runs (time.perf_counter)")
    if a.compare:
        compare(a.n, a.t_end, a.h, a.rho_inf)
    measure(a.n, a.t_end, a.h, a.rho_inf, runs=a.runs, threads=a.threads)


if __name__ == "__main__":
    main()

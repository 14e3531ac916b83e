"""Spatial four-bar (RSUR) with a flexible SE(3)-beam coupler, driven crank, gravity out of plane.

Ground pivots O = (0, 0, 0) and D = (0.8, 0, 0) m; crank OB = 0.2 m (B = (0, 0.2, 0) at t0)
on a :class:`RevoluteJoint` about z, rocker DC = 0.6 m on a revolute about z; coupler
BC = 0.7 m attached to the crank by a :class:`SphericalJoint` at B and to the rocker by a
:class:`UniversalJoint` at C (pins: z on the rocker, e₁ × z on the coupler, e₁ = the
coupler axis), which locks the coupler's spin: R–S–U–R has one degree of freedom
(Grübler: 18 − 5 − 3 − 4 − 5 = 1), taken by the driver. The crank angle is prescribed
by a :class:`DrivenRevoluteAngle`: the rate rises from 0 to ω_s = 2π rad/s over
T_s = 0.5 s along :func:`smooth_ramp` (θ'' ∝ τ⁴(1 − τ)⁴, τ = t/T_s: θ'' and its first
three derivatives vanish at both ends of the ramp), so that the mechanism starts at rest
and the static equilibrium it starts from is consistent with the driven motion to high
order. Gravity (0, 0, −9.81) m/s² acts normal to the plane of the linkage: the coupler
bends out of plane and twists, and every joint carries out-of-plane forces and bending
moments.

Why the ramp matters. The coupler's first axial mode (the stiff coupler on the rocker's
inertia, ω₁ ≈ 3706 rad/s, T₁ ≈ 1.70 ms) is undamped. A ramp whose n-th derivative of
the quasi-static axial force jumps at t = 0 or t = T_s sets it ringing with an amplitude
of about that jump / ω₁ⁿ, for ever. With ``ramp="cosine"`` (the spin-up's profile,
θ'' ∝ 1 − cos 2πτ: the fourth derivative of θ jumps) the in-plane reactions ring with
1.6e-5 N (R_O_x), 1.0e-5 N (R_B_y), 3.8e-6 N m (T_drive), about 4e-6 of their largest
values. Fixed steps damp this ringing (h ω₁ ≳ 2) or lag its phase, by more than a radian
over the run's 350 periods until h ω₁ ≈ 0.06 (h ≈ 16 µs;
:func:`femb.solve.diagnostics.free_oscillation_error`), so the reaction errors stay on a floor
near 1e-5 instead of falling as h² (docs/beams.md, "Convergence with unresolved axial
modes"; :func:`ringing`). The default ramp's θ'' starts as τ⁴: the same
estimate with the fourth derivative, 24 a₄/ω₁⁴ (a₄ the t⁴ coefficient of the reaction),
gives about 2e-9 N, and the reactions converge at order 2 (:func:`time_convergence`). So
does the cosine ramp once material damping damps the axial mode (``damping=1e-4``:
ζ₁ = 0.19).

Coupler: aluminium rod, d = 10 mm, E = 70 GPa, G = 26 GPa, ρ = 2700 kg/m³
(:meth:`SpatialSection.circle`; first pinned–pinned bending frequency ≈ 41 Hz),
meshed with :class:`SpatialBeam` elements. Crank and rocker: rigid steel rods
(0.5 kg, 1.5 kg, radius 10 mm).

``rigid=True`` builds the same mechanism with a :class:`SpatialRigidBody` coupler of the
beam's mass and rigid-body inertia (m = ρA L; about its centre: ρJ₁₁L axially,
mL²/12 + ρJ₂₂L transversely; the beam's consistent translational mass and lumped rotary
inertia reproduce these exactly in a rigid motion), the limit of a very stiff beam
(``stiffness`` ≫ 1 scales E and G).

References
----------
The mechanism is femb's own test case (no published data); the R–S–U–R loop follows
J. E. Shigley, J. J. Uicker, Theory of Machines and Mechanisms, McGraw-Hill, 1980, Ch. 11
(spatial linkages, Kutzbach count).
"""
from __future__ import annotations

import argparse
import math

import numpy as np

from femb import Mechanism
from femb.base.functions import TimeFunction
from femb.elements.spatial_beam import SpatialSection, spatial_beam
from femb.elements.spatial_bodies import SpatialRigidBody
from femb.elements.spatial_forces import SpatialGravity
from femb.elements.spatial_joints import DrivenRevoluteAngle, RevoluteJoint, SphericalJoint, UniversalJoint

from femb.benchmarks.scenes.beams.spin_up import spin_profile

DATA = dict(O=(0.0, 0.0, 0.0), D=(0.8, 0.0, 0.0), crank=0.2, coupler=0.7, rocker=0.6, m_crank=0.5,
            m_rocker=1.5, r_link=0.01, E=7.0e10, G=2.6e10, d=0.01, rho=2700.0, omega_s=2.0 * math.pi,
            T_s=0.5, g=(0.0, 0.0, -9.81))

DEFAULTS = {"t_end": 1.0, "h": 1e-3, "rho_inf": 0.8}

PARAMETERS = {
    "n_elements": ("coupler beam elements", "-"),
    "stiffness": ("factor on the coupler's E and G (1: aluminium; large: the rigid limit)", "-"),
    "rigid": ("rigid coupler (SpatialRigidBody) instead of the beam", "-"),
    "damping": ("stiffness-proportional material damping beta of the coupler", "s"),
    "ramp": ("crank rate ramp: 'smooth' (smooth_ramp, default), 'cosine' (spin_up's profile) or 'constant' "
             "(full speed from t = 0)", "-"),
}

OUTPUTS = {
    "rocker_angle": ("rocker rotation about z from t0", "rad"),
    "mid_x": ("coupler mid-point x (beam: middle node; rigid: centre)", "m"),
    "mid_y": ("coupler mid-point y", "m"),
    "mid_z": ("coupler mid-point z (out-of-plane deflection)", "m"),
    "C_z": ("z of the coupler end at C", "m"),
    "R_O_x": ("force of the ground on the crank at O, x", "N"),
    "R_O_z": ("force of the ground on the crank at O, z", "N"),
    "R_B_y": ("force of the crank on the coupler at B, y", "N"),
    "R_B_z": ("force of the crank on the coupler at B, z", "N"),
    "R_D_z": ("force of the ground on the rocker at D, z", "N"),
    "T_drive": ("driving torque on the crank about z", "N m"),
}

CONVERGENCE = {"t_end": 0.6, "h": [1e-3, 5e-4, 2.5e-4, 1.25e-4],
               "q": ["rocker_angle", "mid_x", "mid_y", "mid_z"],
               "lambda": ["R_O_x", "R_O_z", "R_B_y", "R_B_z", "R_D_z", "T_drive"]}


#: The reference of :func:`time_convergence`: the stabilized index-2 form (no 1/h²
#: amplification of round-off in λ, which limits index-3 reactions below h ≈ 0.1 ms here)
#: with a tight Newton residual test, h = 31.25 µs.
REFERENCE = {"h": 3.125e-5, "formulation": "index2", "newton_test": "residual", "newton_rtol": 1e-13}


def smooth_ramp(omega_s=DATA["omega_s"], T_s=DATA["T_s"], k=4):
    """The crank angle θ(t): the rate rises from 0 to ω_s over T_s, then stays (a TimeFunction).

    θ'(t) = ω_s I_τ(k + 1, k + 1) (τ = t/T_s, the regularized incomplete beta function, a
    polynomial), so θ'' = (ω_s/T_s) τᵏ(1 − τ)ᵏ / B(k + 1, k + 1) and its first k − 1
    derivatives vanish at τ = 0 and τ = 1; θ(t) = ω_s t − ω_s T_s/2 for t ≥ T_s. θ and θ'
    are evaluated in the Bernstein basis (positive terms, no cancellation): index-3
    reactions amplify round-off in a driver's θ(t) by 1/h².
    """
    n = 2 * k + 1
    beta = math.factorial(k) ** 2 / math.factorial(n)
    c1 = [math.comb(n, j) for j in range(n + 1)]                                 # θ'/ω_s
    c0 = [math.comb(n + 1, i) * (i - k - 1) / (n + 1) for i in range(n + 2)]     # θ/(ω_s T_s)

    def f(t):
        if t <= 0.0:
            return 0.0
        if t >= T_s:
            return omega_s * t - 0.5 * omega_s * T_s
        x = t / T_s
        return omega_s * T_s * sum(c0[i] * x ** i * (1.0 - x) ** (n + 1 - i) for i in range(k + 2, n + 2))

    def df(t):
        if t <= 0.0:
            return 0.0
        if t >= T_s:
            return omega_s
        x = t / T_s
        return omega_s * sum(c1[j] * x ** j * (1.0 - x) ** (n - j) for j in range(k + 1, n + 1))

    def ddf(t):
        if t <= 0.0 or t >= T_s:
            return 0.0
        x = t / T_s
        return omega_s / T_s * (x * (1.0 - x)) ** k / beta

    return TimeFunction(f, df, ddf, name=f"smooth ramp (k = {k})")


def constant_speed(omega_s=DATA["omega_s"]):
    """θ(t) = ω_s t: the crank at full speed from t = 0 (a TimeFunction), as a rigid loop is
    often started; the mechanism, at rest before t0, is then set moving impulsively."""
    return TimeFunction(lambda t: omega_s * t, lambda t: omega_s, lambda t: 0.0, name="constant speed")


def crank_profile(ramp="smooth", P=DATA):
    """The driver's θ(t): ``"smooth"`` (:func:`smooth_ramp`), ``"cosine"`` (:func:`spin_profile`)
    or ``"constant"`` (:func:`constant_speed`)."""
    if ramp == "smooth":
        return smooth_ramp(P["omega_s"], P["T_s"])
    if ramp == "cosine":
        return spin_profile(P["omega_s"], P["T_s"])
    if ramp == "constant":
        return constant_speed(P["omega_s"])
    from femb.errors import ParameterError
    raise ParameterError(f"ramp must be 'smooth', 'cosine' or 'constant', got {ramp!r}")


def geometry(P=DATA):
    """Joint points O, B, C, D (3,) at t0 (the upper assembly, C with y > 0)."""
    O, D = np.array(P["O"]), np.array(P["D"])
    B = O + np.array([0.0, P["crank"], 0.0])
    # C on circles |C − B| = coupler, |C − D| = rocker in the plane z = 0
    d = np.linalg.norm(D - B)
    a = (P["coupler"] ** 2 - P["rocker"] ** 2 + d * d) / (2 * d)
    h = math.sqrt(P["coupler"] ** 2 - a * a)
    u = (D - B) / d
    n = np.array([-u[1], u[0], 0.0])
    C = B + a * u + h * n
    if C[1] < 0:
        C = B + a * u - h * n
    return O, B, C, D


def _rod(name, m, p0, p1, r):
    """A rigid rod from p0 to p1 (centre mid-way; inertia in space axes at t0, identity rotation)."""
    d = (p1 - p0) / np.linalg.norm(p1 - p0)
    L = np.linalg.norm(p1 - p0)
    P = np.eye(3) - np.outer(d, d)
    J = m * (3 * r * r + L * L) / 12.0 * P + 0.5 * m * r * r * np.outer(d, d)
    return SpatialRigidBody(name, m, J, position=0.5 * (p0 + p1))


def coupler_section(stiffness=1.0, P=DATA, damping=0.0):
    """The coupler's :meth:`SpatialSection.circle` (E, G scaled by ``stiffness``)."""
    return SpatialSection.circle(P["E"] * stiffness, P["G"] * stiffness, P["d"], density=P["rho"], damping=damping)


def build(n_elements=8, *, stiffness=1.0, rigid=False, damping=0.0, ramp="smooth"):
    """The four-bar. Bodies ``crank``, ``rocker`` and the coupler (beam ``coupler``, nodes
    ``coupler.n0`` … ``coupler.n{n}``, or the rigid body ``coupler``); joints ``O``, ``drive``,
    ``B``, ``C``, ``D``.

    The mechanism starts undeformed (``femb run``: the coupler is released under gravity);
    the studies start at rest in the static equilibrium (:func:`initial_state`). ``ramp``:
    the crank's rate ramp, :func:`crank_profile`."""
    P = DATA
    O, B, C, D = geometry(P)
    z = np.array([0.0, 0.0, 1.0])
    m = Mechanism("flexible_fourbar_3d" if not rigid else "rigid_fourbar_3d")
    crank = m.add(_rod("crank", P["m_crank"], O, B, P["r_link"]))
    rocker = m.add(_rod("rocker", P["m_rocker"], D, C, P["r_link"]))
    m.add(RevoluteJoint("O", m.ground, crank, at=O, axis=z))
    m.add(DrivenRevoluteAngle("drive", m.ground, crank, crank_profile(ramp, P), at=O, axis=z))
    m.add(RevoluteJoint("D", m.ground, rocker, at=D, axis=z))
    sec = coupler_section(stiffness, P, damping)
    e1 = (C - B) / np.linalg.norm(C - B)
    pin = np.cross(e1, z)
    if rigid:
        L = float(np.linalg.norm(C - B))
        mass = sec.rhoA * L
        J = (sec.rhoJ[0, 0] * L, mass * L * L / 12 + sec.rhoJ[1, 1] * L, mass * L * L / 12 + sec.rhoJ[2, 2] * L)
        Rc = np.column_stack((e1, np.cross(z, e1), z))
        cpl = m.add(SpatialRigidBody("coupler", mass, J, position=0.5 * (B + C), rotation=Rc))
        end_b, end_c = cpl, cpl
    else:
        b = spatial_beam(m, "coupler", sec, [B, C], int(n_elements))
        end_b, end_c = b.nodes[0], b.nodes[-1]
    m.add(SphericalJoint("B", crank, end_b, at=B))
    m.add(UniversalJoint("C", rocker, end_c, axis_a=z, axis_b=pin, at=C))
    m.add(SpatialGravity(P["g"]))
    return m


def initial_state(model):
    """The state at rest in the static equilibrium under gravity at t = 0 (a :class:`~femb.system.model.State`).

    Started from it, the mechanism has none of the vibration that releasing an undeformed
    beam under gravity excites, and its initial multipliers are those of the rigid coupler
    in the stiff limit.
    """
    from femb.analysis.static import solve_static
    return solve_static(model).state


def simulate(model, t_end, h, rho_inf=DEFAULTS["rho_inf"], **options):
    """:func:`femb.simulate` from :func:`initial_state` (``options`` passed on)."""
    import femb
    return femb.simulate(model, t_end, h, rho_inf=rho_inf, state=initial_state(model), **options)


def _mid(model):
    if "coupler" in model.node_index:
        return "coupler", "coupler"
    names = sorted((nm for nm in model.node_index if nm.startswith("coupler.n")), key=lambda s: int(s[9:]))
    return names[(len(names) - 1) // 2], names[-1]


def outputs(result):
    """Named outputs over the stored steps, each (nt,) (:data:`OUTPUTS`).

    Forces are the joints' λ[0:3] (force on body b, space axes): O and D act on the crank and
    rocker (b), B on the coupler; ``T_drive`` = −λ of ``drive`` (the driver's moment on the
    crank is −λ e_z). For the rigid coupler the mid-point is its centre and C_z the z of
    the point C on it.
    """
    m = result.model
    mid, end = _mid(m)
    xr = m.node_coordinates("rocker", result.q)
    ang = 2.0 * np.arctan2(xr[:, 6], xr[:, 3])
    xm = m.node_coordinates(mid, result.q)
    if mid == "coupler":
        _, _, C, _ = geometry()
        Cz = result.point("coupler", C)[:, 2]
    else:
        Cz = m.node_coordinates(end, result.q)[:, 2]
    RO, RB, RD = result.reaction("O"), result.reaction("B"), result.reaction("D")
    return {"rocker_angle": ang, "mid_x": xm[:, 0], "mid_y": xm[:, 1], "mid_z": xm[:, 2], "C_z": Cz,
            "R_O_x": RO[:, 0], "R_O_z": RO[:, 2], "R_B_y": RB[:, 1], "R_B_z": RB[:, 2], "R_D_z": RD[:, 2],
            "T_drive": -result.reaction("drive")[:, 0]}


def time_convergence(hs=(2e-3, 1e-3, 5e-4, 2.5e-4, 1.25e-4), t_end=0.6, rho_inf=0.8, options=None,
                     reference=None, **params):
    """Fixed-step errors of the scene's defaults (index 3, ρ∞ = 0.8) against a reference run, from
    :func:`initial_state`.

    ``reference`` (default :data:`REFERENCE`): ``h`` of the reference (each h a multiple of
    it) and its solver options. The reference is the stabilized index-2 form: index-3
    multipliers carry round-off amplified by 1/h² (here R_O_x: 3e-7, 1.3e-6, 5e-6 of its largest
    value at h = 62.5, 31.25, 15.6 µs, whatever the Newton tolerance), which a reference at a
    small h would add to every error.

    Returns
    -------
    dict
        ``h`` (k,); ``err_q`` (k,): the largest |y_h − y_ref| over the stored steps of the
        position outputs of :data:`CONVERGENCE` (m, rad); ``err_lam`` (k,): the same for the
        reactions, each relative to its largest magnitude over the run; ``order_q``,
        ``order_lam`` (k − 1,) log₂ of successive ratios; ``errors``: per output (k,)
        (reactions relative); ``h_omega``: h ω₁ with ω₁ the coupler's first axial frequency.
    """
    reference = dict(REFERENCE if reference is None else reference)
    h_ref = reference.pop("h")
    model = build(**params).compile()
    options = dict(options or {})
    ref = outputs(simulate(model, t_end, h_ref, rho_inf=rho_inf, **reference))
    names = CONVERGENCE["q"] + CONVERGENCE["lambda"]
    errors = {k: [] for k in names}
    for h in hs:
        o = outputs(simulate(model, t_end, h, rho_inf=rho_inf, **options))
        st = int(round(h / h_ref))
        for k in names:
            e = np.abs(o[k] - ref[k][::st]).max()
            errors[k].append(e / np.abs(ref[k]).max() if k in CONVERGENCE["lambda"] else e)
    errors = {k: np.array(v) for k, v in errors.items()}
    eq = np.max([errors[k] for k in CONVERGENCE["q"]], axis=0)
    el = np.max([errors[k] for k in CONVERGENCE["lambda"]], axis=0)
    return {"h": list(hs), "err_q": eq, "err_lam": el, "order_q": np.log2(eq[:-1] / eq[1:]),
            "order_lam": np.log2(el[:-1] / el[1:]), "errors": errors,
            "h_omega": np.array(hs) * axial_omega(model)}


def axial_omega(model):
    """ω₁ (rad/s): the lowest mode of the driven mechanism at its static equilibrium (t = 0)
    whose coupler motion is mostly along the coupler (axial), from :func:`femb.analysis.modal.modal_analysis`;
    NaN for the rigid coupler."""
    from femb.analysis.modal import modal_analysis
    nodes = [nm for nm in model.node_index if nm.startswith("coupler.n")]
    if not nodes:
        return math.nan
    r = modal_analysis(model, initial_state(model), n_modes=12)
    _, B, C, _ = geometry()
    e1 = (C - B) / np.linalg.norm(C - B)
    for k, w in enumerate(r.omega):
        u = np.array([r.node_mode(nm, k)[:3] for nm in nodes])
        if np.sum((u @ e1) ** 2) > 0.5 * np.sum(u * u):
            return float(w)
    return math.nan


def ringing(ramp="cosine", h=7.8125e-6, t_end=0.6, window=4e-3):
    """The axial ringing in the in-plane reactions of the exact motion, and its prediction.

    A run of the stabilized index-2 form with a small h (h ω₁ ≈ 0.03: the ringing is kept);
    the ringing is the reaction minus its running cubic fit over ``window`` (Savitzky–Golay).
    Predicted amplitude: 2 a₂/ω₁², with a₂ the t² coefficient of the reaction at the start
    (least squares over 30 ms); it holds for the cosine ramp, whose θ'' ∝ t² at t = 0.

    Returns
    -------
    dict
        ``omega`` (ω₁, rad/s); per reaction (R_O_x, R_B_y, T_drive): ``(measured amplitude over
        0.1 … 0.4 s, predicted)`` in N or N m.
    """
    from scipy.signal import savgol_filter
    model = build(ramp=ramp).compile()
    w = axial_omega(model)
    r = simulate(model, t_end, h, **{k: v for k, v in REFERENCE.items() if k != "h"})
    o, t = outputs(r), r.t
    res = {"omega": w}
    first, mid = t < 0.03, (t > 0.1) & (t < 0.4)
    for k in ("R_O_x", "R_B_y", "T_drive"):
        y = o[k]
        hp = y - savgol_filter(y, int(round(window / h)) | 1, 3)
        A = np.vstack([t[first] ** p for p in (2, 3, 4, 5)]).T
        a2 = np.linalg.lstsq(A, y[first], rcond=None)[0][0]
        res[k] = (float(np.abs(hp[mid]).max()), float(abs(2.0 * a2) / (w * w)))
    return res


def reference_noise(hs=(6.25e-5, 3.125e-5, 1.5625e-5), t_end=0.6):
    """How well small steps make a reference for the reactions (R_O_x relative to its largest value).

    Returns
    -------
    dict
        ``index3`` (k,): largest |index-3 − index-2 (:data:`REFERENCE` options)| at each h of
        ``hs`` (round-off amplified by 1/h² in the index-3 multipliers); ``index2_default``,
        ``index2_tight``: largest |y_h − y_{h/2}| of the index-2 form at the last h with the
        default Newton test and with the tight one of :data:`REFERENCE`.
    """
    model = build().compile()
    tight = {k: v for k, v in REFERENCE.items() if k != "h"}

    def rox(h, **opt):
        return outputs(simulate(model, t_end, h, **opt))["R_O_x"]

    i3 = []
    scale = None
    for h in hs:
        y2 = rox(h, **tight)
        scale = scale or np.abs(y2).max()
        i3.append(np.abs(rox(h) - y2).max() / scale)
    h = hs[-1]
    d_def = np.abs(rox(h, formulation="index2") - rox(h / 2, formulation="index2")[::2]).max() / scale
    d_tight = np.abs(rox(h, **tight) - rox(h / 2, **tight)[::2]).max() / scale
    return {"h": list(hs), "index3": np.array(i3), "index2_default": d_def, "index2_tight": d_tight}


def slider_crank(ramp="smooth", n_elements=6, damping=0.0):
    """A second mechanism for the ramp study: the IFToMM spatial slider–crank
    (:mod:`femb.benchmarks.scenes.spatial.spatial_slider_crank`: its points, crank and slider) with an
    aluminium SE(3)-beam rod (d = 8 mm, ``n_elements``), the crank driven about x by
    :func:`crank_profile` with ω_s = 4π rad/s, T_s = 0.5 s, gravity; a compiled model. In
    its first axial mode (1613 rad/s at the static equilibrium) the rod carries the 2 kg
    slider along x, at 48° to the rod."""
    from femb.benchmarks.scenes.spatial.spatial_slider_crank import PARAMS as SP, geometry as sc_geometry
    from femb.elements.spatial_joints import PrismaticJoint
    A, B, D, e0, _ = sc_geometry(SP)
    x = np.array([1.0, 0.0, 0.0])
    m = Mechanism("flexible_slider_crank_3d")
    crank = m.add(SpatialRigidBody("crank", SP["m_crank"], SP["J_crank"], position=0.5 * (A + B)))
    slider = m.add(SpatialRigidBody("slider", SP["m_slider"], SP["J_slider"], position=D))
    m.add(RevoluteJoint("O", m.ground, crank, at=A, axis=x))
    m.add(DrivenRevoluteAngle("drive", m.ground, crank, crank_profile(ramp, dict(omega_s=4 * math.pi, T_s=0.5)),
                              at=A, axis=x))
    sec = SpatialSection.circle(DATA["E"], DATA["G"], 0.008, density=DATA["rho"], damping=damping)
    b = spatial_beam(m, "rod", sec, [B, D], int(n_elements))
    pin = np.cross(e0, x)
    m.add(SphericalJoint("B", crank, b.nodes[0], at=B))
    m.add(UniversalJoint("D", slider, b.nodes[-1], axis_a=x, axis_b=pin / np.linalg.norm(pin), at=D))
    m.add(PrismaticJoint("guide", m.ground, slider, at=D, axis=x))
    m.add(SpatialGravity(SP["g"]))
    return m.compile()


def slider_crank_convergence(ramp="smooth", hs=(2e-3, 1e-3, 5e-4, 2.5e-4, 1.25e-4), t_end=0.6, rho_inf=0.8):
    """Fixed-step errors of :func:`slider_crank` from its static equilibrium, as in
    :func:`time_convergence`: slider x (m), and the largest relative error of the multipliers
    whose largest magnitude exceeds 1e-3 of the largest one.

    Returns
    -------
    dict
        ``h``, ``err_q``, ``err_lam``, ``order_q``, ``order_lam``.
    """
    model = slider_crank(ramp)
    reference = dict(REFERENCE)
    h_ref = reference.pop("h")

    def run(h, **opt):
        r = simulate(model, t_end, h, rho_inf=rho_inf, **opt)
        return model.node_coordinates("slider", r.q)[:, 0], r.lam

    xr, lr = run(h_ref, **reference)
    scale = np.abs(lr).max(axis=0)
    cols = scale > 1e-3 * scale.max()
    eq, el = [], []
    for h in hs:
        xh, lh = run(h)
        st = int(round(h / h_ref))
        eq.append(np.abs(xh - xr[::st]).max())
        el.append((np.abs(lh - lr[::st]).max(axis=0)[cols] / scale[cols]).max())
    eq, el = np.array(eq), np.array(el)
    return {"h": list(hs), "err_q": eq, "err_lam": el, "order_q": np.log2(eq[:-1] / eq[1:]),
            "order_lam": np.log2(el[:-1] / el[1:])}


def rigid_limit(stiffness=1e6, n_elements=4, t_end=1.0, h=1e-3, rho_inf=0.8):
    """Largest differences between the stiff-beam and the rigid-coupler four-bar over a run.

    Returns
    -------
    dict
        ``positions`` (m or rad: rocker angle, coupler mid-point, C_z), ``forces`` (N, N m:
        the reactions of :data:`OUTPUTS` relative to max(1, their largest magnitude)).
    """
    import femb

    of = outputs(simulate(build(n_elements, stiffness=stiffness).compile(), t_end, h, rho_inf=rho_inf))
    orr = outputs(simulate(build(rigid=True).compile(), t_end, h, rho_inf=rho_inf))
    pos = max(np.abs(of[k] - orr[k]).max() for k in ("rocker_angle", "mid_x", "mid_y", "mid_z", "C_z"))
    frc = max(np.abs(of[k] - orr[k]).max() / max(1.0, np.abs(orr[k]).max())
              for k in ("R_O_x", "R_O_z", "R_B_y", "R_B_z", "R_D_z", "T_drive"))
    return {"positions": pos, "forces": frc}


def start_figures(h=1e-3, rho_inf=0.8):
    """How the mechanism starts when its driver is at full speed from t = 0 (``ramp="constant"``).

    Returns
    -------
    dict
        ``runs``: {(h, damping): "ok" or the error's class name} from :func:`initial_state`
        over 0.1 s; ``t0``: {stiffness: (T_drive at t = 0, the rigid coupler's)} in N m;
        ``first20``: {stiffness: largest |T_drive − rigid| over the first 20 steps} in N m;
        ``released``: (at t = 0, over steps 10 … 100) the largest reaction difference of
        the stiff (× 10⁶) coupler released undeformed with the default ramp, relative as in
        :func:`rigid_limit`.
    """
    import femb

    def drive(t_end, hh, **kw):
        model = build(8, ramp="constant", **kw).compile()
        r = femb.simulate(model, t_end, hh, rho_inf=rho_inf, state=initial_state(model))
        return outputs(r)["T_drive"]

    runs = {}
    for hh, damping in ((1e-3, 0.0), (1e-3, 1e-5), (1e-3, 1e-4), (5e-4, 0.0), (2e-3, 0.0), (1e-4, 1e-5)):
        try:
            drive(0.1, hh, damping=damping)
            runs[(hh, damping)] = "ok"
        except femb.FembError as e:
            runs[(hh, damping)] = type(e).__name__
    rigid = drive(20 * h, h, rigid=True)
    t0, first = {}, {}
    for s in (1e4, 1e6):
        flex = drive(20 * h, h, stiffness=s)
        t0[s] = (float(flex[0]), float(rigid[0]))
        first[s] = float(np.abs(flex - rigid).max())
    of = outputs(femb.simulate(build(4, stiffness=1e6).compile(), 0.1, h, rho_inf=rho_inf))
    orr = outputs(femb.simulate(build(rigid=True).compile(), 0.1, h, rho_inf=rho_inf))
    d = np.max([np.abs(of[k] - orr[k]) / max(1.0, np.abs(orr[k]).max())
                for k in ("R_O_x", "R_O_z", "R_B_y", "R_B_z", "R_D_z", "T_drive")], axis=0)
    return {"runs": runs, "t0": t0, "first20": first, "released": (float(d[0]), float(d[10:].max()))}


def main(argv=None):
    import femb

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=8)
    ap.add_argument("--study", action="store_true", help="time-step orders and the rigid limit")
    ap.add_argument("--start", action="store_true", help="the start with the driver at full speed from t = 0")
    a = ap.parse_args(argv)
    if a.start:
        sf = start_figures()
        print("driver at full speed from t = 0, from the static equilibrium (rho_inf = 0.8):")
        for (hh, damping), res in sf["runs"].items():
            print(f"  h = {hh:g} s, damping {damping:g} s: {res}")
        for s, (tf, tr) in sf["t0"].items():
            print(f"  stiffness x{s:.0e}: T_drive(0) = {tf:.5f} N m (rigid coupler {tr:.5f}); first 20 steps within "
                  f"{sf['first20'][s]:.2e} N m")
        print(f"  released undeformed (x1e6, default ramp): reaction difference {sf['released'][0]:.1e} at t = 0, "
              f"{sf['released'][1]:.1e} over steps 10 ... 100")
        return
    r = simulate(build(a.n).compile(), DEFAULTS["t_end"], DEFAULTS["h"])
    o = outputs(r)
    print(f"flexible four-bar, n = {a.n}, {r.steps} steps, {r.wall_time:.2f} s")
    for k in range(0, len(r.t), max(1, len(r.t) // 10)):
        print(f"  t = {r.t[k]:.3f}  rocker {o['rocker_angle'][k]: .5f} rad  mid z {o['mid_z'][k]: .3e} m  "
              f"T_drive {o['T_drive'][k]: .4f} N m")
    if a.study:
        href = REFERENCE["h"]
        for ramp in ("smooth", "cosine"):
            c = time_convergence(ramp=ramp)
            print(f"ramp = {ramp!r}: fixed steps (index 3, rho_inf = 0.8) against index 2 at h = {href:g} s")
            print("  h (s), h*omega1, err_q (m, rad), err_lam (relative), worst reaction:")
            for i, h in enumerate(c["h"]):
                worst = max(CONVERGENCE["lambda"], key=lambda k: c["errors"][k][i])
                print(f"  {h:.4g}  {c['h_omega'][i]:6.3f}  {c['err_q'][i]:.3e}  {c['err_lam'][i]:.3e}  {worst}")
            print("  orders q", np.round(c["order_q"], 2), "lambda", np.round(c["order_lam"], 2))
        for form in ("index3", "index2"):
            c = time_convergence(rigid=True, options={"formulation": form})
            print(f"rigid coupler, {form}: err_lam", np.array2string(c["err_lam"], precision=2),
                  "orders lambda", np.round(c["order_lam"], 2), "(positions exact: err_q", f"{c['err_q'].max():.1e})")
        for ramp in ("smooth", "cosine"):
            c = slider_crank_convergence(ramp)
            print(f"spatial slider-crank with a beam rod, ramp = {ramp!r}: err slider x",
                  np.array2string(c["err_q"], precision=2), "orders", np.round(c["order_q"], 2))
            print("  err_lam", np.array2string(c["err_lam"], precision=2), "orders", np.round(c["order_lam"], 2))
        for eta in (1e-5, 1e-4):
            c = time_convergence(ramp="cosine", damping=eta)
            print(f"ramp = 'cosine', material damping {eta:g} s: err_lam", np.array2string(c["err_lam"], precision=2),
                  "orders lambda", np.round(c["order_lam"], 2))
        rn = reference_noise()
        print("R_O_x, index 3 minus index 2 at the same h (relative):",
              ", ".join(f"h = {h:g}: {e:.1e}" for h, e in zip(rn["h"], rn["index3"])))
        print(f"R_O_x, index 2, h = {rn['h'][-1]:g} minus h/2: {rn['index2_default']:.1e} (default Newton test), "
              f"{rn['index2_tight']:.1e} (newton_test='residual', newton_rtol=1e-13)")
        rg = ringing("cosine")
        print(f"axial ringing, ramp 'cosine' (omega1 = {rg['omega']:.1f} rad/s, T1 = "
              f"{2e3 * math.pi / rg['omega']:.3f} ms): measured / predicted 2 a2/omega1^2")
        for k in ("R_O_x", "R_B_y", "T_drive"):
            print(f"  {k}: {rg[k][0]:.2e} / {rg[k][1]:.2e}")
        rs = ringing("smooth")
        print("high-frequency content, ramp 'smooth' (Newton residue and round-off kept by the undamped axial "
              "modes at this h; the ramp's own ringing is about 2e-9 N): "
              + ", ".join(f"{k} {rs[k][0]:.1e}" for k in ("R_O_x", "R_B_y", "T_drive")))
        for s in (1e4, 1e6, 1e8):
            rl = rigid_limit(s)
            print(f"  stiffness x{s:.0e}: max position difference {rl['positions']:.2e}, "
                  f"force {rl['forces']:.2e}")

if __name__ == "__main__":
    main()

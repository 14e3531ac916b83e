"""Spatial rigid slider–crank (IFToMM multibody benchmark library) from femb's spatial elements.

Data (docs/spatial.md §7.2; iftomm-multibody.org/benchmark, spatial rigid
slider-crank mechanism): crank 0.08 m about the x axis through
A = (0, 0.1, 0.12), angle 0 so B = (0, 0.1, 0.2); rod 0.3 m from B to the slider
at D = (0.2, 0, 0) on the x axis. Masses 0.12 / 0.5 / 2 kg; inertias about the
centres of mass: crank diag(1e-4, 1e-4, 1e-5) (body z along the crank, centre
mid-crank), rod diag(4e-4, 4e-3, 4e-3) (body x along the rod, centre mid-rod),
slider diag(1e-4, 1e-4, 1e-4); gravity (0, 0, −9.81). Crank rate 6 rad/s about x;
consistent initial velocities: rod centre (0.12, −0.24, 0) m/s, rod
ω = (1.92, −0.96, 0.48) rad/s (space axes), slider (0.24, 0, 0) m/s.

Joints: ``crank_pivot`` revolute ground → crank (x through A); ``B`` spherical
crank → rod; ``D`` universal slider (a) → rod (b) with pins along x on the
slider and along e₀ × x on the rod (e₀ the rod axis at t0; this pin pair is the
one consistent with the published initial rod ω, see
:mod:`femb.benchmarks.references.spatial_slider_crank`); ``guide`` prismatic
ground → slider along x. 18 velocities, 17 rows, 1 degree of freedom.

Outputs (:func:`outputs`): ``theta`` (crank angle, rad, unwrapped), ``theta_d``
(rad/s), ``slider_x`` (m), ``slider_v`` (m/s), ``rod_omega_x/y/z`` (rad/s,
space axes), ``energy`` (J). Reference: the minimal-coordinate model
:mod:`femb.benchmarks.references.spatial_slider_crank`.

Registered as ``spatial_slider_crank``.
"""
from __future__ import annotations

import numpy as np

from femb import Mechanism
from femb.elements.spatial_bodies import SpatialRigidBody
from femb.elements.spatial_forces import SpatialGravity
from femb.elements.spatial_joints import PrismaticJoint, RevoluteJoint, SphericalJoint, UniversalJoint

from femb.benchmarks.scenes.spatial.spatial_common import rotation_matrices

PARAMS = dict(A=(0.0, 0.1, 0.12), l_crank=0.08, l_rod=0.3, m_crank=0.12, m_rod=0.5, m_slider=2.0,
              J_crank=(1e-4, 1e-4, 1e-5), J_rod=(4e-4, 4e-3, 4e-3), J_slider=(1e-4, 1e-4, 1e-4),
              g=(0.0, 0.0, -9.81), crank_rate=6.0)

PARAMETERS = {"crank_rate": ("initial crank rate about x", "rad/s"),
              "P": ("the data dict (points, lengths, masses, inertias, g); see PARAMS", "-")}

OUTPUTS = {"theta": ("crank angle (unwrapped)", "rad"), "theta_d": ("crank rate", "rad/s"),
           "slider_x": ("slider position", "m"), "slider_v": ("slider velocity", "m/s"),
           "rod_omega_x": ("rod angular velocity, space x", "rad/s"),
           "rod_omega_y": ("rod angular velocity, space y", "rad/s"),
           "rod_omega_z": ("rod angular velocity, space z", "rad/s"),
           "energy": ("kinetic + gravitational energy", "J")}

#: Source run of the benchmark: 5 s, h = 1e-4 s, ρ∞ = 0.9 (docs/spatial.md §7.2).
DEFAULTS = {"t_end": 5.0, "h": 1e-4, "rho_inf": 0.9}

#: Work–precision groups (the reference has no reactions).
CONVERGENCE = {"q": ["theta", "slider_x"], "v": ["theta_d", "slider_v", "rod_omega_x", "rod_omega_y", "rod_omega_z"],
               "lambda": []}


def geometry(P=PARAMS):
    """Initial points A, B, D, rod axis e₀ (B → D) and the rod's initial rotation (body x along e₀)."""
    A = np.asarray(P["A"], dtype=float)
    B = A + np.array([0.0, 0.0, P["l_crank"]])
    D = np.array([np.sqrt(P["l_rod"] ** 2 - B[1] ** 2 - B[2] ** 2), 0.0, 0.0])
    e0 = (D - B) / P["l_rod"]
    h = B - (B @ e0) * e0
    z = h / np.linalg.norm(h)
    R_rod = np.column_stack((e0, np.cross(z, e0), z))
    return A, B, D, e0, R_rod


def build(crank_rate=PARAMS["crank_rate"], P=PARAMS):
    """The spatial slider–crank as a :class:`~femb.Mechanism`.

    Parameters
    ----------
    crank_rate : float
        Initial crank angular velocity about x (rad/s); the other initial
        velocities are the consistent ones for this rate.
    P : dict
        Data (``PARAMS``).

    Returns
    -------
    Mechanism
        Bodies ``crank``, ``rod``, ``slider``; joints ``crank_pivot``, ``B``,
        ``D``, ``guide``; ``gravity``.
    """
    A, B, D, e0, R_rod = geometry(P)
    x = np.array([1.0, 0.0, 0.0])
    w_crank = crank_rate * x
    c_crank = 0.5 * (A + B)
    vB = np.cross(w_crank, B - A)
    vD = np.array([0.0, 0.0, 0.0])
    # rod: vD − vB = ω × (D − B), ω·(a × x) = 0 with a = e0 × x / |e0 × x| (universal pins): solve 3×3
    a = np.cross(e0, x)
    a /= np.linalg.norm(a)
    d = D - B
    # slider speed s' from the rod length: d·(vD − vB) = 0 with vD = (s', 0, 0)
    s_d = (d @ vB) / d[0]
    vD = np.array([s_d, 0.0, 0.0])
    Mrow = np.vstack((np.array([[0, d[2], -d[1]], [-d[2], 0, d[0]], [d[1], -d[0], 0]]),   # ω × d = −d~ω
                      np.cross(a, x)[None]))
    rhs = np.concatenate((vD - vB, [0.0]))
    w_rod = np.linalg.lstsq(Mrow, rhs, rcond=None)[0]
    mech = Mechanism("spatial_slider_crank")
    crank = SpatialRigidBody("crank", P["m_crank"], P["J_crank"], position=c_crank,
                             velocity=np.cross(w_crank, c_crank - A), omega_space=w_crank)
    rod = SpatialRigidBody("rod", P["m_rod"], P["J_rod"], position=0.5 * (B + D), rotation=R_rod,
                           velocity=0.5 * (vB + vD), omega_space=w_rod)
    slider = SpatialRigidBody("slider", P["m_slider"], P["J_slider"], position=D, velocity=vD)
    mech.add(crank, rod, slider)
    mech.add(RevoluteJoint("crank_pivot", "ground", crank, at=A, axis=x),
             SphericalJoint("B", crank, rod, at=B),
             UniversalJoint("D", slider, rod, axis_a=x, axis_b=a, at=D),
             PrismaticJoint("guide", "ground", slider, at=D, axis=x),
             SpatialGravity(P["g"]))
    return mech


def outputs(result, P=PARAMS):
    """Named outputs over the stored steps (see the module docstring), each (nt,)."""
    xc = result.body("crank")
    vc = result.body("crank", "qd")
    Rc = rotation_matrices(xc)
    theta = np.unwrap(np.arctan2(Rc[:, 2, 1], Rc[:, 1, 1]))    # R = Rx(θ)
    xs = result.body("slider")
    vs = result.body("slider", "qd")
    xr = result.body("rod")
    vr = result.body("rod", "qd")
    Rr = rotation_matrices(xr)
    w_rod = np.einsum("nij,nj->ni", Rr, vr[:, 3:6])
    out = {"theta": theta, "theta_d": vc[:, 3], "slider_x": xs[:, 0], "slider_v": vs[:, 0],
           "rod_omega_x": w_rod[:, 0], "rod_omega_y": w_rod[:, 1], "rod_omega_z": w_rod[:, 2]}
    g = np.asarray(P["g"], dtype=float)
    E = np.zeros(xc.shape[0])
    for name, m, J in (("crank", P["m_crank"], P["J_crank"]), ("rod", P["m_rod"], P["J_rod"]),
                       ("slider", P["m_slider"], P["J_slider"])):
        x = result.body(name)
        v = result.body(name, "qd")
        E += 0.5 * m * np.sum(v[:, :3] ** 2, axis=1) + 0.5 * np.sum(np.asarray(J) * v[:, 3:6] ** 2, axis=1) \
            - m * x[:, :3] @ g
    out["energy"] = E
    return out


def reference(t_eval):
    """Reference outputs at ``t_eval`` (minimal coordinate θ, DOP853, rtol = atol = 1e-12)."""
    from femb.benchmarks.references import spatial_slider_crank as ref

    t_eval = np.asarray(t_eval, dtype=float)
    _, out = ref.solve(float(t_eval.max()), t_eval=t_eval)
    return out

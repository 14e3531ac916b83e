"""Heavy top (Brüls & Cardona 2010; Brüls, Cardona & Arnold 2012) from femb's spatial elements.

One :class:`~femb.elements.spatial_bodies.SpatialRigidBody` ``top`` with its node
at the centre of mass, a :class:`~femb.elements.spatial_joints.SphericalJoint`
``support`` from the ground (a) to the top (b) at the origin (body point
(0, −1, 0)), gravity (0, 0, −9.81). Data (docs/spatial.md §7.1): m = 15 kg,
J_C = diag(0.234375, 0.46875, 0.234375) kg m², R0 = I, x0 = (0, 1, 0),
Ω0 = (0, 150, −4.61538) rad/s (body axes), ẋ0 = R0(Ω0 × X) = (4.61538, 0, 0).
6 velocities, 3 constraints.

Outputs (:func:`outputs`)
-------------------------
``x_cm, y_cm, z_cm`` (m, space), ``omega_x, omega_y, omega_z`` (rad/s, body
axes), ``lambda_x, lambda_y, lambda_z`` (N): the force of the support on the
top, space axes (the multipliers of ``support``, Φ = p_ground − p_top),
``energy`` (J) and ``L_z`` (kg m²/s, spatial angular momentum about the fixed
point). Reference: :mod:`femb.benchmarks.references.heavy_top` (quaternion ODE).

Registered as ``heavy_top`` (``femb run heavy_top``, ``femb list``, the benchmark suite).
"""
from __future__ import annotations

import numpy as np

from femb import Mechanism
from femb.elements.spatial_bodies import SpatialRigidBody
from femb.elements.spatial_forces import SpatialGravity
from femb.elements.spatial_joints import SphericalJoint

from femb.benchmarks.scenes.spatial.spatial_common import rotation_matrices

PARAMS = dict(mass=15.0, inertia=(0.234375, 0.46875, 0.234375), X=(0.0, 1.0, 0.0),
              omega0=(0.0, 150.0, -4.61538), g=(0.0, 0.0, -9.81))

PARAMETERS = {"mass": ("mass of the top", "kg"),
              "inertia": ("principal inertia about the centre of mass, body axes (3 values or 3×3)", "kg m^2"),
              "X": ("centre of mass from the fixed point, body axes", "m"),
              "omega0": ("initial angular velocity, body axes", "rad/s"),
              "g": ("gravity", "m/s^2")}

OUTPUTS = {"x_cm": ("centre of mass, space x", "m"), "y_cm": ("centre of mass, space y", "m"),
           "z_cm": ("centre of mass, space z", "m"),
           "omega_x": ("angular velocity, body x", "rad/s"), "omega_y": ("angular velocity, body y", "rad/s"),
           "omega_z": ("angular velocity, body z", "rad/s"),
           "lambda_x": ("force of the support on the top, space x", "N"),
           "lambda_y": ("force of the support on the top, space y", "N"),
           "lambda_z": ("force of the support on the top, space z", "N"),
           "energy": ("kinetic + gravitational energy", "J"),
           "L_z": ("angular momentum about the fixed point, space z", "kg m^2/s")}

#: Run settings: t ∈ [0, 2] s, ρ∞ = 0.9; h = 2⁻¹¹ s (at the protocol's coarsest step 2⁻⁸ the
#: top turns 0.6 rad per step and the support force is off by its own size; at 2⁻¹¹ by ~1 N of 500 N).
DEFAULTS = {"t_end": 2.0, "h": 2.0 ** -11, "rho_inf": 0.9}

#: The protocol of docs/spatial.md §7.1: errors at t = 1 s for h = 2⁻⁸ … 2⁻¹³, ρ∞ = 0.9.
CONVERGENCE = {"t_end": 1.0, "h": [2.0 ** -k for k in range(8, 14)], "rho_inf": 0.9,
               "q": ["x_cm", "y_cm", "z_cm"], "v": ["omega_x", "omega_y", "omega_z"],
               "lambda": ["lambda_x", "lambda_y", "lambda_z"]}


def build(mass=PARAMS["mass"], inertia=PARAMS["inertia"], X=PARAMS["X"], omega0=PARAMS["omega0"],
          g=PARAMS["g"]):
    """The heavy top as a :class:`~femb.Mechanism`.

    Parameters
    ----------
    mass : float
        Mass (kg).
    inertia : (3,) or (3, 3)
        Inertia about the centre of mass, body axes (kg m²).
    X : (3,)
        Centre of mass from the fixed point, body axes (m); R0 = I so also x0.
    omega0 : (3,)
        Initial angular velocity, body axes (rad/s).
    g : (3,)
        Gravity (m/s²).

    Returns
    -------
    Mechanism
        Body ``top``, joint ``support``, ``gravity``.
    """
    X = np.asarray(X, dtype=float)
    W = np.asarray(omega0, dtype=float)
    mech = Mechanism("heavy_top")
    disc = {"type": "cylinder", "radius": 0.25, "length": 0.1, "axis": (0.0, 1.0, 0.0)}
    top = mech.add(SpatialRigidBody("top", mass, inertia, position=X, velocity=np.cross(W, X), omega=W,
                                    points={"O": -X}, shape=disc))
    mech.add(SphericalJoint("support", "ground", top, point_b="O"),
             SpatialGravity(g))
    return mech


def outputs(result, mass=None, inertia=None, g=None):
    """Named outputs over the stored steps (see the module docstring), each (nt,).

    Mass, inertia and gravity default to the model's own (``--set`` values included).
    """
    model = getattr(result, "model", None)
    top = model.bodies["top"] if model is not None else None
    mass = (top.m if top is not None else PARAMS["mass"]) if mass is None else mass
    inertia = (top.J if top is not None else PARAMS["inertia"]) if inertia is None else inertia
    if g is None:
        g = model.gravity if model is not None and model.gravity is not None else PARAMS["g"]
    x = result.body("top")
    v = result.body("top", "qd")
    J = np.diag(inertia) if np.ndim(inertia) == 1 else np.asarray(inertia)
    lam = result.reaction("support")
    R = rotation_matrices(x)
    W = v[:, 3:6]
    out = {"x_cm": x[:, 0], "y_cm": x[:, 1], "z_cm": x[:, 2],
           "omega_x": W[:, 0], "omega_y": W[:, 1], "omega_z": W[:, 2],
           "lambda_x": lam[:, 0], "lambda_y": lam[:, 1], "lambda_z": lam[:, 2]}
    out["energy"] = (0.5 * mass * np.sum(v[:, :3] ** 2, axis=1) + 0.5 * np.einsum("ni,ij,nj->n", W, J, W)
                     - mass * x[:, :3] @ np.asarray(g, dtype=float))
    # L about the fixed point O (origin): R J Ω + m x × ẋ
    L = np.einsum("nij,nj->ni", R, W @ J.T) + mass * np.cross(x[:, :3], v[:, :3])
    out["L_z"] = L[:, 2]
    return out


def rotation_error(p, ref, k=-1):
    """Angle (rad) of the rotation between quaternion ``p`` (4,) and the reference's at output ``k``.

    δ = conj(p_ref) ⊗ p, angle = 2 atan2(‖δ_vec‖, |δ_0|) (sign-safe: p and −p are one rotation).
    """
    p = np.asarray(p, dtype=float)
    pr = np.array([np.atleast_1d(ref[f"p{i}"])[k] for i in range(4)])
    d0 = pr[0] * p[0] + pr[1:] @ p[1:]
    dv = pr[0] * p[1:] - p[0] * pr[1:] - np.cross(pr[1:], p[1:])
    return float(2.0 * np.arctan2(np.linalg.norm(dv), abs(d0)))


def reference(t_eval):
    """Reference outputs at ``t_eval`` (quaternion ODE, DOP853, rtol = atol = 1e-13)."""
    from femb.benchmarks.references import heavy_top as ref

    t_eval = np.asarray(t_eval, dtype=float)
    _, out = ref.solve(float(t_eval.max()), t_eval=t_eval)
    return out

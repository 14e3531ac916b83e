"""Slider-crank with a spring-mass system in minimal coordinates (reference).

Independent reference model for the first benchmark of the seed paper
(Arnold & Bruls, Multibody System Dynamics 18 (2007) 185-202, Sect. 5.1;
data in ``docs/benchmarks.md`` section 1).  It uses plain numpy/scipy only and
shares no code with femb's engine: it is a check, never the thing tested.

Model
-----
Planar, motion in the (x, y) plane, gravity ``g`` (default 0) along -y.

* body 1, crank: uniform bar of length ``l1``, mass ``m1``, centroidal inertia
  ``J1`` (default ``m1 l1**2 / 12``), pinned to the ground at the origin; its
  angle from the x axis is ``theta``, its tip is ``l1 (cos theta, sin theta)``.
* body 2, connecting rod: uniform bar ``l2``, ``m2``, ``J2`` (default
  ``m2 l2**2 / 12``) from the crank tip to the slider.
* body 3, slider: point mass ``m3`` at ``(x3, 0)`` on a frictionless guide,
  pinned to the end of the rod.
* body 4, extra mass: point mass ``m4`` at ``(x4, 0)`` on the same axis.
* linear spring along x between slider and extra mass, stiffness ``k``,
  unstretched length ``L0``; constant torque ``T`` on the crank.

Minimal coordinates ``(theta, x4)``.  With ``s = sin theta``, ``c = cos theta``
and ``w = sqrt(l2**2 - l1**2 s**2)`` (> 0 because ``l2 > l1``) the closed
kinematics of the crank-rod-slider loop are (branch with the slider to the
right of the crank tip)::

    x3   = l1 c + w
    phi2 = -arcsin(l1 s / l2)                    (rod angle, from tip to slider)
    x2   = (l1 c + x3) / 2,   y2 = l1 s / 2     (rod centre)
    x1   = l1 c / 2,          y1 = l1 s / 2     (crank centre), phi1 = theta

so every quantity of bodies 1-3 is a function of ``theta`` alone; with
``p' = dp/dtheta`` the velocities are ``p' theta_d`` and the accelerations
``p' theta_dd + p'' theta_d**2``.  The kinetic energy is::

    T_kin = 1/2 m(theta) theta_d**2 + 1/2 m4 x4_d**2,
    m(theta) = J1 + m1 l1**2/4 + m2 (x2'**2 + y2'**2) + J2 phi2'**2 + m3 x3'**2,

the potential ``V = 1/2 k (x4 - x3 - L0)**2 + g (m1 y1 + m2 y2)`` and the torque
does the work ``T theta``.  Lagrange's equations give::

    m(theta) theta_dd + 1/2 m'(theta) theta_d**2 = T - k (x4 - x3 - L0)(-x3')
                                                   - g (m1 + m2) l1 c / 2
    m4 x4_dd = -k (x4 - x3 - L0)

with ``m' = 2 (m2 (x2' x2'' + y2' y2'') + J2 phi2' phi2'' + m3 x3' x3'')``.
They are integrated with :func:`scipy.integrate.solve_ivp`.

Joint reactions
---------------
Once ``theta_dd`` and ``x4_dd`` are known, the body accelerations follow
from the kinematics and the reactions follow from Newton-Euler on the free
bodies (Newton's third law at every pin), solved body by body:

1. slider, x:   ``m3 a3 = R_rod_slider_x + F_s``, ``F_s = k (x4 - x3 - L0)``
   (spring force on the slider, positive when stretched);
2. rod, moment about its centre (unknown ``R_rod_slider_y``), with the crank
   pin force ``R_crank_rod = m2 a2 - (0, -m2 g) + R_rod_slider``;
3. slider, y:   ``0 = R_rod_slider_y + N_slider - m3 g``;
4. crank, force: ``R_pivot = m1 a1 + R_crank_rod + (0, m1 g)``;
5. extra mass, y: ``N_mass4 = m4 g``.

The crank's moment balance is not used and stays as an independent check
(it is equivalent to the first Lagrange equation).

Accuracy and cost (measured)
----------------------------
``solve(np.linspace(0, 1, 201))`` with the defaults (DOP853, rtol = atol =
1e-12) takes 0.06 s (4.3e3 right-hand-side evaluations) on the 2-core test
machine; against a run at rtol = 1e-13, atol = 1e-14 it differs by 1.3e-10 rad
in theta, 2e-11 m in x4, 1e-9 rad/s in theta_d and 2e-8 N in the reactions
(Radau at 1e-12 is closer, 6e-13 rad, but takes 2.1 s).  The energy integral
stays constant to 3e-11 of the torque's work over [0, 1] s.  Final state:
theta(1) = 7.4146249855 rad, x4(1) = 0.80044313728 m.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["PARAMS", "params", "solve", "energy", "kinematics"]

#: Problem data of ``docs/benchmarks.md`` section 1 (SI units).  ``J1``/``J2``
#: set to ``None`` mean "uniform slender bar", ``m l**2 / 12``; ``x4_0 = None``
#: means "spring unstretched at t = 0", ``x3(theta0) + L0``.
PARAMS: dict = {
    "l1": 0.3,  # crank length [m]
    "m1": 0.36,  # crank mass [kg]
    "J1": None,  # crank centroidal inertia [kg m^2], default m1 l1^2/12
    "l2": 0.6,  # rod length [m]
    "m2": 0.15,  # rod mass [kg]
    "J2": None,  # rod centroidal inertia [kg m^2], default m2 l2^2/12
    "m3": 0.1,  # slider mass [kg]
    "m4": 0.7,  # extra mass [kg]
    "k": 1000.0,  # spring stiffness [N/m]
    "L0": 0.2,  # unstretched spring length [m]
    "T": 1.0,  # constant crank torque [N m]
    "g": 0.0,  # gravity along -y [m/s^2] (none in the benchmark)
    "theta0": math.pi / 2,  # initial crank angle [rad]
    "theta_d0": 0.0,  # initial crank rate [rad/s]
    "x4_0": None,  # initial position of the extra mass [m]
    "x4_d0": 0.0,  # initial velocity of the extra mass [m/s]
}


def params(**overrides) -> dict:
    """Return the full parameter set with defaults resolved.

    Parameters
    ----------
    **overrides
        Any key of :data:`PARAMS`.

    Returns
    -------
    dict
        Copy of :data:`PARAMS` with the overrides applied, ``J1``, ``J2`` and
        ``x4_0`` resolved to numbers.

    Raises
    ------
    KeyError
        If an override is not a key of :data:`PARAMS`.
    ValueError
        If ``l2 <= l1`` (the crank could not turn fully).
    """
    unknown = set(overrides) - set(PARAMS)
    if unknown:
        raise KeyError(f"unknown parameter(s): {sorted(unknown)}")
    p = dict(PARAMS)
    p.update(overrides)
    if not p["l2"] > p["l1"] > 0:
        raise ValueError("need l2 > l1 > 0")
    if p["J1"] is None:
        p["J1"] = p["m1"] * p["l1"] ** 2 / 12.0
    if p["J2"] is None:
        p["J2"] = p["m2"] * p["l2"] ** 2 / 12.0
    if p["x4_0"] is None:
        p["x4_0"] = float(kinematics(p["theta0"], p)["x3"]) + p["L0"]
    return p


def kinematics(theta, p) -> dict:
    """Closed-form kinematics of the crank-rod-slider loop and derivatives.

    Parameters
    ----------
    theta : float or ndarray, shape (nt,)
        Crank angle [rad].
    p : dict
        Parameters (needs ``l1`` and ``l2``).

    Returns
    -------
    dict of ndarray, each of the shape of ``theta``
        ``x1, y1`` (crank centre), ``x2, y2, phi2`` (rod centre and angle),
        ``x3`` (slider), and their first and second derivatives with respect
        to ``theta``, named with suffixes ``_p`` and ``_pp``.
    """
    l1, l2 = p["l1"], p["l2"]
    th = np.asarray(theta, dtype=float)
    s, c = np.sin(th), np.cos(th)
    w = np.sqrt(l2**2 - (l1 * s) ** 2)
    w_p = -(l1**2) * s * c / w
    w_pp = -(l1**2) * (c**2 - s**2) / w - (l1**2 * s * c) ** 2 / w**3

    x3 = l1 * c + w
    x3_p = -l1 * s + w_p
    x3_pp = -l1 * c + w_pp

    phi2 = -np.arcsin(l1 * s / l2)
    # l2 cos(phi2) = w, so dphi2/dtheta = -l1 c / w
    phi2_p = -l1 * c / w
    phi2_pp = l1 * s / w + l1 * c * w_p / w**2

    return {
        "x1": 0.5 * l1 * c, "x1_p": -0.5 * l1 * s, "x1_pp": -0.5 * l1 * c,
        "y1": 0.5 * l1 * s, "y1_p": 0.5 * l1 * c, "y1_pp": -0.5 * l1 * s,
        "x2": 0.5 * (l1 * c + x3), "x2_p": 0.5 * (-l1 * s + x3_p),
        "x2_pp": 0.5 * (-l1 * c + x3_pp),
        "y2": 0.5 * l1 * s, "y2_p": 0.5 * l1 * c, "y2_pp": -0.5 * l1 * s,
        "phi2": phi2, "phi2_p": phi2_p, "phi2_pp": phi2_pp,
        "x3": x3, "x3_p": x3_p, "x3_pp": x3_pp,
    }


def _generalized_mass(kin, p):
    """m(theta) and dm/dtheta (see module docstring)."""
    m = (p["J1"] + p["m1"] * p["l1"] ** 2 / 4.0
         + p["m2"] * (kin["x2_p"] ** 2 + kin["y2_p"] ** 2)
         + p["J2"] * kin["phi2_p"] ** 2 + p["m3"] * kin["x3_p"] ** 2)
    m_p = 2.0 * (p["m2"] * (kin["x2_p"] * kin["x2_pp"] + kin["y2_p"] * kin["y2_pp"])
                 + p["J2"] * kin["phi2_p"] * kin["phi2_pp"]
                 + p["m3"] * kin["x3_p"] * kin["x3_pp"])
    return m, m_p


def _accelerations(theta, theta_d, x4, p):
    """Minimal-coordinate accelerations (theta_dd, x4_dd) from Lagrange."""
    kin = kinematics(theta, p)
    m, m_p = _generalized_mass(kin, p)
    stretch = x4 - kin["x3"] - p["L0"]
    q_theta = (p["T"] + p["k"] * stretch * kin["x3_p"]
               - p["g"] * (p["m1"] + p["m2"]) * 0.5 * p["l1"] * np.cos(theta))
    theta_dd = (q_theta - 0.5 * m_p * theta_d**2) / m
    x4_dd = -p["k"] * stretch / p["m4"]
    return theta_dd, x4_dd


def _scalar_rhs(p):
    """The integrand ``rhs(t, y) -> [θ', x4', θ'', x4'']`` of :func:`solve` in Python floats.

    The formulas of :func:`kinematics`, :func:`_generalized_mass` and :func:`_accelerations`
    for one state, with :mod:`math` instead of numpy: those array functions cost about three
    times as much per call on scalars, and a stiff spring (k × 10⁶) takes 4·10⁵ calls at
    rtol = 1e-12.
    """
    l1, l2, m2, m3, J2 = p["l1"], p["l2"], p["m2"], p["m3"], p["J2"]
    k, L0, T, g, m4 = p["k"], p["L0"], p["T"], p["g"], p["m4"]
    m_const = p["J1"] + p["m1"] * l1 ** 2 / 4.0
    grav = g * (p["m1"] + m2) * 0.5 * l1
    l1s = l1 ** 2

    def rhs(_t, y):
        th, x4, th_d, x4_d = y
        s, c = math.sin(th), math.cos(th)
        w = math.sqrt(l2 ** 2 - (l1 * s) ** 2)
        w_p = -l1s * s * c / w
        w_pp = -l1s * (c ** 2 - s ** 2) / w - (l1s * s * c) ** 2 / w ** 3
        x3_p, x3_pp = -l1 * s + w_p, -l1 * c + w_pp
        x2_p, x2_pp = 0.5 * (-l1 * s + x3_p), 0.5 * (-l1 * c + x3_pp)
        y2_p, y2_pp = 0.5 * l1 * c, -0.5 * l1 * s
        phi2_p = -l1 * c / w
        phi2_pp = l1 * s / w + l1 * c * w_p / w ** 2
        m = m_const + m2 * (x2_p ** 2 + y2_p ** 2) + J2 * phi2_p ** 2 + m3 * x3_p ** 2
        m_p = 2.0 * (m2 * (x2_p * x2_pp + y2_p * y2_pp) + J2 * phi2_p * phi2_pp + m3 * x3_p * x3_pp)
        stretch = x4 - (l1 * c + w) - L0
        q_theta = T + k * stretch * x3_p - grav * c
        return [th_d, x4_d, (q_theta - 0.5 * m_p * th_d ** 2) / m, -k * stretch / m4]

    return rhs


def solve(t_eval, *, rtol=1e-12, atol=1e-12, method="DOP853", cache=False, **overrides) -> dict:
    """Integrate the minimal-coordinate model and post-process body states.

    Parameters
    ----------
    t_eval : array_like, shape (nt,)
        Output times [s], increasing, starting at or after 0 (the initial
        state is given at t = 0).
    rtol, atol : float, optional
        Tolerances passed to :func:`scipy.integrate.solve_ivp`.
    method : str, optional
        ``solve_ivp`` method, ``"DOP853"`` (default, about 1e-10 accurate in
        theta over [0, 1] s) or ``"Radau"`` (more accurate here, 35x slower;
        preferable for very stiff springs).
    cache : bool, optional
        Integrate once per process for these parameters, tolerances and method
        and evaluate that dense solution at later ``t_eval`` (for references; a
        timed run leaves it off). :func:`femb.benchmarks.references.dense.integrate`.
    **overrides
        Any key of :data:`PARAMS` (e.g. ``k=1e5``, ``m2=0.3``, ``T=0``).

    Returns
    -------
    dict
        Arrays over ``t_eval`` (``nt`` points):

        * ``t`` (nt,)
        * ``theta, theta_d, theta_dd`` (nt,): crank angle, rate, acceleration
        * ``x3, x3_d, x3_dd`` (nt,): slider position, velocity, acceleration
        * ``x4, x4_d, x4_dd`` (nt,): extra mass
        * ``x1, y1, phi1`` and ``x1_d, y1_d, phi1_d`` (nt,): crank centre and
          angle (``phi1 = theta``) and their rates
        * ``x2, y2, phi2`` and ``x2_d, y2_d, phi2_d`` (nt,): rod centre and
          angle (direction crank tip -> slider) and their rates
        * ``a1`` (nt, 2), ``alpha1`` (nt,), ``a2`` (nt, 2), ``alpha2`` (nt,):
          centre accelerations and angular accelerations of crank and rod
        * ``spring_force`` (nt,): ``k (x4 - x3 - L0)``, tension positive
        * ``R_pivot`` (nt, 2): force of the ground on the crank at the pivot
        * ``R_crank_rod`` (nt, 2): force of the crank on the rod at their pin
        * ``R_rod_slider`` (nt, 2): force of the rod on the slider
        * ``N_slider`` (nt,): vertical (y) force of the guide on the slider
        * ``N_mass4`` (nt,): vertical force of the guide on the extra mass
        * ``params``: the resolved parameter dict
        * ``nfev``: number of right-hand-side evaluations

    Raises
    ------
    RuntimeError
        If the integrator fails.
    """
    from femb.benchmarks.references.dense import integrate

    p = params(**overrides)
    t_eval = np.atleast_1d(np.asarray(t_eval, dtype=float))

    rhs = _scalar_rhs(p)
    y0 = [p["theta0"], p["x4_0"], p["theta_d0"], p["x4_d0"]]
    key = ("slider_crank_minimal", tuple(sorted(p.items()))) if cache else None
    Y, nfev = integrate(rhs, y0, t_eval, key=key, rtol=rtol, atol=atol, method=method)
    th, x4, th_d, x4_d = Y.T
    return _post_process(t_eval, th, th_d, x4, x4_d, p, nfev)


def _post_process(t, th, th_d, x4, x4_d, p, nfev):
    kin = kinematics(th, p)
    th_dd, x4_dd = _accelerations(th, th_d, x4, p)

    def vel(name):
        return kin[name + "_p"] * th_d

    def acc(name):
        return kin[name + "_p"] * th_dd + kin[name + "_pp"] * th_d**2

    m1, m2, m3, m4, g = p["m1"], p["m2"], p["m3"], p["m4"], p["g"]
    l1 = p["l1"]
    s, c = np.sin(th), np.cos(th)

    a1 = np.column_stack([acc("x1"), acc("y1")])
    a2 = np.column_stack([acc("x2"), acc("y2")])
    alpha1 = th_dd
    alpha2 = acc("phi2")
    a3 = acc("x3")
    x3 = kin["x3"]
    spring = p["k"] * (x4 - x3 - p["L0"])

    # pins: crank tip A, slider B; lever arms from the rod's centre
    rA = np.column_stack([l1 * c, l1 * s])
    rB = np.column_stack([x3, np.zeros_like(x3)])
    r2 = np.column_stack([kin["x2"], kin["y2"]])
    dA, dB = rA - r2, rB - r2

    def cross(u, v):
        return u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]

    # 1. slider, x direction
    R_rs_x = m3 * a3 - spring
    # 2. rod: m2 a2 = R_cr - R_rs + (0, -m2 g);  J2 alpha2 = dA x R_cr - dB x R_rs
    #    with R_cr = m2 a2 + (0, m2 g) + R_rs:
    #    J2 alpha2 = dA x (m2 a2 + (0, m2 g)) + (dA - dB) x R_rs
    F2 = m2 * a2 + np.column_stack([np.zeros_like(th), np.full_like(th, m2 * g)])
    dAB = dA - dB  # = rA - rB
    # (dA - dB) x R_rs = dAB_x R_rs_y - dAB_y R_rs_x  -> solve for R_rs_y
    R_rs_y = (p["J2"] * alpha2 - cross(dA, F2) + dAB[:, 1] * R_rs_x) / dAB[:, 0]
    R_rs = np.column_stack([R_rs_x, R_rs_y])
    R_cr = F2 + R_rs
    # 3. slider, y direction
    N_slider = m3 * g - R_rs_y
    # 4. crank, force balance: m1 a1 = R_pivot - R_cr + (0, -m1 g)
    R_pivot = m1 * a1 + R_cr + np.column_stack([np.zeros_like(th), np.full_like(th, m1 * g)])
    # 5. extra mass
    N_mass4 = np.full_like(th, m4 * g)

    return {
        "t": t,
        "theta": th, "theta_d": th_d, "theta_dd": th_dd,
        "x3": x3, "x3_d": vel("x3"), "x3_dd": a3,
        "x4": x4, "x4_d": x4_d, "x4_dd": x4_dd,
        "x1": kin["x1"], "y1": kin["y1"], "phi1": th.copy(),
        "x1_d": vel("x1"), "y1_d": vel("y1"), "phi1_d": th_d.copy(),
        "x2": kin["x2"], "y2": kin["y2"], "phi2": kin["phi2"],
        "x2_d": vel("x2"), "y2_d": vel("y2"), "phi2_d": vel("phi2"),
        "a1": a1, "alpha1": alpha1, "a2": a2, "alpha2": alpha2,
        "spring_force": spring,
        "R_pivot": R_pivot, "R_crank_rod": R_cr, "R_rod_slider": R_rs,
        "N_slider": N_slider, "N_mass4": N_mass4,
        "params": p, "nfev": nfev,
    }


def energy(sol) -> np.ndarray:
    """Energy integral of a solution returned by :func:`solve`.

    ``E = T_kin + V_spring + V_gravity - T (theta - theta0)``, which is
    constant in time for the exact solution (the torque is constant and
    there is no dissipation).

    Parameters
    ----------
    sol : dict
        Output of :func:`solve`.

    Returns
    -------
    ndarray, shape (nt,)
        Energy integral [J] at each output time.
    """
    p = sol["params"]
    kin_energy = 0.5 * (
        p["m1"] * (sol["x1_d"] ** 2 + sol["y1_d"] ** 2) + p["J1"] * sol["phi1_d"] ** 2
        + p["m2"] * (sol["x2_d"] ** 2 + sol["y2_d"] ** 2) + p["J2"] * sol["phi2_d"] ** 2
        + p["m3"] * sol["x3_d"] ** 2 + p["m4"] * sol["x4_d"] ** 2)
    v_spring = 0.5 * p["k"] * (sol["x4"] - sol["x3"] - p["L0"]) ** 2
    v_grav = p["g"] * (p["m1"] * sol["y1"] + p["m2"] * sol["y2"])
    return kin_energy + v_spring + v_grav - p["T"] * (sol["theta"] - p["theta0"])

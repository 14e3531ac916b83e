"""Andrews' squeezing mechanism in Hairer's relative coordinates (reference).

Independent reference model for the second benchmark of the seed paper
(Arnold & Bruls, Multibody System Dynamics 18 (2007) 185-202, Sect. 5.2;
data in ``docs/benchmarks.md`` section 2).  Plain numpy/scipy, no code shared
with femb's engine: it is a check, never the thing tested.

Sources
-------
* E. Hairer, G. Wanner, *Solving Ordinary Differential Equations II*, 2nd ed.,
  Springer 1996, Sect. VII.7 (the mechanism, its data and initial values).
* F. Mazzia, C. Magherini, *Test Set for Initial Value Problem Solvers*,
  release 2.4 (2008), problem ``andrews`` (Univ. of Bari,
  https://archimede.uniba.it/~testset/): closed-form ``M(q)``, ``f(q, q')``,
  ``g(q)``, ``G = g_q`` and the PSIDE reference solution at t = 0.03.  The
  formulas below were written from its problem description and re-derived
  here from the body table of ``docs/benchmarks.md`` (walking the hinges);
  the test file checks ``M`` against the kinetic energy of the seven bodies
  and the quadratic velocity terms against Lagrange's equations.

Coordinates and equations
-------------------------
``q = (beta, Theta, gamma, Phi, delta, Omega, epsilon)``, with the absolute
body angles ``phi1 = beta``, ``phi2 = beta + Theta``, ``phi3 = gamma``,
``phi4 = Phi + delta``, ``phi5 = delta``, ``phi6 = Omega + epsilon``,
``phi7 = epsilon``.  The chains O-1-2, B-3, A-5-4 and A-7-6 are open; the six
constraints close them at point E (two components each)::

    g1,2 = E(rod) - E(triangle 3)
    g3,4 = E(rod) - E(body 4, reached through A-5-F-4)
    g5,6 = E(rod) - E(body 6, reached through A-7-G-6)

and the equations of motion are ``M(q) q'' = f(q, q') - G(q)^T lam``,
``g(q) = 0`` (the published sign convention).  ``solve`` integrates the
index-1 form: at each right-hand-side call it solves

    [ M  G^T ] [ q'' ]   [ f                 ]
    [ G  0   ] [ lam ] = [ -g_qq(q', q')      ]

with ``g_qq(q', q') = d/dt(G) q'``, the 13 x 13 system being nonsingular.

Multipliers and reactions at E
------------------------------
With ``M q'' = f - G^T lam``, the generalized force of ``g_i`` is
``-lam_i grad g_i``; since ``g_i`` is "point E of the rod minus point E of
the other chain", ``lam_(2j-1), lam_(2j)`` is the force (x, y) **exerted by
the rod on the other body at E** (triangle 3 for j = 1, body 4 for j = 2,
body 6 for j = 3), and the rod receives ``-(lam1 + lam3 + lam5,
lam2 + lam4 + lam6)`` at E.  In an absolute-coordinate model with hinge
constraints written "rod minus body", the same hinge multipliers appear;
written "body minus rod", they appear with the opposite sign.

Accuracy and cost (measured, see ``tests/test_reference_andrews.py``)
---------------------------------------------------------------------
``solve([0.03])`` with the defaults (DOP853, rtol = atol = 1e-12) takes
0.15 s on the 2-core test machine (3233 right-hand-side evaluations;
Radau at the same tolerances gives the same digits in 4.8 s).  Against
:data:`PUBLISHED_T003`:

* angles: max abs. difference 1.4e-9 rad (Theta; beta 1.1e-9 on 15.8 rad,
  largest relative one 2.8e-10 on gamma),
* rates: 1.3e-10 relative on beta', Theta'; at most 5.1e-8 relative
  (epsilon') over all seven,
* multipliers: at most 1.26e-6 relative (lam6, 1.5e-5 N), the others
  <= 3.7e-7; accelerations at most 1.3e-6 relative,

i.e. at the stated accuracy of the published values (3e-10 rel. in angles,
5e-8 in velocities, about 1e-6 in lam).  The differences are the published
values' own errors: this solution changes by only 5e-13 rad in the angles and
2e-11 relative in lam when the tolerances go to 1e-13/1e-14 or the method to
Radau.  The index-1 form is integrated without projection; the position
constraints drift to about 1e-14 m, the velocity constraints to 4e-12 m/s,
the energy integral to 3e-12 relative (of the torque's work) over [0, 0.03].
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "PARAMS", "NAMES", "Q0", "QD0", "Y0", "QDD0", "LAM0", "PUBLISHED_T003",
    "mass_matrix", "forces", "constraints", "constraint_jacobian",
    "constraint_bias", "spring_length", "energy", "body_frames", "hinge_points",
    "accelerations", "solve",
]

#: Problem constants (SI), docs/benchmarks.md section 2 = Hairer & Wanner,
#: Sect. VII.7 = IVP test set, problem ``andrews``.
PARAMS: dict = {
    "m1": 0.04325, "m2": 0.00365, "m3": 0.02373, "m4": 0.00706,
    "m5": 0.07050, "m6": 0.00706, "m7": 0.05498,
    "i1": 2.194e-6, "i2": 4.410e-7, "i3": 5.255e-6, "i4": 5.667e-7,
    "i5": 1.169e-5, "i6": 5.667e-7, "i7": 1.912e-5,
    "xa": -0.06934, "ya": -0.00227,
    "xb": -0.03635, "yb": 0.03273,
    "xc": 0.014, "yc": 0.072,
    "d": 28e-3, "da": 115e-4, "e": 2e-2, "ea": 1421e-5, "rr": 7e-3, "ra": 92e-5,
    "ss": 35e-3, "sa": 1874e-5, "sb": 1043e-5, "sc": 18e-3, "sd": 2e-2,
    "ta": 2308e-5, "tb": 916e-5, "u": 4e-2, "ua": 1228e-5, "ub": 449e-5,
    "zf": 2e-2, "zt": 4e-2, "fa": 1421e-5,
    "mom": 0.033, "c0": 4530.0, "l0": 0.07785,
}

#: Names of the seven relative angles, in the order of ``q``.
NAMES = ("beta", "Theta", "gamma", "Phi", "delta", "Omega", "epsilon")

#: Consistent initial angles [rad] (Hairer & Wanner VII.7; IVP test set).
Q0 = np.array([
    -0.0617138900142764496358948458001,
    0.0,
    0.455279819163070380255912382449,
    0.222668390165885884674473185609,
    0.487364979543842550225598953530,
    -0.222668390165885884674473185609,
    1.23054744454982119249735015568,
])
#: Initial angular velocities [rad/s]: the mechanism starts at rest.
QD0 = np.zeros(7)
#: Initial state ``(q, q')``, shape (14,).
Y0 = np.concatenate([Q0, QD0])
#: Consistent initial accelerations [rad/s^2] (IVP test set initial values).
QDD0 = np.array([14222.4439199541138705911625887, -10666.8329399655854029433719415,
                 0.0, 0.0, 0.0, 0.0, 0.0])
#: Consistent initial multipliers [N] (IVP test set initial values).
LAM0 = np.array([98.5668703962410896057654982170, -6.12268834425566265503114393122,
                 0.0, 0.0, 0.0, 0.0])

#: Published reference solution at t = 0.03 s.  Source: IVP test set
#: (Mazzia & Magherini), problem ``andrews``, computed with PSIDE at
#: rtol = atol = 1e-14 (values as in docs/benchmarks.md section 2).  Stated
#: accuracy: about 3e-10 relative in the angles, 5e-8 relative in the
#: velocities, about 1e-6 in the multipliers (not the 16 printed digits).
#: Multipliers in the convention M q'' = f - G^T lam.
PUBLISHED_T003: dict = {
    "t": 0.03,
    "angles": np.array([
        15.81077119629904,  # beta
        -15.75637105984298,  # Theta
        0.04082224013073101,  # gamma
        -0.5347301163226948,  # Phi
        0.5244099658805304,  # delta
        0.5347301163226948,  # Omega
        1.048080741042263,  # epsilon
    ]),
    "beta_d": 1139.920302151208,
    "Theta_d": -1424.379294994111,
    "lam": np.array([
        199.175333373191, -29.75531228015052,  # rod - triangle 3 at E
        23.06654119098399, 31.45271365475927,  # rod - body 4 at E
        22.64249232082739, 11.61740700019673,  # rod - body 6 at E
    ]),
    # rates and accelerations of all seven angles: same source (the test
    # set's reference solution vector), not listed in docs/benchmarks.md
    "rates": np.array([
        0.1139920302151208e+4, -0.1424379294994111e+4, 0.1103291221937134e+2,
        0.1929337464421385e+2, 0.5735699284790808e+0, -0.1929337464421385e+2,
        0.3231791658026955e+0,
    ]),
    "accelerations": np.array([
        -0.2463176316945196e+5, 0.5185037701610329e+5, 0.3241025686413781e+6,
        0.5667493645176213e+6, 0.1674362929479361e+5, -0.5667493645176222e+6,
        0.9826520791458422e+4,
    ]),
    "rtol_angles": 3e-10,
    "rtol_velocities": 5e-8,
    "rtol_lam": 1e-6,
}


def _trig(q):
    be, th, ga, ph, de, om, ep = q
    return dict(
        sbe=np.sin(be), cbe=np.cos(be), sth=np.sin(th), cth=np.cos(th),
        sga=np.sin(ga), cga=np.cos(ga), sph=np.sin(ph), sde=np.sin(de),
        cde=np.cos(de), som=np.sin(om), sep=np.sin(ep), cep=np.cos(ep),
        sbt=np.sin(be + th), cbt=np.cos(be + th),
        spd=np.sin(ph + de), cpd=np.cos(ph + de),
        soe=np.sin(om + ep), coe=np.cos(om + ep),
    )


def mass_matrix(q, p=PARAMS) -> np.ndarray:
    """Mass matrix of the relative-coordinate model.

    Parameters
    ----------
    q : array_like, shape (7,)
        Angles ``(beta, Theta, gamma, Phi, delta, Omega, epsilon)`` [rad].
    p : dict, optional
        Constants, default :data:`PARAMS`.

    Returns
    -------
    ndarray, shape (7, 7)
        Symmetric positive definite ``M(q)`` [kg m^2]; block diagonal with
        blocks (beta, Theta), (gamma), (Phi, delta), (Omega, epsilon).
    """
    q = np.asarray(q, dtype=float)
    cth, sph, som = np.cos(q[1]), np.sin(q[3]), np.sin(q[5])
    m2, m4, m6 = p["m2"], p["m4"], p["m6"]
    rr, da, zt, u = p["rr"], p["da"], p["zt"], p["u"]
    e4 = p["e"] - p["ea"]  # distance centre of body 4 - point F
    f6 = p["zf"] - p["fa"]  # distance centre of body 6 - point G
    M = np.zeros((7, 7))
    # crank 1 and rod 2 (rod centre = P - da e(phi2))
    M[0, 0] = p["m1"] * p["ra"] ** 2 + m2 * (rr**2 - 2 * da * rr * cth + da**2) + p["i1"] + p["i2"]
    M[0, 1] = M[1, 0] = m2 * (da**2 - da * rr * cth) + p["i2"]
    M[1, 1] = m2 * da**2 + p["i2"]
    # triangle 3 pivoting at B
    M[2, 2] = p["m3"] * (p["sa"] ** 2 + p["sb"] ** 2) + p["i3"]
    # body 4 (hinged at F of body 5) and body 5 (pivoting at A)
    M[3, 3] = m4 * e4**2 + p["i4"]
    M[3, 4] = M[4, 3] = m4 * (e4**2 + zt * e4 * sph) + p["i4"]
    M[4, 4] = (m4 * (zt**2 + 2 * zt * e4 * sph + e4**2) + p["m5"] * (p["ta"] ** 2 + p["tb"] ** 2)
               + p["i4"] + p["i5"])
    # body 6 (hinged at G of body 7) and body 7 (pivoting at A)
    M[5, 5] = m6 * f6**2 + p["i6"]
    M[5, 6] = M[6, 5] = m6 * (f6**2 - u * f6 * som) + p["i6"]
    M[6, 6] = (m6 * (f6**2 - 2 * u * f6 * som + u**2) + p["m7"] * (p["ua"] ** 2 + p["ub"] ** 2)
               + p["i6"] + p["i7"])
    return M


def spring_length(q, p=PARAMS) -> float:
    """Length ``|D - C|`` of the spring [m] for angles ``q`` (shape (7,))."""
    ga = q[2]
    xd = p["sd"] * np.cos(ga) + p["sc"] * np.sin(ga) + p["xb"]
    yd = p["sd"] * np.sin(ga) - p["sc"] * np.cos(ga) + p["yb"]
    return float(np.hypot(xd - p["xc"], yd - p["yc"]))


def forces(q, qd, p=PARAMS) -> np.ndarray:
    """Applied plus quadratic-velocity (centrifugal/Coriolis) forces.

    Parameters
    ----------
    q, qd : array_like, shape (7,)
        Angles [rad] and angular velocities [rad/s].
    p : dict, optional
        Constants.

    Returns
    -------
    ndarray, shape (7,)
        ``f(q, q')`` [N m]: the torque ``mom`` on ``beta``, the spring force's
        generalized component on ``gamma``, and ``-(M' q' - 1/2 grad(q'^T M q'))``.
    """
    q = np.asarray(q, dtype=float)
    bep, thp, _, php, dep, omp, epp = np.asarray(qd, dtype=float)
    ga = q[2]
    sth, cph, com = np.sin(q[1]), np.cos(q[3]), np.cos(q[5])
    sga, cga = np.sin(ga), np.cos(ga)
    m2, m4, m6 = p["m2"], p["m4"], p["m6"]
    e4 = p["e"] - p["ea"]
    f6 = p["zf"] - p["fa"]
    # spring between D (on body 3) and the ground point C, force on D
    xd = p["sd"] * cga + p["sc"] * sga + p["xb"]
    yd = p["sd"] * sga - p["sc"] * cga + p["yb"]
    L = np.hypot(xd - p["xc"], yd - p["yc"])
    fac = -p["c0"] * (L - p["l0"]) / L
    fx, fy = fac * (xd - p["xc"]), fac * (yd - p["yc"])
    # dD/dgamma = (-sd sin + sc cos, sd cos + sc sin)
    f = np.empty(7)
    f[0] = p["mom"] - m2 * p["da"] * p["rr"] * thp * (thp + 2 * bep) * sth
    f[1] = m2 * p["da"] * p["rr"] * bep**2 * sth
    f[2] = fx * (p["sc"] * cga - p["sd"] * sga) + fy * (p["sd"] * cga + p["sc"] * sga)
    f[3] = m4 * p["zt"] * e4 * dep**2 * cph
    f[4] = -m4 * p["zt"] * e4 * php * (php + 2 * dep) * cph
    f[5] = -m6 * p["u"] * f6 * epp**2 * com
    f[6] = m6 * p["u"] * f6 * omp * (omp + 2 * epp) * com
    return f


def constraints(q, p=PARAMS) -> np.ndarray:
    """Loop-closure constraints at point E.

    Parameters
    ----------
    q : array_like, shape (7,)
        Angles [rad].
    p : dict, optional
        Constants.

    Returns
    -------
    ndarray, shape (6,)
        ``g(q)`` [m]: E of the rod minus E of triangle 3 (g1, g2), of body 4
        (g3, g4) and of body 6 (g5, g6), (x, y) each.
    """
    t = _trig(q)
    rr, d, ss, e, zt, zf, u = (p[k] for k in ("rr", "d", "ss", "e", "zt", "zf", "u"))
    ex = rr * t["cbe"] - d * t["cbt"]  # E of the rod, x
    ey = rr * t["sbe"] - d * t["sbt"]  # E of the rod, y
    return np.array([
        ex - ss * t["sga"] - p["xb"],
        ey + ss * t["cga"] - p["yb"],
        ex - e * t["spd"] - zt * t["cde"] - p["xa"],
        ey + e * t["cpd"] - zt * t["sde"] - p["ya"],
        ex - zf * t["coe"] - u * t["sep"] - p["xa"],
        ey - zf * t["soe"] + u * t["cep"] - p["ya"],
    ])


def constraint_jacobian(q, p=PARAMS) -> np.ndarray:
    """Constraint gradient ``G = dg/dq``.

    Parameters
    ----------
    q : array_like, shape (7,)
        Angles [rad].
    p : dict, optional
        Constants.

    Returns
    -------
    ndarray, shape (6, 7)
        ``G(q)`` [m/rad], full row rank in the mechanism's working range.
    """
    t = _trig(q)
    rr, d, ss, e, zt, zf, u = (p[k] for k in ("rr", "d", "ss", "e", "zt", "zf", "u"))
    G = np.zeros((6, 7))
    # derivative of E(rod) with respect to (beta, Theta), shared by all rows
    G[0::2, 0] = -rr * t["sbe"] + d * t["sbt"]
    G[0::2, 1] = d * t["sbt"]
    G[1::2, 0] = rr * t["cbe"] - d * t["cbt"]
    G[1::2, 1] = -d * t["cbt"]
    G[0, 2] = -ss * t["cga"]
    G[1, 2] = -ss * t["sga"]
    G[2, 3] = -e * t["cpd"]
    G[2, 4] = -e * t["cpd"] + zt * t["sde"]
    G[3, 3] = -e * t["spd"]
    G[3, 4] = -e * t["spd"] - zt * t["cde"]
    G[4, 5] = zf * t["soe"]
    G[4, 6] = zf * t["soe"] - u * t["cep"]
    G[5, 5] = -zf * t["coe"]
    G[5, 6] = -zf * t["coe"] - u * t["sep"]
    return G


def constraint_bias(q, qd, p=PARAMS) -> np.ndarray:
    """Quadratic velocity term of the constraint accelerations.

    Parameters
    ----------
    q, qd : array_like, shape (7,)
        Angles [rad] and angular velocities [rad/s].
    p : dict, optional
        Constants.

    Returns
    -------
    ndarray, shape (6,)
        ``g_qq(q', q') = (dG/dt) q'`` [m/s^2], so that
        ``d^2 g/dt^2 = G q'' + g_qq(q', q')``.
    """
    t = _trig(q)
    rr, d, ss, e, zt, zf, u = (p[k] for k in ("rr", "d", "ss", "e", "zt", "zf", "u"))
    bep, thp, gap, php, dep, omp, epp = np.asarray(qd, dtype=float)
    w2 = (bep + thp) ** 2
    ax = -rr * t["cbe"] * bep**2 + d * t["cbt"] * w2  # E(rod) centripetal, x
    ay = -rr * t["sbe"] * bep**2 + d * t["sbt"] * w2
    w4 = (php + dep) ** 2
    w6 = (omp + epp) ** 2
    return np.array([
        ax + ss * t["sga"] * gap**2,
        ay - ss * t["cga"] * gap**2,
        ax + e * t["spd"] * w4 + zt * t["cde"] * dep**2,
        ay - e * t["cpd"] * w4 + zt * t["sde"] * dep**2,
        ax + zf * t["coe"] * w6 + u * t["sep"] * epp**2,
        ay + zf * t["soe"] * w6 - u * t["cep"] * epp**2,
    ])


def accelerations(q, qd, p=PARAMS):
    """Solve the index-1 system for ``q''`` and ``lam``.

    Parameters
    ----------
    q, qd : array_like, shape (7,)
        Angles [rad] and angular velocities [rad/s].
    p : dict, optional
        Constants.

    Returns
    -------
    qdd : ndarray, shape (7,)
        Angular accelerations [rad/s^2].
    lam : ndarray, shape (6,)
        Multipliers [N], convention ``M q'' = f - G^T lam``.
    """
    G = constraint_jacobian(q, p)
    A = np.zeros((13, 13))
    A[:7, :7] = mass_matrix(q, p)
    A[:7, 7:] = G.T
    A[7:, :7] = G
    b = np.concatenate([forces(q, qd, p), -constraint_bias(q, qd, p)])
    x = np.linalg.solve(A, b)
    return x[:7], x[7:]


def energy(q, qd, p=PARAMS):
    """Energy integral ``T + V - mom * beta`` (constant along solutions).

    Parameters
    ----------
    q, qd : array_like, shape (7,) or (nt, 7)
        Angles [rad] and angular velocities [rad/s].
    p : dict, optional
        Constants.

    Returns
    -------
    float or ndarray, shape (nt,)
        ``1/2 q'^T M(q) q' + 1/2 c0 (|D - C| - l0)^2 - mom beta`` [J].
    """
    q = np.asarray(q, dtype=float)
    qd = np.asarray(qd, dtype=float)
    if q.ndim == 2:
        return np.array([energy(qi, qdi, p) for qi, qdi in zip(q, qd)])
    kin = 0.5 * qd @ mass_matrix(q, p) @ qd
    pot = 0.5 * p["c0"] * (spring_length(q, p) - p["l0"]) ** 2
    return float(kin + pot - p["mom"] * q[0])


def _rot(phi):
    c, s = np.cos(phi), np.sin(phi)
    return np.array([[c, -s], [s, c]])


def hinge_points(p=PARAMS) -> dict:
    """Body-frame coordinates of the hinge and spring points.

    Points of each body in its own frame, relative to its centre of mass [m]
    (docs/benchmarks.md section 2, table "Bodies in absolute coordinates").

    Parameters
    ----------
    p : dict, optional
        Constants.

    Returns
    -------
    dict
        ``{body: {point: ndarray (2,)}}`` for bodies 1..7, e.g.
        ``hinge_points()[3]["D"]``.
    """
    return {
        1: {"O": np.array([-p["ra"], 0.0]), "P": np.array([p["rr"] - p["ra"], 0.0])},
        2: {"P": np.array([p["da"], 0.0]), "E": np.array([p["da"] - p["d"], 0.0])},
        3: {"B": np.array([-p["sa"], p["sb"]]), "E": np.array([-p["sa"], p["sb"] - p["ss"]]),
            "D": np.array([p["sd"] - p["sa"], p["sb"] - p["sc"]])},
        4: {"F": np.array([0.0, p["e"] - p["ea"]]), "E": np.array([0.0, -p["ea"]])},
        5: {"A": np.array([-p["ta"], -p["tb"]]), "F": np.array([p["zt"] - p["ta"], -p["tb"]])},
        6: {"G": np.array([-(p["zf"] - p["fa"]), 0.0]), "E": np.array([p["fa"], 0.0])},
        7: {"A": np.array([-p["ua"], -p["ub"]]), "G": np.array([-p["ua"], -p["u"] - p["ub"]])},
    }


def body_frames(q, p=PARAMS) -> np.ndarray:
    """Absolute centre positions and angles of the seven bodies.

    The open chains are walked from the ground hinges O, B and A using the
    body-point table of docs/benchmarks.md (so this is independent of the
    closed-form formulas above; on a consistent ``q`` the three copies of E
    coincide).

    Parameters
    ----------
    q : array_like, shape (7,)
        Relative angles [rad].
    p : dict, optional
        Constants.

    Returns
    -------
    ndarray, shape (7, 3)
        Row ``k - 1`` is ``(x_k, y_k, phi_k)`` of body ``k``.
    """
    be, th, ga, ph, de, om, ep = np.asarray(q, dtype=float)
    pts = hinge_points(p)
    A = np.array([p["xa"], p["ya"]])
    B = np.array([p["xb"], p["yb"]])
    phi = np.array([be, be + th, ga, ph + de, de, om + ep, ep])
    R = [_rot(a) for a in phi]
    c = np.zeros((7, 2))
    c[0] = -R[0] @ pts[1]["O"]  # O at the origin
    P = c[0] + R[0] @ pts[1]["P"]
    c[1] = P - R[1] @ pts[2]["P"]
    c[2] = B - R[2] @ pts[3]["B"]
    c[4] = A - R[4] @ pts[5]["A"]
    F = c[4] + R[4] @ pts[5]["F"]
    c[3] = F - R[3] @ pts[4]["F"]
    c[6] = A - R[6] @ pts[7]["A"]
    G = c[6] + R[6] @ pts[7]["G"]
    c[5] = G - R[5] @ pts[6]["G"]
    return np.column_stack([c, phi])


def solve(t_eval, *, rtol=1e-12, atol=1e-12, method="DOP853", y0=None, cache=False) -> dict:
    """Integrate the index-1 form with :func:`scipy.integrate.solve_ivp`.

    Parameters
    ----------
    t_eval : array_like, shape (nt,)
        Output times [s], increasing, >= 0 (the initial state is at t = 0).
    rtol, atol : float, optional
        Tolerances of ``solve_ivp`` (on angles and angular velocities).
    method : str, optional
        ``solve_ivp`` method; DOP853 (default) is the most accurate per unit
        of time on this non-stiff problem.
    y0 : array_like, shape (14,), optional
        Initial ``(q, q')``; default :data:`Y0` (must be consistent).
    cache : bool, optional
        Integrate once per process for these ``y0``, tolerances and method and
        evaluate that dense solution at later ``t_eval`` (for references; a
        timed run leaves it off). :func:`femb.benchmarks.references.dense.integrate`.

    Returns
    -------
    dict
        * ``t`` (nt,)
        * ``angles`` (nt, 7), ``rates`` (nt, 7), ``accelerations`` (nt, 7):
          ``q, q', q''`` in the order of :data:`NAMES`
        * ``lam`` (nt, 6): multipliers, convention ``M q'' = f - G^T lam``
        * ``nfev``: number of right-hand-side evaluations

    Raises
    ------
    RuntimeError
        If the integrator fails.
    """
    from femb.benchmarks.references.dense import integrate

    t_eval = np.atleast_1d(np.asarray(t_eval, dtype=float))
    y0 = Y0.copy() if y0 is None else np.asarray(y0, dtype=float)

    def rhs(_t, y):
        qdd, _ = accelerations(y[:7], y[7:])
        return np.concatenate([y[7:], qdd])

    Y, nfev = integrate(rhs, y0, t_eval, key=("andrews", y0.tobytes()) if cache else None, rtol=rtol, atol=atol,
                        method=method)
    acc = np.empty((t_eval.size, 7))
    lam = np.empty((t_eval.size, 6))
    for i, y in enumerate(Y):
        acc[i], lam[i] = accelerations(y[:7], y[7:])
    return {"t": t_eval, "angles": Y[:, :7].copy(), "rates": Y[:, 7:].copy(),
            "accelerations": acc, "lam": lam, "nfev": nfev}

"""Slider-crank with a flexible connecting rod, crank driven at constant speed.

A rigid crank (length L1) turns about a ground hinge at the origin at the
constant angular velocity ω, prescribed by a rheonomic
:class:`~femb.elements.DrivenAngle` together with the crank's
:class:`~femb.elements.Hinge`. The connecting rod (length L2) is a
geometrically exact beam (:mod:`femb.elements.beam`), hinged to the crank
pin and to a slider that moves along the x axis (a point mass on a
:class:`~femb.elements.PointOnLine`). No gravity.

Data (SI) in the spirit of the classic flexible slider-crank problems
(crank 0.152 m, rod 0.304 m, 150 rad/s; e.g. Jonker 1990, Escalona,
Hussien & Shabana 1998) with a steel rod of circular section, diameter 6 mm;
the values are this scene's own, see ``DATA``.

Initial state: crank angle 0 (top dead centre, rod along x), the whole
mechanism moving as a rigid slider-crank at crank speed ω: crank pin velocity
ω L1 ey, rod angular velocity −ω L1/L2, slider at rest. The rod starts
undeformed, so its bending vibration is excited by the sudden inertial load.

Output: the transverse deflection of the rod midpoint relative to the chord
of its ends (``midspan_deflection``, positive to the left of the chord from
crank pin to slider), the slider position and the driving torque.

References
----------
J. B. Jonker, A finite element dynamic analysis of flexible spatial
mechanisms and manipulators, Comput. Methods Appl. Mech. Eng. 76 (1989).

J. L. Escalona, H. A. Hussien, A. A. Shabana, Application of the absolute
nodal co-ordinate formulation to multibody system dynamics, J. Sound Vib.
214 (1998) 833–851.
"""
from __future__ import annotations

import argparse

import numpy as np

from femb.benchmarks.scenes.beams import studies

from femb import Mechanism
from femb.base.functions import Linear
from femb.elements import DrivenAngle, Hinge, PointMass, PointOnLine, RigidBody, Section, add_beam

#: Scene data (SI units)
DATA = dict(L1=0.152, L2=0.304, omega=150.0, crank_mass=0.5, E=2.0e11, nu=0.3, density=7850.0,
            diameter=6e-3, slider_mass=0.05, damping=1e-5, t_end=0.05)

#: default step of the scene (s)
H = 2e-5

#: Run settings of the benchmark (scene protocol, :mod:`femb.study.registry`).
DEFAULTS = {"t_end": DATA["t_end"], "h": H, "rho_inf": 0.7}

#: Parameters of :func:`build`: name -> (meaning, unit), shown by ``femb list``.
PARAMETERS = {
    "n_elements": ("beam elements of the connecting rod", "-"),
    "omega": ("prescribed crank angular velocity", "rad/s"),
    "damping": ("stiffness-proportional material damping eta of the rod", "s"),
    "mass": ("beam mass matrix, 'consistent' or 'lumped'", "-"),
}

#: Outputs of :func:`outputs`: name -> (meaning, unit), shown by ``femb list``.
OUTPUTS = {
    "midspan_deflection": ("deflection of the rod midpoint from the chord of its ends (left positive)", "m"),
    "tip_deflection": ("same as midspan_deflection (name shared with the other beam scenes)", "m"),
    "slider_x": ("slider position", "m"),
    "crank_angle": ("crank angle", "rad"),
    "drive_torque": ("torque the driver applies to the crank", "N m"),
    "R_slider_x": ("x force of the rod on the slider pin", "N"),
    "R_slider_y": ("y force of the rod on the slider pin", "N"),
}

#: h-convergence study: outputs of :func:`outputs` at t = 0.01 s.
CONVERGENCE = {"t_end": 0.01, "h": [8e-5, 4e-5, 2e-5, 1e-5],
               "q": ["midspan_deflection", "slider_x"], "lambda": ["drive_torque", "R_slider_x", "R_slider_y"]}

def newton_options(n_elements):
    """Solver options for a mesh of n elements: none.

    The solver's default Newton test judges the corrections in q and in
    acceleration units with a round-off floor, so stiff beams nearly at rest
    converge without a force floor (the former ``atol`` override is gone).
    Kept so that studies can pass scene-specific options uniformly.
    """
    return {}


def section(damping=0.0):
    """The rod's circular steel section."""
    D = DATA
    return Section.circle(D["E"], D["E"] / (2.0 * (1.0 + D["nu"])), D["diameter"], D["density"],
                          damping=damping)


def build(n_elements=8, *, omega=DATA["omega"], damping=DATA["damping"], mass="consistent"):
    """The flexible slider-crank.

    Parameters
    ----------
    n_elements : int
        Beam elements of the connecting rod.
    omega : float
        Crank angular velocity (rad/s).
    damping : float
        Stiffness-proportional material damping η of the rod (s).
    mass : {"consistent", "lumped"}

    Returns
    -------
    Mechanism
        Bodies ``crank``, ``slider``; rod nodes ``rod.n0`` … ``rod.n{n}``;
        joints ``O`` (crank hinge), ``rod.start`` (crank pin), ``rod.end``
        (slider pin), ``guide`` (slider on the x axis); driver ``drive``.
    """
    D = DATA
    L1, L2 = D["L1"], D["L2"]
    mech = Mechanism("flexible_slider_crank")
    crank = mech.add(RigidBody("crank", D["crank_mass"], D["crank_mass"] * L1 ** 2 / 12.0,
                               position=(0.5 * L1, 0.0), velocity=(0.0, 0.5 * omega * L1), omega=omega,
                               points={"O": (-0.5 * L1, 0.0), "A": (0.5 * L1, 0.0)},
                               shape={"type": "bar", "width": 0.01}))
    slider = mech.add(PointMass("slider", D["slider_mass"], position=(L1 + L2, 0.0)))
    mech.add(Hinge("O", mech.ground, crank, at=(0.0, 0.0)))
    mech.add(DrivenAngle("drive", mech.ground, crank, Linear(omega)))
    mech.add(PointOnLine("guide", mech.ground, slider, axis=(1.0, 0.0)))

    def rigid_velocity(xy, theta):
        # rigid slider-crank at crank angle 0: v(s) = ω L1 (1 − s/L2) ey, rod rate −ω L1/L2
        s = xy[:, 0] - L1
        v = np.zeros((xy.shape[0], 3))
        v[:, 1] = omega * L1 * (1.0 - s / L2)
        v[:, 2] = -omega * L1 / L2
        return v

    add_beam(mech, "rod", section(damping), (crank, "A"), slider, n_elements, start_joint="hinge",
             end_joint="hinge", mass=mass, velocities=rigid_velocity)
    return mech


def _rod_nodes(model):
    names = [nm for nm in model.node_index if nm.startswith("rod.n")]
    return sorted(names, key=lambda s: int(s[5:]))


def midspan_deflection(result):
    """Transverse deflection of the rod midpoint from the chord of its ends, shape (nt,).

    The midpoint is the point at half the reference arc length, interpolated
    linearly between the nodes around it.
    """
    names = _rod_nodes(result.model)
    n = len(names) - 1
    X = np.stack([result.body(nm)[:, :2] for nm in names], axis=1)      # (nt, n+1, 2)
    k = n // 2
    mid = X[:, k] if n % 2 == 0 else 0.5 * (X[:, k] + X[:, k + 1])
    A, B = X[:, 0], X[:, -1]
    e = (B - A) / np.linalg.norm(B - A, axis=1)[:, None]
    d = mid - A
    return e[:, 0] * d[:, 1] - e[:, 1] * d[:, 0]


def outputs(result):
    """Named outputs over the stored time steps (scene protocol of :mod:`femb.study.registry`).

    Returns
    -------
    dict of str to ndarray, each of shape (nt,)
        ``midspan_deflection`` (m), also as ``tip_deflection`` (the name shared
        with the other beam scenes); ``slider_x`` (m); ``crank_angle`` (rad);
        ``drive_torque``: torque the driver applies to the crank (N m; minus
        the DrivenAngle multiplier); ``R_slider_x``,
        ``R_slider_y``: force of the rod on the slider pin (N).
        :func:`final_outputs` gives the values at the final time.
    """
    w = midspan_deflection(result)
    R = result.reaction("rod.end")          # hinge a = slider, b = rod end: force on the rod
    return {"midspan_deflection": w, "tip_deflection": w, "slider_x": result.body("slider")[:, 0],
            "crank_angle": result.body("crank")[:, 2], "drive_torque": -result.reaction("drive")[:, 0],
            "R_slider_x": -R[:, 0], "R_slider_y": -R[:, 1]}


def final_outputs(result):
    """:func:`outputs` at the final time, as floats."""
    return {k: float(v[-1]) for k, v in outputs(result).items()}


def time_convergence(n_elements=4, t_end=0.01, hs=(8e-5, 4e-5, 2e-5, 1e-5), h_ref=1.25e-6, rho_inf=0.7, **kw):
    """Global errors at t_end against a run with h_ref: dict with ``h``, ``err_q``, ``err_lam``, orders."""
    return studies.time_convergence(build, newton_options, n_elements, t_end, hs, h_ref, rho_inf, **kw)


def mesh_convergence(ns=(2, 4, 8, 16), t_end=DATA["t_end"], h=H, rho_inf=0.7, **kw):
    """Midspan deflection at t_end for each mesh and the observed orders.

    Returns a dict with ``n``, ``midspan_deflection``, ``diff`` (``|w_{k+1} − w_k|``)
    and ``orders`` log₂(diff_k / diff_{k+1}) for meshes refined by 2.
    """
    res = studies.mesh_convergence(build, newton_options, lambda r: final_outputs(r)["midspan_deflection"],
                                   ns, t_end, h, rho_inf, **kw)
    res["midspan_deflection"] = res.pop("value")
    return res


def main(argv=None):
    import femb

    ap = argparse.ArgumentParser(description="Flexible slider-crank (rigid crank, beam rod, slider)")
    ap.add_argument("--n", type=int, default=8, help="rod elements")
    ap.add_argument("--h", type=float, default=H)
    ap.add_argument("--t-end", type=float, default=DATA["t_end"])
    ap.add_argument("--convergence", action="store_true", help="also run the h and mesh studies")
    a = ap.parse_args(argv)
    r = femb.simulate(build(a.n).compile(), a.t_end, a.h, rho_inf=0.7, **newton_options(a.n))
    w = midspan_deflection(r)
    print(f"flexible slider-crank, n = {a.n}, h = {a.h:g} s, t = {r.t[-1]:g} s, {r.wall_time:.2f} s wall")
    for k in range(0, len(r.t), max(1, len(r.t) // 20)):
        print(f"  t = {r.t[k]:.4f} s  crank {r.body('crank')[k, 2]:7.3f} rad  midspan {w[k]: .4e} m")
    for k, v in final_outputs(r).items():
        print(f"  {k} = {v:.6g}")
    if a.convergence:
        c = time_convergence()
        print("time convergence (n = 4, t = 0.01 s, rho_inf = 0.7): h, err_q, err_lam")
        for row in zip(c["h"], c["err_q"], c["err_lam"]):
            print("  %.4g  %.3e  %.3e" % row)
        print(f"  orders: q {c['order_q']:.2f}, lambda {c['order_lam']:.2f}")
        m = mesh_convergence()
        print(f"mesh convergence (t = {DATA['t_end']} s, h = {H}): n, midspan deflection, |change|, order")
        for i, (n, w) in enumerate(zip(m["n"], m["midspan_deflection"])):
            d = f"{m['diff'][i - 1]:.3e}" if i else ""
            o = f"{m['orders'][i - 2]:.2f}" if i >= 2 else ""
            print(f"  {n:3d}  {w: .6e}  {d:>10s}  {o}")


if __name__ == "__main__":
    main()

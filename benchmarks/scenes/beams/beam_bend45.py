"""45° bend under an out-of-plane tip force (Bathe & Bolourchi 1979), static, SE(3) beams.

Arc of radius R = 100 and 45° in the x–y plane, root at the origin with tangent +y,
centre (100, 0, 0), tip at (29.29, 70.71, 0); A = 1, I₂ = I₃ = 1/12, E = 1e7, ν = 0
(G = E/2), polar J = 1/6 (as GXBeam, BeamDyn and Kynema; St-Venant would be 0.141),
shear factor 1; clamped root, dead tip force F e_z up to F = 600, solved statically
by load steps. Data: ``docs/beams.md``, "Spatial beam scenes".

References (tip, F = 600)
-------------------------
* GXBeam's test (byuflowlab/GXBeam.jl:test/examples/curved.jl; 16 elements, J = 1/6,
  k = 1): displacement (−13.577, −23.545, 53.458).
* Bathe & Bolourchi 1979 (as quoted in OpenFAST/r-test:modules/beamdyn/bd_curved_beam/README.md
  and in the GXBeam test): displacement (−13.4, −23.5, 53.4).
* Simo & Vu-Quoc 1986, Part II (tip *positions*, 8 elements; values as quoted in
  spatial.md §7.4): F = 300 (22.33, 58.84, 40.08), F = 450 (18.62, 52.32, 48.39),
  F = 600 (15.79, 47.23, 53.37).
* Check, independent of femb: the continuum rod (:func:`continuum`, the Cosserat rod
  equations solved by shooting with scipy, ``benchmarks/references/cosserat_rod.py``):
  (−13.60452, −23.56024, 53.47486) for k = 1. femb's meshes converge to it at order 2
  (16 elements: 4.8e-4, 8.6e-4, 6.6e-4 of each component); GXBeam's 16-element value
  differs from it by 2.0e-3, 6.5e-4, 3.2e-4 (its own discretization error).

K. J. Bathe, S. Bolourchi, Large displacement analysis of three-dimensional beam
structures, Int. J. Numer. Methods Eng. 14:961–986, 1979.
J. C. Simo, L. Vu-Quoc, A three-dimensional finite-strain rod model. Part II,
Comput. Methods Appl. Mech. Eng. 58:79–116, 1986.
"""
from __future__ import annotations

import argparse
import math

import numpy as np

from femb import Mechanism
from femb.elements.spatial_beam import SpatialSection, spatial_beam
from femb.elements.spatial_forces import SpatialForce

DATA = dict(R=100.0, E=1e7, A=1.0, I=1.0 / 12.0, J=1.0 / 6.0, k=1.0, F=600.0)
TIP0 = np.array([100.0 - 100.0 / math.sqrt(2.0), 100.0 / math.sqrt(2.0), 0.0])
#: load factors of the published tables (F = 60 … 600)
LOAD_FACTORS = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.75, 0.9, 1.0]

#: GXBeam's tip displacement at F = 600 (16 elements, J = 1/6, k = 1)
GXBEAM = np.array([-13.577, -23.545, 53.458])
#: Bathe & Bolourchi (1979) tip displacement at F = 600 (3 digits)
BATHE = np.array([-13.4, -23.5, 53.4])
#: Simo & Vu-Quoc (1986) tip positions by load
SIMO_VU_QUOC = {300.0: np.array([22.33, 58.84, 40.08]), 450.0: np.array([18.62, 52.32, 48.39]),
                600.0: np.array([15.79, 47.23, 53.37])}

#: Static scene: t_end is the final load factor (femb run solves statically).
DEFAULTS = {"t_end": 1.0, "h": 0.1, "rho_inf": 0.7}
ANALYSIS = "static"

PARAMETERS = {"n_elements": ("beam elements", "-")}

OUTPUTS = {"u_x": ("tip displacement x", "m"), "u_y": ("tip displacement y", "m"),
           "u_z": ("tip displacement z", "m"), "F": ("tip force", "N")}


def section():
    """The section: EA, GA (k = 1, ν = 0), GJ (J = 1/6), EI₂ = EI₃."""
    D = DATA
    E, G = D["E"], D["E"] / 2.0
    return SpatialSection.from_properties(E * D["A"], D["k"] * G * D["A"], D["k"] * G * D["A"], G * D["J"],
                                          E * D["I"], E * D["I"], rhoA=1.0, rhoJ=(1 / 6, 1 / 12, 1 / 12))


def build(n_elements=16):
    """The bend ``beam`` (nodes ``beam.n0`` clamped … ``beam.n{n}``) with tip force ``F`` = (0, 0, 600)."""
    R = DATA["R"]

    def path(s):
        a = s * math.pi / 4.0
        return np.array([R - R * math.cos(a), R * math.sin(a), 0.0])

    def frames(s):                        # exact tangent frames of the arc (e3 = z)
        a = s * math.pi / 4.0
        return np.column_stack(((math.sin(a), math.cos(a), 0.0), (-math.cos(a), math.sin(a), 0.0),
                                (0.0, 0.0, 1.0)))

    m = Mechanism("beam_bend45")
    b = spatial_beam(m, "beam", section(), path, int(n_elements), frames=frames, start="clamp")
    m.add(SpatialForce("F", b.nodes[-1], (0.0, 0.0, DATA["F"])))
    return m


def solve(model, **_):
    """Static solution at the load factors :data:`LOAD_FACTORS` (a StaticResult, t = load factors)."""
    from femb.analysis.static import solve_static
    return solve_static(model, load_factors=LOAD_FACTORS)


def _tip(model):
    return max((nm for nm in model.node_index if nm.startswith("beam.n")), key=lambda s: int(s[6:]))


def outputs(result):
    """Tip displacement (u_x, u_y, u_z) and the force F = 600 μ per load level (nt,)."""
    x = result.model.node_coordinates(_tip(result.model), result.q)[:, 0:3] - TIP0
    return {"u_x": x[:, 0], "u_y": x[:, 1], "u_z": x[:, 2], "F": DATA["F"] * np.asarray(result.t)}


def reference(t, **params):
    """GXBeam's tip displacement at F = 600 (t = 1 only; NaN at other load factors)."""
    t = np.atleast_1d(np.asarray(t, dtype=float))
    out = {k: np.where(t == 1.0, GXBEAM[i], np.nan) for i, k in enumerate(("u_x", "u_y", "u_z"))}
    out["F"] = DATA["F"] * t
    out["description"] = ("GXBeam test (byuflowlab/GXBeam.jl:test/examples/curved.jl), 16 elements, "
                          "J = 1/6, k = 1: tip displacement at F = 600")
    return out


def continuum(F=None):
    """Tip displacement of the continuum rod at force F (default ``DATA["F"]``), (3,).

    The independent check of :mod:`femb.benchmarks.references.cosserat_rod` (shooting on
    the Cosserat rod equations with scipy) for the section of :func:`section`, the arc's
    initial curvature κ₀ = (0, 0, −1/R) and root frame (e₁ = +y, e₂ = −x, e₃ = z).
    """
    from femb.benchmarks.references.cosserat_rod import clamped_rod
    R = DATA["R"]
    F = DATA["F"] if F is None else F
    R0 = np.column_stack(((0.0, 1.0, 0.0), (-1.0, 0.0, 0.0), (0.0, 0.0, 1.0)))
    out = clamped_rod(section().C, R * math.pi / 4.0, R0, (0.0, 0.0, -1.0 / R), (0.0, 0.0, F))
    return out["x"] - TIP0


def refinement(ns=(4, 8, 16, 32, 64, 128)):
    """Mesh-refinement study of the tip displacement at F = 600.

    Returns
    -------
    dict
        ``n`` (k,), ``u`` (k, 3) tip displacements, ``diff`` (k − 1,) |u_{i+1} − u_i|,
        ``orders`` (k − 2,) log₂(diff_i / diff_{i+1}).
    """
    us = []
    for n in ns:
        model = build(n).compile()
        r = solve(model)
        o = outputs(r)
        us.append([o["u_x"][-1], o["u_y"][-1], o["u_z"][-1]])
    us = np.array(us)
    diff = np.linalg.norm(np.diff(us, axis=0), axis=1)
    return {"n": list(ns), "u": us, "diff": diff, "orders": np.log2(diff[:-1] / diff[1:])}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="*", default=[4, 8, 16, 32, 64, 128])
    a = ap.parse_args(argv)
    st = refinement(a.n)
    uc = continuum()
    print(f"continuum rod (shooting, scipy): ({uc[0]:.5f}, {uc[1]:.5f}, {uc[2]:.5f}); "
          f"GXBeam (16 el.) relative to it: " + ", ".join(f"{e:.1e}" for e in np.abs(GXBEAM / uc - 1.0)))
    print("n     tip displacement at F = 600             |change|    order   |u - GXBeam|  "
          "max relative error per component against the continuum rod")
    for i, n in enumerate(st["n"]):
        u = st["u"][i]
        d = f"{st['diff'][i - 1]:.3e}" if i else ""
        o = f"{st['orders'][i - 2]:.2f}" if i >= 2 else ""
        print(f"{n:4d}  ({u[0]: .4f}, {u[1]: .4f}, {u[2]: .4f})  {d:>10s}  {o:>5s}   "
              f"{np.linalg.norm(u - GXBEAM):.3e}     {np.abs(u / uc - 1.0).max():.2e}")
    model = build(8).compile()
    r = solve(model)
    o = outputs(r)
    print("Simo & Vu-Quoc (8 elements), tip position:")
    for F, ref in SIMO_VU_QUOC.items():
        k = int(np.argmin(np.abs(o["F"] - F)))
        x = TIP0 + np.array([o["u_x"][k], o["u_y"][k], o["u_z"][k]])
        print(f"  F = {F:5.0f}: femb ({x[0]:.2f}, {x[1]:.2f}, {x[2]:.2f})  paper ({ref[0]}, {ref[1]}, {ref[2]})")


if __name__ == "__main__":
    main()

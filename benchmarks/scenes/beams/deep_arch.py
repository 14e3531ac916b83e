"""Deep clamped–hinged circular arch under a crown load: limit point by arc length (static, SE(3) beams).

A circular arch of radius R = 100 opening 215° (ends at ±107.5° from the crown, 17.5°
below the centre), clamped at its left end and hinged at its right end (a
:class:`~femb.elements.spatial_joints.RevoluteJoint` to the ground about z), carries a
downward dead load P = μ P_ref at the crown. Its equilibrium path has a limit point
(snap-through) at P_cr = 8.97 EI/R² (DaDeppo & Schmidt 1975, inextensible elastica; 897
for EI = 10⁶, R = 100, the figure quoted by Ibrahimbegović 1995 and reached there within
0.03 % by curved elements with EA = GA = 10⁸). Load stepping fails there; :func:`solve`
follows the path by arc length (:func:`femb.analysis.static.solve_static` with
``method="arc_length"``) just past the maximum of the load, and the limit load is
refined between the stored points by :meth:`~femb.analysis.static.StaticResult.limit_load_factors`.

Section: EI = 10⁶ (in plane), EA = GA = 10⁸ (Ibrahimbegović 1995); out of plane
EI₂ = GJ = 10⁸ (the planar problem: no lateral buckling). The SE(3) element holds the
circular reference exactly (constant curvature); its limit load converges from above with
order 2 in the element length.

``femb run deep_arch`` prints the path's last level and the limit load;
``python -m femb.benchmarks.scenes.beams.deep_arch`` the mesh convergence against the reference.

References
----------
D. A. DaDeppo, R. Schmidt, Instability of clamped-hinged circular arches subjected to a
point load, J. Appl. Mech. 42 (1975) 894–896.

A. Ibrahimbegović, On finite element implementation of geometrically nonlinear Reissner's
beam theory: three-dimensional curved beam elements, Comput. Methods Appl. Mech. Eng. 122
(1995) 11–26 (Example 2: 897 with 20 three-node curved elements, 906 with straight ones).

J. C. Simo, L. Vu-Quoc, A three-dimensional finite-strain rod model. Part II: Computational
aspects, Comput. Methods Appl. Mech. Eng. 58 (1986) 79–116 (the same arch).
"""
from __future__ import annotations

import argparse
import math
import time

import numpy as np

from femb import Mechanism
from femb.elements.spatial_beam import SpatialSection, spatial_beam
from femb.elements.spatial_forces import SpatialForce
from femb.elements.spatial_joints import RevoluteJoint

DATA = dict(R=100.0, opening=215.0, EI=1e6, EA=1e8, GA=1e8, EI_out=1e8, GJ=1e8)

#: limit load P_cr R²/EI of DaDeppo & Schmidt (1975)
P_CR = 8.97

#: reference load P_ref (N): μ = P / P_ref; 10 EI/R², so the limit point is near μ = 0.9
P_REF = 10.0 * DATA["EI"] / DATA["R"] ** 2

#: Static scene (femb run follows the path by arc length; t_end and h are not used).
DEFAULTS = {"t_end": 1.0, "h": 0.05, "rho_inf": 0.7}
ANALYSIS = "static"

PARAMETERS = {
    "n_elements": ("beam elements (even: a node at the crown)", "-"),
    "arc_length": ("first arc length of the continuation (scaled norm of solve_static; default: "
                   "the tangent step to dmu = 0.05)", "-"),
}

OUTPUTS = {
    "load": ("crown load P R²/EI at each stored level", "-"),
    "crown_u": ("horizontal displacement of the crown over R", "-"),
    "crown_v": ("vertical displacement of the crown over R (down negative)", "-"),
    "limit_load": ("limit load P_cr R²/EI, refined between the stored levels (same value at every level)", "-"),
}


def _half():
    return math.radians(DATA["opening"]) / 2.0


def point(s):
    """Centre line at s ∈ [0, 1] (left clamped end to right hinged end), (3,)."""
    phi = -_half() + 2.0 * _half() * s
    return np.array([DATA["R"] * math.sin(phi), DATA["R"] * math.cos(phi), 0.0])


def build(n_elements=40, *, arc_length=None):
    """The arch ``arch`` (nodes ``arch.n0`` clamped … ``arch.n{n}`` hinged), crown load ``P`` = P_ref
    downwards at node ``arch.n{n/2}`` (``arc_length`` is used by :func:`solve`)."""
    n = int(n_elements)
    if n < 4 or n % 2:
        raise ValueError(f"deep_arch: n_elements must be even and ≥ 4 (a node at the crown), got {n_elements!r}")
    D = DATA
    sec = SpatialSection.from_properties(D["EA"], D["GA"], D["GA"], D["GJ"], D["EI_out"], D["EI"],
                                         rhoA=1.0, rhoJ=(1.0, 1.0, 1.0))   # section axis 3 = z: in-plane EI3
    m = Mechanism("deep_arch")
    b = spatial_beam(m, "arch", sec, point, n, start="clamp")
    m.add(RevoluteJoint("hinge", "ground", b.nodes[-1], at=point(1.0), axis=(0.0, 0.0, 1.0)))
    m.add(SpatialForce("P", b.nodes[n // 2], (0.0, -P_REF, 0.0)))
    return m


def solve(model, *, arc_length=None, **_):
    """Arc-length continuation from μ = 0 to just past the limit point (a StaticResult; t = μ)."""
    from femb.analysis.static import solve_static
    return solve_static(model, method="arc_length", target_load_factor=None, max_limit_points=1,
                        arc_length=None if arc_length is None else float(arc_length))


def _crown(model):
    nodes = sorted((nm for nm in model.node_index if nm.startswith("arch.n")), key=lambda s: int(s[6:]))
    return nodes[len(nodes) // 2]


def outputs(result):
    """Load, crown displacement and the refined limit load per stored level (nt,)."""
    m = result.model
    x = m.node_coordinates(_crown(m), result.q)[:, 0:3] - point(0.5)
    lim = result.limit_load_factors()
    scale = P_REF * DATA["R"] ** 2 / DATA["EI"]
    nt = len(result.t)
    return {"load": np.asarray(result.t) * scale, "crown_u": x[:, 0] / DATA["R"], "crown_v": x[:, 1] / DATA["R"],
            "limit_load": np.full(nt, lim[0] * scale if len(lim) else np.nan)}


def reference(t, **params):
    """DaDeppo & Schmidt (1975): P_cr R²/EI = 8.97 (the limit load only; NaN for the path)."""
    t = np.atleast_1d(np.asarray(t, dtype=float))
    nan = np.full(len(t), np.nan)
    return {"load": nan, "crown_u": nan, "crown_v": nan, "limit_load": np.full(len(t), P_CR),
            "description": "DaDeppo & Schmidt 1975: limit load P_cr = 8.97 EI/R^2 (897 for EI = 1e6, R = 100)"}


def refinement(ns=(10, 20, 40, 80, 160)):
    """Mesh convergence of the limit load.

    Returns
    -------
    dict
        ``n`` (k,), ``P`` (k,) limit loads P_cr R²/EI, ``steps`` (k,) stored levels, ``time`` (k,) s,
        ``orders`` (k − 2,) log₂ of the ratio of successive changes, ``extrapolated`` (Richardson,
        order 2, from the two finest meshes).
    """
    P, steps, times = [], [], []
    for n in ns:
        model = build(n).compile()
        t0 = time.perf_counter()
        r = solve(model)
        times.append(time.perf_counter() - t0)
        P.append(outputs(r)["limit_load"][-1])
        steps.append(len(r.t))
    P = np.array(P)
    d = np.diff(P)
    orders = np.log2(d[:-1] / d[1:]) if len(P) > 2 else np.zeros(0)
    return {"n": list(ns), "P": P, "steps": steps, "time": times, "orders": orders,
            "extrapolated": P[-1] + (P[-1] - P[-2]) / 3.0 if len(P) > 1 else np.nan}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="*", default=[10, 20, 40, 80, 160])
    a = ap.parse_args(argv)
    st = refinement(a.n)
    print(f"deep arch, limit load P_cr R^2/EI (reference {P_CR}, DaDeppo & Schmidt 1975)")
    print("   n   P_cr R^2/EI   P_cr/8.97 - 1   order   levels   time (s)")
    for i, n in enumerate(st["n"]):
        o = f"{st['orders'][i - 2]:.2f}" if i >= 2 else ""
        print(f"{n:4d}   {st['P'][i]:.5f}      {st['P'][i] / P_CR - 1: .2e}    {o:>5s}   {st['steps'][i]:5d}"
              f"    {st['time'][i]:.2f}")
    print(f"Richardson (order 2, two finest): {st['extrapolated']:.5f} ({st['extrapolated'] / P_CR - 1: .2e})")


if __name__ == "__main__":
    main()

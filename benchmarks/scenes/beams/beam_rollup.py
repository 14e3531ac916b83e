"""Roll-up of a cantilever into a full circle under an end moment 2πEI/L (static, SE(3) beams).

A straight cantilever of length L, clamped at the origin along x, carries a
follower-free (dead) end torque M = μ 2πEI/L about z. Pure bending with a
constant moment gives constant curvature κ = M/EI: the exact centre line is
the circular arc x(s) = (sin κs/κ, (1 − cos κs)/κ, 0), which closes into a full
circle at μ = 1 (Simo & Vu-Quoc 1986, Part II, Sect. 7.1; the classical roll-up test).

The SE(3) element represents a constant-curvature configuration exactly
(``elements/spatial_beam.py``), so every node lies on the exact arc to round-off
for *any* number of elements, at every load level. One element cannot rotate
its end past π relative to its start (the SO(3) logarithm is taken on the principal
branch), so the full circle needs n ≥ 3.

``femb run beam_rollup`` solves the load steps statically
(:func:`femb.analysis.static.solve_static`); the reference is the exact arc.

References
----------
J. C. Simo, L. Vu-Quoc, A three-dimensional finite-strain rod model. Part II:
Computational aspects, Comput. Methods Appl. Mech. Eng. 58:79–116, 1986.
"""
from __future__ import annotations

import argparse
import math

import numpy as np

from femb import Mechanism
from femb.elements.spatial_beam import SpatialSection, spatial_beam
from femb.elements.spatial_forces import SpatialTorque

DATA = dict(L=10.0, EA=1e4, GA=1e4, GJ=1e2, EI=1e2)

#: Static scene: t_end is the final load factor, h the load increment (femb run solves statically).
DEFAULTS = {"t_end": 1.0, "h": 0.05, "rho_inf": 0.7}
ANALYSIS = "static"

PARAMETERS = {
    "n_elements": ("beam elements (≥ 3 for the full circle)", "-"),
    "load_steps": ("equal load increments up to M = 2πEI/L", "-"),
}

OUTPUTS = {
    "tip_x": ("tip x", "m"), "tip_y": ("tip y", "m"), "tip_z": ("tip z", "m"),
    "max_node_error": ("largest distance of a node from the exact arc", "m"),
}


def build(n_elements=10, *, load_steps=20):
    """Cantilever ``beam`` (nodes ``beam.n0`` clamped … ``beam.n{n}``) with end torque ``M``
    (``load_steps`` is used by :func:`solve`)."""
    D = DATA
    if int(n_elements) < 3:
        raise ValueError("beam_rollup: n_elements must be ≥ 3 (one element cannot turn past π)")
    m = Mechanism("beam_rollup")
    sec = SpatialSection.from_properties(D["EA"], D["GA"], D["GA"], D["GJ"], D["EI"], D["EI"],
                                         rhoA=1.0, rhoJ=(1e-3, 1e-3, 1e-3))
    b = spatial_beam(m, "beam", sec, [(0, 0, 0), (D["L"], 0, 0)], int(n_elements), start="clamp")
    m.add(SpatialTorque("M", b.nodes[-1], (0.0, 0.0, 2.0 * math.pi * D["EI"] / D["L"])))
    return m


def solve(model, *, load_steps=20, **_):
    """Static solution in ``load_steps`` equal increments (a :class:`~femb.analysis.static.StaticResult`;
    its ``t`` are the load factors μ)."""
    from femb.analysis.static import solve_static
    return solve_static(model, load_steps=int(load_steps))


def exact_arc(mu, s):
    """Exact centre line at load factor μ for arc lengths s (k,): (k, 3)."""
    s = np.asarray(s, dtype=float)
    kap = mu * 2.0 * math.pi / DATA["L"]
    if kap == 0.0:
        return np.column_stack((s, 0 * s, 0 * s))
    return np.column_stack((np.sin(kap * s) / kap, (1.0 - np.cos(kap * s)) / kap, 0 * s))


def _nodes(model):
    return sorted((nm for nm in model.node_index if nm.startswith("beam.n")), key=lambda s: int(s[6:]))


def outputs(result):
    """Tip position and the largest node distance from the exact arc, per load level (nt,)."""
    m = result.model
    names = _nodes(m)
    X = np.stack([m.node_coordinates(nm, result.q)[:, 0:3] for nm in names], axis=1)   # (nt, n+1, 3)
    s = np.linspace(0.0, DATA["L"], len(names))
    err = np.array([np.linalg.norm(X[k] - exact_arc(mu, s), axis=1).max() for k, mu in enumerate(result.t)])
    return {"tip_x": X[:, -1, 0], "tip_y": X[:, -1, 1], "tip_z": X[:, -1, 2], "max_node_error": err}


def reference(t, **params):
    """The exact arc's tip at load factors t."""
    tip = np.array([exact_arc(mu, [DATA["L"]])[0] for mu in np.atleast_1d(t)])
    return {"tip_x": tip[:, 0], "tip_y": tip[:, 1], "tip_z": tip[:, 2],
            "max_node_error": np.zeros(len(tip)),
            "description": "exact circular arc of pure bending, kappa = M/EI (closed form)"}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="*", default=[3, 4, 5, 10, 20, 40])
    a = ap.parse_args(argv)
    L = DATA["L"]
    print("n   load steps   max |node - exact arc| / L over all levels   tip at mu = 1")
    for n in a.n:
        model = build(n).compile()
        r = solve(model, load_steps=max(4, 2 * n))
        out = outputs(r)
        print(f"{n:3d}  {len(r.t) - 1:4d}        {out['max_node_error'].max() / L:.2e}"
              f"                          ({out['tip_x'][-1]: .2e}, {out['tip_y'][-1]: .2e}, {out['tip_z'][-1]: .2e})")


if __name__ == "__main__":
    main()

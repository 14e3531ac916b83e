"""Argyris' right-angle frame: lateral (flexural–torsional) buckling, P_cr = 1.088 N (SE(3) beams).

Two arms of 0.24 m, a strip 30 × 0.6 mm (the wide side in the frame's plane), E = 71.24 GPa,
ν = 0.31, torsion constant J = h w³/3, shear factors 1; clamped at one end, in-plane
tip force P along the first arm. Linearized buckling (:func:`femb.analysis.modal.buckling_analysis`)
about the unloaded frame; the critical load of Argyris et al. (1979) is 1.088 N. Data as
jgerstmayr/EXUDYN:main/pythonDev/TestModels/rightAngleFrame.py (Nachbagauer & Gerstmayr 2013).

References
----------
J. H. Argyris, O. Hilpert, G. A. Malejannakis, D. W. Scharpf, On the geometrical stiffness
of a beam in space — a consistent v.w. approach, Comput. Methods Appl. Mech. Eng.
20:105–131, 1979.
K. Nachbagauer, J. Gerstmayr, Structural and continuum mechanics approaches for a 3D shear
deformable ANCF beam finite element, J. Comput. Nonlinear Dynam. 9:011013, 2013.
"""
from __future__ import annotations

import argparse

import numpy as np

from femb import Mechanism
from femb.elements.spatial_beam import SpatialSection, spatial_beam
from femb.elements.spatial_forces import SpatialForce

DATA = dict(L=0.24, w=0.0006, h=0.03, E=7.124e10, nu=0.31)
P_CR = 1.088

#: Buckling scene (femb run computes the critical loads; t_end and h are not used).
DEFAULTS = {"t_end": 1.0, "h": 1.0, "rho_inf": 0.7}
ANALYSIS = "buckling"

PARAMETERS = {"n_elements": ("elements per arm", "-")}

OUTPUTS = {"P_cr": ("lowest positive critical tip load", "N"),
           "mode_in_plane": ("largest in-plane (x, y) translation of the buckling mode over its largest "
                             "out-of-plane (z) one", "-")}


def build(n_elements=10):
    """The frame ``frame`` (nodes ``frame.n0`` clamped … ``frame.n{2n}``) with unit tip load ``P``."""
    D = DATA
    L, w, h, E = D["L"], D["w"], D["h"], D["E"]
    G = E / (2 * (1 + D["nu"]))
    A = w * h
    Iw, Is, J = h * w ** 3 / 12, w * h ** 3 / 12, h * w ** 3 / 3
    sec = SpatialSection.from_properties(E * A, G * A, G * A, G * J, E * Iw, E * Is)
    m = Mechanism("argyris_frame")
    b = spatial_beam(m, "frame", sec, [(0, 0, 0), (L, 0, 0), (L, -L, 0)], int(n_elements),
                     start="clamp")                                   # section axis 3 = z
    m.add(SpatialForce("P", b.nodes[-1], (1.0, 0.0, 0.0)))
    return m


def solve(model, **_):
    """Linearized buckling: a Result with one entry (t = [P_cr]) carrying ``buckling``."""
    from femb.analysis.modal import buckling_analysis
    from femb.results.result import Result
    res = buckling_analysis(model, n_modes=4)
    pos = res.factors > 0
    k = int(np.argmin(np.where(pos, res.factors, np.inf)))
    z = np.zeros((1, model.nq))
    r = Result(model, np.array([res.factors[k]]), model.q0[None, :].copy(), z, z, np.zeros((1, model.nc)),
               np.zeros(0, dtype=int))
    r.buckling = res
    r.critical_mode = res.modes[k]
    return r


def outputs(result):
    """P_cr (the unit load times the critical factor) and the mode's in-plane share, each (1,)."""
    phi = result.critical_mode
    ratio = max(np.abs(phi[0::6]).max(), np.abs(phi[1::6]).max()) / np.abs(phi[2::6]).max()
    return {"P_cr": np.asarray(result.t, dtype=float), "mode_in_plane": np.array([ratio])}


def reference(t, **params):
    """Argyris et al. (1979): P_cr = 1.088 N."""
    return {"P_cr": np.full(np.size(t), P_CR), "description": "Argyris et al. 1979, P_cr = 1.088 N"}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="*", default=[5, 10, 20, 40])
    a = ap.parse_args(argv)
    print("n per arm   P_cr (N)    P_cr/1.088 - 1")
    for n in a.n:
        r = solve(build(n).compile())
        print(f"{n:6d}     {r.t[0]:.5f}    {r.t[0] / P_CR - 1: .2e}")


if __name__ == "__main__":
    main()

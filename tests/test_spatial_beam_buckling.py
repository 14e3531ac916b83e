"""Linearized buckling of spatial beams: Argyris' right-angle frame (femb.analysis.modal.buckling_analysis).

Data as jgerstmayr/EXUDYN:main/pythonDev/TestModels/rightAngleFrame.py (Nachbagauer &
Gerstmayr 2013, J. Comput. Nonlinear Dynam. 9:011013): arms 0.24 m, strip 30 × 0.6 mm
(wide side in the frame's plane), E = 71.24 GPa, ν = 0.31, J = h w³/3, shear factors 1;
clamped at one end, in-plane tip force along the first arm; lateral (flexural–torsional)
buckling at P_cr = 1.088 N (Argyris et al. 1979).
"""
import numpy as np
import pytest

from femb import Mechanism
from femb.analysis.modal import buckling_analysis
from femb.elements.spatial_beam import SpatialSection, spatial_beam
from femb.elements.spatial_forces import SpatialForce


@pytest.mark.parametrize("n, rel", [(10, 2e-3), (20, 1e-3)])     # measured +0.10 %, −0.03 %
def test_argyris_frame(n, rel):
    L, w, h, E, nu = 0.24, 0.0006, 0.03, 7.124e10, 0.31
    G = E / (2 * (1 + nu))
    A = w * h
    Iw, Is, J = h * w ** 3 / 12, w * h ** 3 / 12, h * w ** 3 / 3
    sec = SpatialSection.from_properties(E * A, G * A, G * A, G * J, E * Iw, E * Is)
    m = Mechanism("argyris")
    b = spatial_beam(m, "frame", sec, [(0, 0, 0), (L, 0, 0), (L, -L, 0)], n, start="clamp")   # axis 3 = z
    m.add(SpatialForce("P", b.nodes[-1], (1.0, 0.0, 0.0)))
    res = buckling_analysis(m.compile(), n_modes=4)
    pos = res.factors[res.factors > 0].min()
    assert abs(pos / 1.088 - 1.0) < rel
    # the buckling mode is lateral: out-of-plane (z) translations, no in-plane ones
    k = int(np.argmin(np.where(res.factors > 0, res.factors, np.inf)))
    phi = res.modes[k]
    assert np.abs(phi[2::6]).max() > 100 * max(np.abs(phi[0::6]).max(), np.abs(phi[1::6]).max())

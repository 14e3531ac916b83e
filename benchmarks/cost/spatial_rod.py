"""The steel rod of the spatial-beam cost measurements: a cantilever of SE(3) beams under gravity.

L = 1 m, d = 20 mm, E = 210 GPa, G = 80.8 GPa, ρ = 7850 kg/m³, clamped at x = 0 along x,
released undeformed under gravity (0, 0, −9.81); fixed steps h = 1e-4 s, ρ∞ = 0.7. Shared by
:mod:`femb.benchmarks.cost.spatial_beam_scaling` (femb's cost against n) and
:mod:`femb.benchmarks.cost.spatial_beam_peer` (the same rod in Exudyn), so that neither imports the other
for it.
"""
from __future__ import annotations

DATA = dict(L=1.0, d=0.02, E=2.1e11, G=8.08e10, rho=7850.0, g=(0.0, 0.0, -9.81))
H = 1e-4
RHO_INF = 0.7


def build(n, mass="consistent"):
    """The cantilever with n SpatialBeam elements (nodes ``rod.n0`` clamped … ``rod.n{n}``)."""
    from femb import Mechanism
    from femb.elements.spatial_beam import SpatialSection, spatial_beam
    from femb.elements.spatial_forces import SpatialGravity

    D = DATA
    m = Mechanism(f"rod{n}")
    sec = SpatialSection.circle(D["E"], D["G"], D["d"], density=D["rho"])
    spatial_beam(m, "rod", sec, [(0, 0, 0), (D["L"], 0, 0)], int(n), start="clamp", mass=mass)
    m.add(SpatialGravity(D["g"]))
    return m

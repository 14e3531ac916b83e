"""Sign conventions of every constraint type's multipliers (docs/conventions.md).

Each case is a mechanism whose reaction at t = 0 follows by hand from Newton's
laws; the test checks sign and value of ``result.reaction(name)[0]`` (the
consistent initial multipliers). M q̈ = f − Φ_qᵀ λ throughout.
"""
import math

import numpy as np
import pytest

import femb
from femb.elements import (Clamp, DrivenAngle, DrivenDisplacement, Force, Gravity, Hinge, PointMass,
                           PointOnLine, RigidBody, Slider, Torque)
from femb.base.functions import Polynomial

G = 9.81


def _lam0(mech, name):
    """Multipliers of joint ``name`` at t = 0 (after consistent initialization)."""
    res = femb.simulate(mech.compile(), t_end=1e-3, h=1e-3, rho_inf=0.7)
    return res.reaction(name)[0]


# ------------------------------------------------------------------ Hinge
@pytest.mark.parametrize("ground_is_a", [True, False])
def test_hinge_lambda_is_force_on_b(ground_is_a):
    """Point mass m hanging on a hinge: the hinge holds it up with m g."""
    m = 2.0
    mech = femb.Mechanism("hang")
    p = mech.add(PointMass("p", m, (0.3, -0.2)))
    a, b = (mech.ground, p) if ground_is_a else (p, mech.ground)
    mech.add(Hinge("pin", a, b, at=(0.3, -0.2)), Gravity((0.0, -G)))
    lam = _lam0(mech, "pin")
    up = np.array([0.0, m * G])                  # force of the hinge on the mass
    np.testing.assert_allclose(lam, up if ground_is_a else -up, rtol=1e-12, atol=1e-12)


def test_hinge_bar_released_horizontal():
    """Uniform bar (m, L) pinned at one end, released horizontal: force on the bar = m g/4 up.

    α = 3 g/(2 L) (J_O = m L²/3); centre acceleration α L/2 = 3 g/4 downward;
    R − m g = −3 m g/4.
    """
    m, L = 1.5, 0.8
    mech = femb.Mechanism("bar")
    bar = mech.add(RigidBody("bar", m, m * L * L / 12.0, (0.5 * L, 0.0), points={"O": (-0.5 * L, 0.0)}))
    mech.add(Hinge("pivot", "ground", bar, point_b="O"), Gravity((0.0, -G)))
    np.testing.assert_allclose(_lam0(mech, "pivot"), [0.0, 0.25 * m * G], rtol=1e-12, atol=1e-12)


# ------------------------------------------------------------------ PointOnLine
@pytest.mark.parametrize("incline", [0.0, 0.4])
def test_point_on_line_lambda_is_minus_normal_force_on_b(incline):
    """Mass on a frictionless incline (axis at angle a): normal force m g cos a on b along
    n = (−sin a, cos a), so λ = −m g cos a."""
    m = 0.7
    axis = (math.cos(incline), math.sin(incline))
    mech = femb.Mechanism("incline")
    p = mech.add(PointMass("p", m, (0.0, 0.0)))
    mech.add(PointOnLine("track", "ground", p, axis=axis), Gravity((0.0, -G)))
    (lam,) = _lam0(mech, "track")
    assert lam == pytest.approx(-m * G * math.cos(incline), rel=1e-12)


def test_point_on_line_lambda_along_the_normal_of_a_turned_body_a():
    """Line on a body a turned by θ_a, normal n_a = R(θ_a) J ū: a force F n_a on b is balanced
    by the joint's force −λ n_a on b, so λ = F."""
    th, F, m = 0.6, 3.0, 1.0
    mech = femb.Mechanism("turned")
    base = mech.add(RigidBody("base", 5.0, 0.2, (0.0, 0.0), th))
    p = mech.add(PointMass("p", m, (0.1 * math.cos(th), 0.1 * math.sin(th))))
    n_a = (-math.sin(th), math.cos(th))
    mech.add(Clamp("weld", "ground", base), PointOnLine("track", base, p, axis=(1.0, 0.0)),
             Force("push", p, (F * n_a[0], F * n_a[1])))
    (lam,) = _lam0(mech, "track")
    assert lam == pytest.approx(F, rel=1e-12)


# ------------------------------------------------------------------ Slider
def test_slider_lambdas_normal_force_and_torque_on_b():
    """Block on a horizontal slider under gravity and a torque T: the slider pushes b up with
    m g (λ₁ = −m g, normal n = (0, 1)) and holds it with the torque −T (λ₂ = T)."""
    m, T = 1.2, 0.5
    mech = femb.Mechanism("slider")
    blk = mech.add(RigidBody("blk", m, 0.01, (0.2, 0.1)))
    mech.add(Slider("rail", "ground", blk, axis=(1.0, 0.0), at=(0.2, 0.1)), Gravity((0.0, -G)), Torque("t", blk, T))
    lam = _lam0(mech, "rail")
    np.testing.assert_allclose(lam, [-m * G, T], rtol=1e-12, atol=1e-12)


# ------------------------------------------------------------------ drivers
def test_driven_angle_lambda_is_minus_torque_on_b():
    """Body driven at angular acceleration α about its centre: the driver applies J α to b,
    so λ = −J α; with an extra torque T on b the driver applies J α − T, λ = T − J α."""
    J, alpha, T = 0.05, 4.0, 0.3
    mech = femb.Mechanism("drive")
    rot = mech.add(RigidBody("rot", 1.0, J, (0.0, 0.0)))
    mech.add(Hinge("pivot", "ground", rot), DrivenAngle("motor", "ground", rot, Polynomial([0.0, 0.0, alpha / 2])),
             Torque("t", rot, T))
    (lam,) = _lam0(mech, "motor")
    assert lam == pytest.approx(T - J * alpha, rel=1e-12)


def test_driven_displacement_lambda_is_minus_force_on_b_along_u():
    """Mass driven along a line at acceleration a: the driver pushes b with m a along u_a,
    so λ = −m a; the axis is inclined, so gravity adds its component along u."""
    m, acc, ang = 0.8, 2.5, 0.3
    u = (math.cos(ang), math.sin(ang))
    mech = femb.Mechanism("actuator")
    p = mech.add(PointMass("p", m, (0.5 * u[0], 0.5 * u[1])))
    mech.add(PointOnLine("guide", "ground", p, axis=u),
             DrivenDisplacement("act", "ground", p, Polynomial([0.0, 0.0, acc / 2]), axis=u),
             Gravity((0.0, -G)))
    (lam,) = _lam0(mech, "act")
    push = m * acc + m * G * math.sin(ang)        # driver force on b along u
    assert lam == pytest.approx(-push, rel=1e-12)


# ------------------------------------------------------------------ Clamp
def test_clamp_force_on_b_and_minus_torque_on_b():
    """Cantilever bar (m, L) clamped at its left end: the clamp holds it with m g up and the
    counter-clockwise moment m g L/2 about the clamp point, so λ = (0, m g, −m g L/2)."""
    m, L = 2.0, 0.6
    mech = femb.Mechanism("cantilever")
    bar = mech.add(RigidBody("bar", m, m * L * L / 12.0, (0.5 * L, 0.0), points={"O": (-0.5 * L, 0.0)}))
    mech.add(Clamp("root", "ground", bar, point_b="O"), Gravity((0.0, -G)))
    np.testing.assert_allclose(_lam0(mech, "root"), [0.0, m * G, -0.5 * m * G * L], rtol=1e-12, atol=1e-12)


def test_every_constraint_type_is_covered():
    """A new constraint type in femb.elements needs its convention here and in docs/conventions.md
    (planar) or in the joint table of docs/spatial.md (spatial joints)."""
    import femb.elements as el
    from femb.system.element import Element

    types = {n for n in el.__all__ if isinstance(getattr(el, n), type) and issubclass(getattr(el, n), Element)
             and getattr(el, n).n_constraints > 0}
    spatial = {n for n in types if getattr(el, n).__module__ == "femb.elements.spatial_joints"}
    assert types - spatial == {"Hinge", "Slider", "PointOnLine", "DrivenAngle", "DrivenDisplacement", "Clamp"}
    # the spatial joints' multipliers are tabulated in docs/spatial.md (joint | rows | λ)
    import re
    from pathlib import Path
    text = (Path(__file__).resolve().parents[1] / "docs" / "spatial.md").read_text(encoding="utf-8")
    rows = {m.group(1) for m in re.finditer(r"^\| `(\w+)[`(]", text, re.M)}
    assert spatial and spatial <= rows, sorted(spatial - rows)


def test_conventions_page_names_every_type_and_existing_tests():
    """docs/conventions.md has a row per constraint type, and the tests it cites exist."""
    import re
    from pathlib import Path

    text = (Path(__file__).resolve().parents[1] / "docs" / "conventions.md").read_text(encoding="utf-8")
    rows = {m.group(1) for m in re.finditer(r"^\| `(\w+)` \|", text, re.M)}
    assert rows == {"Hinge", "Slider", "PointOnLine", "DrivenAngle", "DrivenDisplacement", "Clamp"}
    cited = set(re.findall(r"`(test_\w+)`", text))
    assert cited and cited <= set(globals()), sorted(cited - set(globals()))

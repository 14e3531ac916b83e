"""Contact elements: every kernel against finite differences, parameters checked, the contract role."""
import numpy as np
import pytest

import femb
from femb.contact import check_contact_kernels
from femb.elements import RigidBody, SpatialRigidBody
from femb.elements.contact import (DiscOnDisc, PinInHole, SphereOnPlane, SpatialSphereOnPlane, SpatialSpherePair,
                                   block_corners)
from femb.errors import ModelError


def _planar():
    m = femb.Mechanism("planar_contacts")
    m.add(RigidBody("a", 1.0, 0.1, position=(0.1, 0.3), angle=0.3))
    m.add(RigidBody("b", 2.0, 0.2, position=(0.5, 0.2), angle=-0.2))
    m.add(SphereOnPlane("s", "a", radius=0.1, point=(0.05, -0.02), plane_point=(0.1, -0.3), normal=(0.2, 1.0)))
    m.add(DiscOnDisc("dd", "a", "b", 0.1, 0.05, point_a=(0.02, 0.01), point_b=(-0.03, 0.04), mu=0.3))
    m.add(PinInHole("ph", "b", "a", 0.1, 0.09, point_a=(0.1, 0.03), point_b=(-0.2, 0.05)))
    for c in block_corners("blk", "b", 0.2, 0.4):
        m.add(c)
    return m.compile()


def _spatial():
    p = np.array((0.9, 0.3, -0.4, 0.1))
    m = femb.Mechanism("spatial_contacts")
    m.add(SpatialRigidBody("a", 1.0, (0.1, 0.2, 0.3), position=(0.1, 0.3, 0.5), rotation=p / np.linalg.norm(p)))
    m.add(SpatialSphereOnPlane("s", "a", radius=0.1, point=(0.05, -0.02, 0.03), plane_point=(0.1, -0.3, 0.0),
                               normal=(0.2, 0.3, 1.0), mu=0.2))
    p = np.array((0.2, -0.5, 0.7, 0.3))
    m.add(SpatialRigidBody("b", 2.0, (0.2, 0.1, 0.3), position=(0.3, 0.45, 0.4), rotation=p / np.linalg.norm(p)))
    m.add(SpatialSpherePair("ss", "a", "b", 0.1, 0.15, point_a=(0.05, -0.02, 0.03), point_b=(-0.03, 0.04, 0.01),
                            mu=0.2))
    m.add(SpatialSpherePair("gs", "ground", "b", 0.2, 0.1, point_a=(0.4, 0.1, 0.1), point_b=(0.02, 0.0, -0.01)))
    return m.compile()


@pytest.mark.parametrize("build", [_planar, _spatial])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_contact_kernels_match_finite_differences(build, seed):
    """W_N = ∂g_N/∂q, ζ = (W v)_q v and H = ∂(Wᵀλ)/∂q of every contact type, at random moved states."""
    report = check_contact_kernels(build(), seed=seed)
    assert report.ok, str(report)
    assert len(report.checks) == 3


def test_check_detects_a_wrong_kernel(monkeypatch):
    """The finite-difference check fails when a kernel's curvature term is wrong (it can fail)."""
    from femb.contact import assemble
    model = _planar()
    real = assemble.evaluate

    def wrong(*a, **k):
        out = real(*a, **k)
        out["zN"] = out["zN"] + 1.0
        return out
    monkeypatch.setattr(assemble, "evaluate", wrong)
    assert not check_contact_kernels(model).ok


def test_model_counts_and_sign_of_gap():
    model = _planar()
    assert model.n_contacts == 7 and model.n_friction == 7
    m = femb.Mechanism("ball")
    m.add(RigidBody("ball", 1.0, 0.004, position=(0.0, 0.35)))
    m.add(SphereOnPlane("floor", "ball", radius=0.1))
    from femb.contact import assemble
    mod = m.compile()
    ev = assemble.evaluate(mod, 0.0, mod.q0, np.array([1.0, -2.0, 3.0]))
    assert ev["gN"][0] == pytest.approx(0.25)              # open gap: centre height − radius
    assert (ev["WN"] @ np.array([1.0, -2.0, 3.0]))[0] == pytest.approx(-2.0)   # ġ_N = ẏ
    assert (ev["WF"] @ np.array([1.0, -2.0, 3.0]))[0] == pytest.approx(1.0 + 0.1 * 3.0)   # ẋ + R ω


@pytest.mark.parametrize("kw, what", [
    (dict(e_N=1.5), "e_N"), (dict(e_N=-0.1), "e_N"), (dict(mu=-1.0), "mu"), (dict(mu=float("nan")), "mu"),
    (dict(e_F=2.0), "e_F"), (dict(radius=-0.1), "radius"), (dict(normal=(0.0, 0.0)), "normal"),
    (dict(mu="abc"), "mu"),
])
def test_bad_contact_parameters_are_model_errors(kw, what):
    with pytest.raises(ModelError, match=what) as err:
        SphereOnPlane("floor", "ball", **kw)
    assert "floor" in str(err.value)


def test_pin_larger_than_hole_is_a_model_error():
    with pytest.raises(ModelError, match="hole_radius"):
        PinInHole("clearance", "a", "b", 0.01, 0.02)


def test_spatial_contact_on_planar_body_is_refused():
    m = femb.Mechanism("mixed")
    m.add(RigidBody("ball", 1.0, 0.004, position=(0.0, 0.35)))
    m.add(SpatialSphereOnPlane("floor", "ball", radius=0.1))
    with pytest.raises(ModelError, match="floor"):
        m.compile()


def test_contact_kernel_role_signature_is_checked():
    """A contact type whose kernel has the wrong arity is refused with the role's signature."""
    from femb.base.jit import kernel

    @kernel
    def bad(P, t, tf, xe, ve, jac, gN, W, zeta, H):      # le missing
        gN[0, 0] = 0.0

    class Bad(SphereOnPlane):
        kernels = {"contact": bad}

    m = femb.Mechanism("bad")
    m.add(RigidBody("ball", 1.0, 0.004, position=(0.0, 0.35)))
    m.add(Bad("floor", "ball", radius=0.1))
    with pytest.raises(ModelError, match="contact"):
        m.compile()

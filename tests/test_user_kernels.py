"""A user's own element type, written with each mistake a new user makes (docs/kernels.md).

Each mistake must end in a clear femb error or warning naming the element type, never a
silent wrong answer or a crashed process; the public Jacobian check finds the mistakes that
only slow Newton down.
"""
import math
import warnings

import numpy as np
import pytest

import femb
from femb import Mechanism
from femb.base.jit import kernel
from femb.elements import Hinge, RigidBody
from femb.errors import ModelError
from femb.system.element import Element
from femb.system.kernels import ContractWarning


# ---- kernels of a linear spring pulling a body's centre of mass to the origin, f = −k x − c ẋ
@kernel
def spring_force(P, t, tf, xe, ve, jac, fe, fq, fv):
    for e in range(xe.shape[0]):
        k = P[e, 0]
        c = P[e, 1]
        fe[e, 0] = -k * xe[e, 0] - c * ve[e, 0]
        fe[e, 1] = -k * xe[e, 1] - c * ve[e, 1]
        if jac:
            fq[e, 0, 0] = -k
            fq[e, 1, 1] = -k
            fv[e, 0, 0] = -c
            fv[e, 1, 1] = -c


def spring_force_plain(P, t, tf, xe, ve, jac, fe, fq, fv):     # no @kernel: femb compiles it
    for e in range(xe.shape[0]):
        k = P[e, 0]
        c = P[e, 1]
        fe[e, 0] = -k * xe[e, 0] - c * ve[e, 0]
        fe[e, 1] = -k * xe[e, 1] - c * ve[e, 1]
        if jac:
            fq[e, 0, 0] = -k
            fq[e, 1, 1] = -k
            fv[e, 0, 0] = -c
            fv[e, 1, 1] = -c


@kernel
def spring_returns(P, t, tf, xe, ve, jac, fe, fq, fv):
    # the mistake: the force is returned, not written
    return -P[0, 0] * xe[0, 0]


@kernel
def spring_writes_and_returns(P, t, tf, xe, ve, jac, fe, fq, fv):
    for e in range(xe.shape[0]):
        fe[e, 0] = -P[e, 0] * xe[e, 0]
    return fe[0, 0]


@kernel
def spring_out_of_bounds(P, t, tf, xe, ve, jac, fe, fq, fv):
    for e in range(xe.shape[0]):
        fe[e, 0] = -P[e, 0] * xe[e, 0]
        fe[e, 1] = -P[e, 0] * xe[e, 1]
        fe[e, 3] = 0.0          # a planar body has 3 coordinates: index 3 is out of bounds


@kernel
def spring_out_of_bounds_later(P, t, tf, xe, ve, jac, fe, fq, fv):
    for e in range(xe.shape[0]):
        fe[e, 0] = -P[e, 0] * xe[e, 0]
        fe[e, 1] = -P[e, 0] * xe[e, 1]
        if t > 0.01:
            fe[e, 5] = 0.0      # only after a few steps


@kernel
def spring_wrong_arity(P, t, xe, ve, jac, fe, fq, fv):
    pass


@kernel
def spring_sign_error(P, t, tf, xe, ve, jac, fe, fq, fv):
    for e in range(xe.shape[0]):
        k = P[e, 0]
        fe[e, 0] = -k * xe[e, 0]
        fe[e, 1] = -k * xe[e, 1]
        if jac:
            fq[e, 0, 0] = k         # the mistake: + instead of −
            fq[e, 1, 1] = -k


@kernel
def spring_does_not_type(P, t, tf, xe, ve, jac, fe, fq, fv):
    for e in range(xe.shape[0]):
        fe[e, 0] = "a string"


def make_type(fn, damped=True, name=None):
    """An element type 'UserSpring' with the force kernel ``fn``."""

    class UserSpring(Element):
        has_force = True
        force_depends_on_qd = damped
        kernels = {"force": fn}

        def __init__(self, name, body, k, c=0.0):
            super().__init__(name)
            self.body, self.k, self.c = body, float(k), float(c)

        def resolve(self, lookup):
            self.body = lookup(self.body, "body")

        def nodes(self):
            return [self.body.node]

        @classmethod
        def pack(cls, elements):
            return {"P": np.array([[e.k, e.c] for e in elements], dtype=float).reshape(-1, 2)}

    if name:
        UserSpring.__name__ = UserSpring.__qualname__ = name
    return UserSpring


def oscillator(cls, k=40.0, c=0.0):
    """A 1 kg body on the spring, started at x = 0.1 m (no gravity, no joint)."""
    m = Mechanism("user")
    b = m.add(RigidBody("b", mass=1.0, inertia=0.1, position=(0.1, 0.0)))
    m.add(cls("spring", b, k, c))
    return m


def test_a_correct_user_element_runs_and_matches_the_exact_oscillator():
    model = oscillator(make_type(spring_force), k=40.0, c=0.0).compile()
    res = femb.simulate(model, t_end=1.0, h=1e-3)
    x = res.body("b")[-1, 0]
    assert abs(x - 0.1 * math.cos(math.sqrt(40.0) * 1.0)) < 1e-3
    assert femb.check_jacobians(model).ok


def test_a_kernel_without_the_decorator_is_compiled_by_femb_and_gives_the_same_numbers():
    a = femb.simulate(oscillator(make_type(spring_force), c=0.5).compile(), t_end=0.5, h=1e-3)
    b = femb.simulate(oscillator(make_type(spring_force_plain), c=0.5).compile(), t_end=0.5, h=1e-3)
    assert np.array_equal(a.q, b.q)


def test_a_kernel_that_returns_its_result_is_refused_by_name():
    with pytest.raises(ModelError, match=r"UserSpring.*spring_returns.*never uses its output arrays"):
        oscillator(make_type(spring_returns)).compile()
    with pytest.raises(ModelError, match=r"spring_writes_and_returns returns a value"):
        oscillator(make_type(spring_writes_and_returns)).compile()


def test_an_out_of_bounds_write_is_a_model_error_not_a_crash():
    with pytest.raises(ModelError, match=r"UserSpring.*spring_out_of_bounds.*out of bounds"):
        oscillator(make_type(spring_out_of_bounds)).compile()


def test_debug_mode_names_the_element_of_an_out_of_bounds_write_during_the_run(monkeypatch):
    monkeypatch.setenv("FEMB_DEBUG", "1")
    model = oscillator(make_type(spring_out_of_bounds_later, name="LateSpring")).compile()
    with pytest.raises(ModelError, match=r"LateSpring.*out of bounds.*during the run"):
        femb.simulate(model, t_end=0.1, h=1e-3)


def test_a_wrong_signature_is_refused_with_the_expected_one():
    with pytest.raises(ModelError, match=r"must take 9 arguments \(P, t, tf, xe, ve, jac, fe, fq, fv\)"):
        oscillator(make_type(spring_wrong_arity)).compile()


def test_a_kernel_that_does_not_compile_gets_a_femb_error_naming_it():
    with pytest.raises(ModelError, match=r"UserSpring: kernel spring_does_not_type does not compile"):
        oscillator(make_type(spring_does_not_type)).compile()


def test_the_jacobian_check_finds_a_sign_error():
    model = oscillator(make_type(spring_sign_error, damped=False)).compile()
    rep = femb.check_jacobians(model)
    assert not rep.ok
    bad = rep.failures
    assert [c.what for c in bad] == ["force: df/dx (fq)"]
    assert bad[0].element_type == "UserSpring" and bad[0].error > 0.1
    assert "WRONG" in str(rep)


def test_damping_without_force_depends_on_qd_is_warned_and_found():
    cls = make_type(spring_force, damped=False)
    with pytest.warns(ContractWarning, match="force_depends_on_qd"):
        model = oscillator(cls, c=0.5).compile()
    rep = femb.check_jacobians(model)
    assert [c.what for c in rep.failures] == ["force: depends on v?"]


def test_a_correct_damped_element_passes_silently():
    with warnings.catch_warnings():
        warnings.simplefilter("error", ContractWarning)
        model = oscillator(make_type(spring_force, damped=True), c=0.5).compile()
    assert femb.check_jacobians(model).ok


def test_every_builtin_scene_passes_the_jacobian_check():
    from femb.study import registry
    for name in ("andrews", "heavy_top", "bricard", "spatial_slider_crank", "flexible_slider_crank", "spin_up_3d",
                 "flexible_fourbar_3d", "right_angle_cantilever"):
        mech = registry.load(name).module.build()
        model = mech.compile() if hasattr(mech, "compile") else mech
        rep = femb.check_jacobians(model)
        assert rep.ok, f"{name}:\n{rep}"


def test_a_hinge_user_model_mixing_builtin_and_user_types():
    m = Mechanism("mixed")
    b = m.add(RigidBody("b", mass=1.0, inertia=0.1, position=(0.5, 0.0), points={"O": (-0.5, 0.0)}))
    m.add(Hinge("pivot", "ground", b, point_b="O"))
    m.add(make_type(spring_force)("spring", b, 10.0, 0.1))
    model = m.compile()
    assert femb.check_jacobians(model).ok
    res = femb.simulate(model, t_end=0.2, h=1e-3)
    assert np.isfinite(res.q).all()


def test_a_spatial_joint_type_without_its_rows_is_a_model_error():
    """A user's joint type on SpatialPairElement that defines neither program() nor pack()."""
    from femb.elements.spatial_bodies import SpatialRigidBody
    from femb.elements.spatial_joints import JOINT_KERNELS, SpatialPairElement

    class MyJoint(SpatialPairElement):
        n_constraints = 3
        constraint_names = ("x", "y", "z")
        kernels = JOINT_KERNELS

    m = Mechanism("myjoint")
    b = m.add(SpatialRigidBody("b", 1.0, (0.1, 0.1, 0.1), position=(0.0, 0.0, -1.0)))
    m.add(MyJoint("j", "ground", b, at=(0.0, 0.0, 0.0)))
    with pytest.raises(ModelError, match=r"MyJoint 'j'.*must define program\(\)"):
        m.compile()

"""Bad input gets femb's own errors, naming the element or parameter."""
import math

import numpy as np
import pytest

import femb
from femb import (ConvergenceError, InitializationError, ModelError, ParameterError,
                  SingularMatrixError)
from femb.elements import Force, Gravity, Hinge, PointMass, RigidBody, Slider, SpringDamper, Torque


def pendulum():
    m = femb.Mechanism("p")
    bar = m.add(RigidBody("bar", 1.0, 0.1, (0.5, 0.0), 0.0, points={"O": (-0.5, 0.0)}))
    m.add(Hinge("pivot", "ground", bar, point_b="O"))
    m.add(Gravity())
    return m


@pytest.mark.parametrize("kw, what", [
    (dict(mass=-1.0, inertia=1.0), "mass"),
    (dict(mass=0.0, inertia=1.0), "mass"),
    (dict(mass=float("nan"), inertia=1.0), "mass"),
    (dict(mass=1.0, inertia=-2.0), "inertia"),
    (dict(mass=1.0, inertia=float("inf")), "inertia"),
    (dict(mass=1.0, inertia=1.0, position=(0.0, float("nan"))), "position"),
    (dict(mass=1.0, inertia=1.0, angle=float("inf")), "angle"),
    (dict(mass=1.0, inertia=1.0, velocity=(1.0, 2.0, 3.0)), "velocity"),
    (dict(mass="heavy", inertia=1.0), "mass"),
])
def test_bad_body_parameters(kw, what):
    with pytest.raises(ModelError, match=rf"RigidBody 'b'.*{what}"):
        RigidBody("b", **kw)


def test_bad_element_parameters():
    with pytest.raises(ModelError, match="SpringDamper 's'.*stiffness"):
        SpringDamper("s", "a", "b", stiffness=-1.0)
    with pytest.raises(ModelError, match="Slider 'sl'.*axis"):
        Slider("sl", "a", "b", axis=(0.0, 0.0))
    with pytest.raises(ModelError, match="Torque 't'.*bare callable"):
        Torque("t", "a", lambda t: t)
    with pytest.raises(ModelError, match="Force 'f'.*two components"):
        Force("f", "a", (1.0, 2.0, 3.0))
    with pytest.raises(ModelError, match="PointMass 'p'.*mass"):
        PointMass("p", -3.0)


def test_unknown_and_foreign_bodies():
    m = pendulum()
    m.add(Hinge("h2", "bar", "nobody"))
    with pytest.raises(ModelError, match="Hinge 'h2'.*'nobody'.*not in mechanism"):
        m.compile()
    m = pendulum()
    stranger = RigidBody("stranger", 1.0, 1.0)
    m.add(Hinge("h3", "bar", stranger))
    with pytest.raises(ModelError, match="Hinge 'h3'.*'stranger'.*not added"):
        m.compile()
    m = pendulum()
    m.add(Hinge("h4", "bar", "pivot"))
    with pytest.raises(ModelError, match="Hinge 'h4'.*must be a body"):
        m.compile()


def test_unknown_point_name():
    m = pendulum()
    m.add(Hinge("h5", "bar", "ground", point_a="nowhere"))
    with pytest.raises(ModelError, match="body 'bar' has no point named 'nowhere'"):
        m.compile()


def test_duplicate_names():
    m = pendulum()
    with pytest.raises(ModelError, match="duplicate name 'bar'"):
        m.add(RigidBody("bar", 1.0, 1.0))
    with pytest.raises(ModelError, match="duplicate name 'ground'"):
        m.add(RigidBody("ground", 1.0, 1.0))


def test_not_an_element():
    with pytest.raises(ModelError, match="not a femb element"):
        femb.Mechanism().add("bar")


def test_no_mass():
    m = femb.Mechanism("empty")
    with pytest.raises(ModelError, match="no free coordinates"):
        m.compile()


@pytest.mark.parametrize("kw, match", [
    (dict(t_end=1.0, h=0.0), "h must be"),
    (dict(t_end=1.0, h=-1e-3), "h must be"),
    (dict(t_end=1.0, h=float("nan")), "h must be"),
    (dict(t_end=0.0, h=1e-3), "t_end"),
    (dict(t_end=-1.0, h=1e-3), "t_end"),
    (dict(t_end=1.0, h=1e-3, rho_inf=1.2), "rho_inf"),
    (dict(t_end=1.0, h=1e-3, rho_inf=-0.1), "rho_inf"),
    (dict(t_end=1.0, h=1e-3, stride=0), "stride"),
    (dict(t_end=1.0, h=1e-3, rtol=0.0), "rtol"),
    (dict(t_end=1.0, h=1e-3, max_iter=0), "max_iter"),
    (dict(t_end=1.0, h=1e-3, linear_solver="magic"), "linear_solver"),
    (dict(t_end=1.0, h=1e-3, alpha=(0.1, 0.2)), "alpha"),
])
def test_bad_solver_parameters(kw, match):
    model = pendulum().compile()
    with pytest.raises(ParameterError, match=match):
        femb.simulate(model, **kw)


def test_rho_inf_one_warns():
    model = pendulum().compile()
    with pytest.warns(femb.ParameterWarning, match="rho_inf = 1"):
        femb.simulate(model, 0.01, 1e-3, rho_inf=1.0)


def test_unprojectable_initial_configuration():
    m = femb.Mechanism("bad")
    pts = {"s": (-0.5, 0.0), "e": (0.5, 0.0)}
    a = m.add(RigidBody("a", 1.0, 0.1, (0.5, 0.0), points=pts))
    b = m.add(RigidBody("b", 1.0, 0.1, (1.2, 0.5), 0.8, points=pts))
    m.ground.add_point("far", (5.0, 0.0))
    m.add(Hinge("root", "ground", a, point_b="s"))
    m.add(Hinge("knee", a, b, point_a="e", point_b="s"))
    m.add(Hinge("reach", "ground", b, point_a="far", point_b="e"))   # two 1 m bars cannot reach 5 m
    with pytest.raises(InitializationError, match="cannot project.*'(root|knee|reach)'"):
        femb.simulate(m.compile(), 0.1, 1e-3)


def test_redundant_constraints_are_reported():
    m = pendulum()
    m.add(Hinge("pivot_again", "ground", "bar", point_b="O"))
    model = m.compile()
    with pytest.raises(InitializationError, match="redundant constraints.*hinge 'pivot_again' equations x, y "
                                                  "are dependent on hinge 'pivot' equations x, y"):
        femb.simulate(model, 0.1, 1e-3)
    # without initialization the solver's own check reports it, with time and step
    with pytest.raises(SingularMatrixError, match=r"t = 0.001 s \(step 1\).*redundant") as err:
        femb.simulate(model, 0.1, 1e-3, initialize=False)
    assert err.value.step == 1 and err.value.t == pytest.approx(1e-3)


def test_newton_failure_reports_time_step_residual_and_keeps_result():
    from femb.benchmarks.scenes.planar import andrews
    model = andrews.build().compile()
    with pytest.raises(ConvergenceError) as err:
        femb.simulate(model, 0.03, 2e-3)
    e = err.value
    assert 0.0 < e.t < 0.03 and e.step >= 1
    assert f"t = {e.t:.6g} s" in str(e) and f"step {e.step}" in str(e)
    assert set(e.residuals) == {"r_q", "Phi"}
    # the partial result holds every step accepted before the failure
    assert e.result is not None and e.result.status == "failed"
    assert e.result.t[-1] == pytest.approx(e.t - 2e-3)
    assert e.result.steps == e.step - 1


def test_newton_iteration_limit_names_the_limit():
    model = pendulum().compile()
    with pytest.raises(ConvergenceError, match="within 1 iterations"):
        femb.simulate(model, 0.5, 1e-2, max_iter=1, predictor="zero")


def test_point_mass_slider_rotation_lock_is_rejected():
    m = femb.Mechanism("pm")
    p = m.add(PointMass("p", 1.0, (0.0, 0.0)))
    m.add(Slider("s", "ground", p))
    with pytest.raises(ModelError, match="Slider 's'.*PointOnLine"):
        m.compile()


def test_model_is_frozen():
    model = pendulum().compile()
    with pytest.raises(AttributeError, match="frozen"):
        model.nq = 4
    with pytest.raises(ValueError):
        model.q0[0] = 1.0

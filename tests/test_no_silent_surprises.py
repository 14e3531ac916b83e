"""No silent surprises in 3-D: mixed planar/spatial input, changed initial velocities,
non-unit quaternions, steps longer than the run or too long for a short run, and the
hint of a singular iteration matrix at a huge step.
"""
import warnings

import numpy as np
import pytest

import femb
from femb import elements as E
from femb.errors import (AccuracyWarning, InitialMoveWarning, InitialVelocityWarning, ModelError, ParameterWarning,
                         SingularMatrixError)


def _spatial():
    return E.SpatialRigidBody("s", 1.0, (1.0, 1.0, 1.0), position=(1.0, 0.0, 0.0), points={"O": (-1.0, 0.0, 0.0)})


def _planar():
    return E.RigidBody("p", mass=1.0, inertia=0.1, position=(1.0, 0.0), points={"O": (-1.0, 0.0)})


PLANAR_ON_SPATIAL = {
    "Hinge": lambda s, p: E.Hinge("j", "ground", s, point_b="O"),
    "Hinge (default points)": lambda s, p: E.Hinge("j", p, s),
    "Slider": lambda s, p: E.Slider("j", "ground", s, axis=(1.0, 0.0)),
    "PointOnLine": lambda s, p: E.PointOnLine("j", "ground", s, axis=(1.0, 0.0)),
    "DrivenAngle": lambda s, p: E.DrivenAngle("j", "ground", s, 0.0),
    "SpringDamper": lambda s, p: E.SpringDamper("j", "ground", s, 1.0),
    "RotationalSpringDamper": lambda s, p: E.RotationalSpringDamper("j", "ground", s, 1.0),
    "Force": lambda s, p: E.Force("j", s, (1.0, 0.0)),
    "Torque": lambda s, p: E.Torque("j", s, 1.0),
}

SPATIAL_ON_PLANAR = {
    "SphericalJoint": lambda s, p: E.SphericalJoint("j", "ground", p),
    "SphericalJoint (a planar)": lambda s, p: E.SphericalJoint("j", p, s),
    "PointSpringDamper": lambda s, p: E.PointSpringDamper("j", "ground", p, stiffness=1.0),
    "SpatialForce": lambda s, p: E.SpatialForce("j", p, (1.0, 0.0, 0.0)),
    "SpatialTorque": lambda s, p: E.SpatialTorque("j", p, (1.0, 0.0, 0.0)),
}


@pytest.mark.parametrize("kind", sorted(PLANAR_ON_SPATIAL))
def test_a_planar_element_on_a_spatial_body_is_a_model_error_that_says_so(kind):
    mech = femb.Mechanism("mixed")
    s, p = mech.add(_spatial(), _planar())
    mech.add(PLANAR_ON_SPATIAL[kind](s, p))
    with pytest.raises(ModelError) as err:
        mech.compile()
    msg = str(err.value)
    cls = kind.split()[0]
    assert f"{cls} 'j'" in msg and "'s' is a spatial body" in msg and "planar" in msg, msg


@pytest.mark.parametrize("kind", sorted(SPATIAL_ON_PLANAR))
def test_a_spatial_element_on_a_planar_body_is_a_model_error_that_says_so(kind):
    mech = femb.Mechanism("mixed")
    s, p = mech.add(_spatial(), _planar())
    mech.add(SPATIAL_ON_PLANAR[kind](s, p))
    with pytest.raises(ModelError, match=r"'p' is not a spatial body \(planar and spatial elements cannot be joined\)"):
        mech.compile()


# ---------------------------------------------------------------- initial velocities
def _pendulum(velocity, omega=0.0, drive=None):
    mech = femb.Mechanism("pendulum")
    bar = mech.add(E.RigidBody("bar", mass=1.0, inertia=1 / 12, position=(0.5, 0.0), velocity=velocity, omega=omega,
                               points={"O": (-0.5, 0.0)}))
    mech.add(E.Hinge("pivot", "ground", bar, point_b="O"))
    if drive is not None:
        mech.add(E.DrivenAngle("drive", "ground", bar, drive))
    return mech.compile()


def test_a_given_velocity_changed_by_the_projection_warns():
    model = _pendulum(velocity=(0.3, 1.0), omega=2.0)       # consistent: v = (0, ω · 0.5) = (0, 1)
    with pytest.warns(InitialVelocityWarning, match=r"'bar' by 0\.3[0-9]* m/s") as rec:
        st = femb.consistent_initial_state(model)
    assert issubclass(rec[0].category, InitialMoveWarning)
    assert abs(model.node_velocities("bar", st.qd)[0]) < 1e-12


def test_consistent_or_unset_velocities_do_not_warn():
    from femb.base.functions import Linear
    with warnings.catch_warnings():
        warnings.simplefilter("error", InitialMoveWarning)
        femb.consistent_initial_state(_pendulum(velocity=(0.0, 1.0), omega=2.0))
        # from rest, set in motion by a driver: what the projection is for
        st = femb.consistent_initial_state(_pendulum(velocity=(0.0, 0.0), drive=Linear(2.0)))
    assert abs(st.qd[2] - 2.0) < 1e-12


def test_a_spatial_initial_velocity_changed_by_the_projection_warns():
    from femb.benchmarks.scenes.spatial import heavy_top
    X, W = np.array([0.0, 1.0, 0.0]), np.array([0.0, 150.0, -4.61538])
    mech = femb.Mechanism("top")
    top = mech.add(E.SpatialRigidBody("top", 15.0, (0.234375, 0.46875, 0.234375), position=X,
                                      velocity=(0.0, 0.0, 0.0), omega=W, points={"O": -X}))
    mech.add(E.SphericalJoint("support", "ground", top, point_b="O"), E.SpatialGravity((0.0, 0.0, -9.81)))
    with pytest.warns(InitialVelocityWarning, match="'top' by"):
        femb.consistent_initial_state(mech.compile())
    with warnings.catch_warnings():
        warnings.simplefilter("error", InitialMoveWarning)
        femb.consistent_initial_state(heavy_top.build().compile())


# ---------------------------------------------------------------- quaternions
def test_a_non_unit_quaternion_is_refused():
    for rot in ((1.0, 1.0, 0.0, 0.0), (2.0, 0.0, 0.0, 0.0), (0.0, 0.0, 1.0)):
        with pytest.raises(ModelError, match="SpatialRigidBody 'b': rotation"):
            E.SpatialRigidBody("b", 1.0, (1.0, 1.0, 1.0), rotation=rot)
    with pytest.raises(ModelError, match=r"not a unit quaternion \(norm 1\.41421\)"):
        E.SpatialRigidBody("b", 1.0, (1.0, 1.0, 1.0), rotation=(1.0, 1.0, 0.0, 0.0))
    with pytest.raises(ModelError, match="node 'n': rotation"):
        E.FrameNode("n", rotation=(0.5, 0.5, 0.5, 0.6))
    # a unit quaternion printed to 7 digits is accepted, and normalised to round-off
    c = round(np.cos(np.pi / 8), 7), 0.0, 0.0, round(np.sin(np.pi / 8), 7)
    b = E.SpatialRigidBody("b", 1.0, (1.0, 1.0, 1.0), rotation=c)
    assert abs(np.linalg.norm(b.node.q0[3:7]) - 1.0) < 1e-15


# ---------------------------------------------------------------- step sizes
def test_a_step_longer_than_the_run_warns():
    model = _pendulum(velocity=(0.0, 0.0))
    with pytest.warns(ParameterWarning, match=r"h = 0\.3 s is longer than the run \(t_end − t0 = 0\.1 s\)"):
        r = femb.simulate(model, 0.1, 0.3)
    assert r.steps == 1


def test_a_run_too_short_for_the_in_loop_check_still_warns_when_h_is_far_too_large():
    from femb.benchmarks.scenes.planar import pendulum
    scene_model = pendulum.build().compile()
    with pytest.warns(AccuracyWarning, match="short run of 10 stored steps"):
        r = femb.simulate(scene_model, 2.0, 0.2)
    assert r.steps == 10
    ref = pendulum.reference(r.t)
    out = pendulum.outputs(r)
    assert np.abs(np.asarray(out["psi"]) - np.asarray(ref["psi"])).max() > 0.1     # really wrong
    with warnings.catch_warnings():
        warnings.simplefilter("error", AccuracyWarning)
        femb.simulate(scene_model, 0.1, 0.01)                                       # short and accurate
        femb.simulate(scene_model, 0.1, 0.01, stride=3)


def test_singular_iteration_matrix_at_a_huge_step_on_a_clamped_beam_names_the_step_size_first():
    mech = femb.Mechanism("cantilever")
    sec = E.Section.rectangle(E=2.1e11, G=8.1e10, width=0.01, height=0.01, density=7800.0)
    E.add_beam(mech, "beam", sec, start=(0.0, 0.0), end=(1.0, 0.0), n_elements=10, start_joint="clamp")
    mech.add(E.Gravity((0.0, -9.81)))
    # the beam starts in its quasi-static deflection (femb/system/initial.py, settle): Newton then stalls
    # (ConvergenceError) where, started undeformed, it met a singular matrix; either names h first
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", AccuracyWarning)
        with pytest.raises((SingularMatrixError, femb.ConvergenceError)) as err:
            femb.simulate(mech.compile(), 100.0, 10.0)
    if isinstance(err.value, SingularMatrixError):
        hint = str(err.value).split("hint:", 1)[1]
        assert hint.strip().startswith("the step size"), hint
    else:
        assert str(err.value).split("; ")[-1].startswith("try a smaller h"), str(err.value)
    # a rotation without inertia and without a constraint keeps the hint about masses
    from femb.system.initial import singular_hint
    m2 = femb.Mechanism("massless")
    node = m2.add(E.BeamNode("n", (0.5, 0.0)))              # a massless node: θ has no mass
    m2.add(E.Hinge("h", "ground", node), E.PointMass("m", 1.0, (1.0, 0.0)))
    model2 = m2.compile()
    assert "neither mass" in singular_hint(model2, model2.q0)

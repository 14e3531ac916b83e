"""Consistent initial values (femb.system.initial): redundant constraints named and eliminated, moves reported."""
import math
import warnings

import numpy as np
import pytest

import femb
from femb import Mechanism
from femb.elements import Gravity, Hinge, RigidBody
from femb.errors import InitializationError, ModelError
from femb.system.initial import (
    InitialMoveWarning, RedundantConstraintWarning, consistent_initial_state, redundancy)

G = 9.81


def pendulum(hinges=("h1",), offset=(0.0, 0.0)):
    m = Mechanism("pendulum")
    bar = m.add(RigidBody("bar", 1.0, 1 / 12, position=(0.5 + offset[0], offset[1]), points={"O": (-0.5, 0.0)}))
    for h in hinges:
        m.add(Hinge(h, "ground", bar, point_b="O"))
    m.add(Gravity((0.0, -G)))
    return m


def test_two_identical_hinges_error_names_them():
    model = pendulum(("h1", "h2")).compile()
    assert model.active_constraints.tolist() == [True] * 4 and model.removed_constraints == []
    with pytest.raises(InitializationError, match=r"hinge 'h2' equations x, y are dependent on hinge 'h1' "
                                                  r"equations x, y") as err:
        femb.simulate(model, 0.1, 1e-2)
    assert "redundant=\"eliminate\"" in str(err.value)


def test_two_identical_hinges_eliminated_run_like_one():
    with warnings.catch_warnings():
        warnings.simplefilter("error")          # asked for: compiled without a warning
        model = pendulum(("h1", "h2")).compile(redundant="eliminate")
    assert model.removed_constraints == [("h2", "x"), ("h2", "y")]
    assert model.nc == 4 and model.active_constraints.tolist() == [True, True, False, False]
    # the user-level functions honour the mask
    q = model.q0 + 0.01
    assert np.all(femb.system.assembly.constraint_vector(model, 0.0, q)[2:] == 0.0)
    assert femb.system.assembly.constraint_jacobian(model, 0.0, q).toarray()[2:].any() == False  # noqa: E712
    one = femb.simulate(pendulum().compile(), 0.5, 1e-2)
    two = femb.simulate(model, 0.5, 1e-2)
    np.testing.assert_allclose(two.q, one.q, atol=1e-12)
    sparse = femb.simulate(model, 0.5, 1e-2, linear_solver="sparse")
    np.testing.assert_allclose(sparse.q, one.q, atol=1e-12)
    # the user-level iteration matrix is regular: a removed equation is the trivial λ_i = 0
    S = femb.system.assembly.iteration_matrix(model, two.at(0.25), 1e-2, femb.GeneralizedAlpha.from_rho_inf(0.7))
    assert np.linalg.matrix_rank(S.toarray()) == model.nq + model.nc
    np.testing.assert_allclose(two.reaction("h1"), one.reaction("h1"), atol=1e-9)
    with pytest.warns(RedundantConstraintWarning, match="not unique") as rec:
        assert np.all(two.reaction("h2") == 0.0)
    # one short line naming the joint, pointing at the caller (this file), not at femb
    assert len(rec) == 1 and rec[0].filename == __file__
    assert str(rec[0].message) == "joint 'h2': equation(s) x, y removed as redundant; its reaction is not unique"


def parallelogram(fifth, r=0.5, w=1.0, phi0=math.radians(60)):
    """Cranks of length r at x = 0, w (and 2w) on the ground, a coupler through their tips, under gravity.

    Without the middle crank, crank 'c0' has twice the mass and inertia: for a parallelogram all cranks
    turn alike, so both mechanisms have the same kinetic and potential energy as functions of the angle.
    """
    m = Mechanism("parallelogram")
    c, s = math.cos(phi0), math.sin(phi0)
    xs = (0.0, w, 2 * w) if fifth else (0.0, 2 * w)
    cranks = []
    for i, x in enumerate(xs):
        k = 2.0 if (not fifth and i == 0) else 1.0
        b = m.add(RigidBody(f"c{i}", 0.3 * k, 0.3 * k * r * r / 12, position=(x + r / 2 * c, r / 2 * s), angle=phi0,
                            points={"O": (-r / 2, 0.0), "T": (r / 2, 0.0)}))
        m.add(Hinge(f"g{i}", "ground", b, at=(x, 0.0)))
        cranks.append((x, b))
    cp = m.add(RigidBody("coupler", 1.0, 1.0 * (2 * w) ** 2 / 12, position=(w + r * c, r * s)))
    for i, (x, b) in enumerate(cranks):
        m.add(Hinge(f"t{i}", b, cp, at=(x + r * c, r * s)))
    m.add(Gravity((0.0, -G)))
    return m


def test_parallelogram_with_fifth_bar():
    with pytest.raises(InitializationError, match=r"(hinge '[gt]\d' equations? [xy](, [xy])?).* dependent on "
                                                  r".*hinge '[gt]\d'"):
        femb.simulate(parallelogram(True).compile(), 0.1, 1e-2)
    an = redundancy(parallelogram(True).compile())
    assert an.rank == 11 and len(an.dependent) == 1
    model = parallelogram(True).compile(redundant="eliminate")
    assert len(model.removed_constraints) == 1
    five = femb.simulate(model, 0.6, 2e-3)
    four = femb.simulate(parallelogram(False).compile(), 0.6, 2e-3)
    np.testing.assert_allclose(five.body("coupler"), four.body("coupler"), atol=1e-9)
    np.testing.assert_allclose(five.body("c0")[:, 2], four.body("c0")[:, 2], atol=1e-9)
    assert abs(five.body("coupler")[-1, 1] - five.body("coupler")[0, 1]) > 0.05    # it did move


def test_initial_moves_reported_and_limited():
    # a hinge 0.1 m off (10 % of the 1 m model): above the default limit of 1 %
    with pytest.raises(InitializationError, match=r"largest initial residual is in hinge 'h1'.*'bar' by 0\.1 m"):
        femb.simulate(pendulum(offset=(0.1, 0.0)).compile(), 0.1, 1e-2)
    # allowed explicitly: warned, listing the body, distance and angle
    model = pendulum(offset=(0.1, 0.0)).compile(max_initial_move=0.5)
    with pytest.warns(InitialMoveWarning, match=r"'bar' by 0\.1 m and 0 rad"):
        st = consistent_initial_state(model)
    assert np.abs(femb.system.assembly.constraint_vector(model, 0.0, st.q)).max() < 1e-12
    # the option of the function overrides the model's
    with pytest.raises(InitializationError, match="max_initial_move = 0.01 m"):
        consistent_initial_state(model, max_initial_move=0.01)
    # rounding of the input (2e-5 m) passes with a warning; exact input is silent
    with pytest.warns(InitialMoveWarning):
        consistent_initial_state(pendulum(offset=(2e-5, 0.0)).compile())
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        consistent_initial_state(pendulum().compile())
    with pytest.raises(ModelError, match="max_initial_move"):
        pendulum().compile(max_initial_move=-1.0)
    with pytest.raises(ModelError, match="redundant"):
        pendulum().compile(redundant="ignore")


def test_singular_matrix_hint_fits_the_cause():
    """Redundant joints are named; a singular matrix with independent constraints is not called redundancy."""
    from femb.elements import PointMass, SpringDamper
    from femb.errors import SingularMatrixError
    with pytest.raises(SingularMatrixError, match=r"step 1.*hinge 'h2' equations x, y are dependent on hinge 'h1'"):
        femb.simulate(pendulum(("h1", "h2")).compile(), 0.1, 1e-2, initialize=False)
    # a rotation with (almost) no inertia, no stiffness and no joint: nothing redundant about it
    m = Mechanism("spinner")
    b = m.add(RigidBody("b", 1.0, 1e-20, position=(1.0, 0.0)))
    p = m.add(PointMass("p", 1.0, position=(0.0, 1.0)))
    m.add(SpringDamper("s", "ground", b, 100.0, length=0.5), Hinge("h", "ground", p, at=(0.0, 1.0)))
    with pytest.raises(SingularMatrixError, match="constraints are independent") as err:
        femb.simulate(m.compile(), 0.1, 1e-2, initialize=False)
    assert "redundant constraints or" not in str(err.value)


def test_scene_that_asks_for_elimination_compiles_silently():
    # bricard's closure is structurally redundant and its scene compiles with redundant="eliminate":
    # asked for, so no warning (it printed 700 characters with an internal path and source line)
    from femb.study import registry
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        model = registry.load("bricard").model()
    assert model.removed_constraints == [("J6", "lock_2")]

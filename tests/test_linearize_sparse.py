"""femb.analysis.linearize, large models: sparse null-space bases, A as a LinearOperator, sparse modes."""
import numpy as np
import pytest

from femb import Mechanism
from femb.analysis import linearize as fl
from femb.benchmarks.cost.linearize_large import BETA, E, NU, RHO
from femb.elements import SpatialRigidBody, SphericalJoint
from femb.elements.spatial_beam import SpatialSection, spatial_beam
from femb.errors import ParameterError


def _beam(n=12):
    """A damped steel beam clamped at one end, welded to a rigid body at the other, the body pinned
    to the ground by a spherical joint: 6 + 3 constraint rows on a flexible model."""
    sec = SpatialSection.rectangle(E, E / (2.0 * (1.0 + NU)), 0.02, 0.01, RHO, damping=BETA)
    m = Mechanism("pinned_beam")
    m.add(SpatialRigidBody("tip", 0.3, (1e-4, 2e-4, 3e-4), position=(1.0, 0.0, 0.0)))
    spatial_beam(m, "beam", sec, [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0)], n, start="clamp", end="tip")
    m.add(SphericalJoint("pin", "ground", "tip", at=(1.0, 0.0, 0.0)))
    return m.compile()


def _io(model):
    q0 = model.q0
    ins = [fl.force(model, q0, "beam.n4", (0.0, 0.3, 1.0), name="F"),
           fl.torque(model, q0, "tip", (1.0, 0.0, 0.0), name="T")]
    outs = [fl.coordinate(model, "beam.n4.vz"), fl.coordinate(model, "beam.n4.vy", rate=True),
            fl.coordinate(model, "tip.Omega_x", rate=True)]
    return ins, outs


def test_sparse_and_dense_linearizations_agree():
    """Same eigenvalues (all 138) and Markov parameters C Aᵏ B, k = 0..3 (invariant under the change of
    basis between the orthonormal dense and the coordinate-partitioned sparse null space), same D."""
    model = _beam()
    assert model.nc == 9
    ins, outs = _io(model)
    d = fl.linearize(model, inputs=ins, outputs=outs)
    s = fl.linearize_sparse(model, inputs=ins, outputs=outs)
    assert s.sparse and not d.sparse
    As = s.dense_A()
    ed, es = np.linalg.eigvals(d.A), np.linalg.eigvals(As)
    assert max(np.min(np.abs(es - e)) for e in ed) < 1e-9 * np.abs(ed).max()
    for k in range(4):
        Md = d.C @ np.linalg.matrix_power(d.A, k) @ d.B
        Ms = s.C @ np.linalg.matrix_power(As, k) @ s.B
        assert np.abs(Md).max() > 0
        assert np.abs(Md - Ms).max() < 1e-9 * np.abs(Md).max(), k
    np.testing.assert_allclose(s.D, d.D, atol=1e-12 * max(1.0, np.abs(d.D).max()))
    # the physical state is the same: (δq, δv) of the sparse basis satisfy the constraints
    x = np.random.default_rng(1).standard_normal(s.n)
    dq = s.basis @ x
    assert np.abs(s.descriptor["W"] @ dq[:model.nq]).max() < 1e-12 * np.abs(dq).max()


def test_sparse_modes_match_dense_modes():
    model = _beam()
    s = fl.linearize_sparse(model)
    got = s.eig(n_modes=10).eigenvalues
    ev = fl.linearize(model).eig().eigenvalues
    want = ev[np.argsort(np.abs(ev))][:10]
    assert max(np.min(np.abs(got - w)) for w in want) < 1e-9 * np.abs(want).max()
    with pytest.raises(ParameterError, match="needs n_modes"):
        s.eig()


def test_auto_threshold_and_refusals(monkeypatch):
    model = _beam(6)
    monkeypatch.setattr(fl, "SPARSE_ABOVE", 20)
    lin = fl.linearize(model)
    assert lin.sparse
    monkeypatch.setattr(fl, "DENSE_STATES_MAX", 40)
    with pytest.raises(ParameterError, match=f"has {lin.n} states; a dense A would take"):
        lin.to_scipy()
    monkeypatch.setattr(fl, "DENSE_STATES_MAX", 5000)
    np.testing.assert_allclose(lin.to_scipy().A, lin.dense_A())
    assert not fl.linearize(model, outputs=[fl.reaction(model, "pin", 0)]).sparse   # dense: it takes reactions
    monkeypatch.setattr(fl, "DENSE_STATES_MAX", 40)
    with pytest.raises(ParameterError, match="large .* does not take reaction outputs, and the dense form"):
        fl.linearize(model, outputs=[fl.reaction(model, "pin", 0)])
    with pytest.raises(ParameterError, match="does not take symmetries"):
        fl.linearize(model, symmetries=[fl.translation((1.0, 0.0, 0.0))])
    with pytest.raises(ParameterError, match="linearize_sparse: .* does not take reaction outputs"):
        fl.linearize_sparse(model, outputs=[fl.reaction(model, "pin", 0)])


def test_sparse_form_with_rolling_constraints():
    """The upright coin at rest (1 holonomic, 2 non-holonomic rows: N_v ≠ N_q, ẏ = L_q N_v w): the sparse
    form has the dense form's eigenvalues; the lean root s² = m g r/(A + m r²) from the shift-invert of
    A_e − σE."""
    from femb.elements import SpatialGravity
    from femb.elements.rolling import RollingDisc
    m, r, g = 1.3, 0.4, 9.81
    A = m * r * r / 4.0
    mech = Mechanism("coin")
    mech.add(SpatialRigidBody("coin", m, (A, 2 * A, A), position=(0.0, 0.0, r)))
    mech.add(RollingDisc("contact", "coin", r, (0.0, 1.0, 0.0)))
    mech.add(SpatialGravity((0.0, 0.0, -g)))
    model = mech.compile()
    d = fl.linearize(model)
    s = fl.linearize_sparse(model)
    assert not s.descriptor["identity_kinematics"]
    ed, es = np.linalg.eigvals(d.A), np.linalg.eigvals(s.dense_A())
    assert max(np.min(np.abs(es - e)) for e in ed) < 1e-6      # a 6-fold (defective) zero: ε^(1/2)
    lean = np.sqrt(m * g * r / (A + m * r * r))
    assert max(np.min(np.abs(es - e)) for e in (lean, -lean)) < 1e-10 * lean
    got = s.eig(n_modes=1, sigma=4.0).eigenvalues
    assert abs(got[0] - lean) < 1e-10 * lean

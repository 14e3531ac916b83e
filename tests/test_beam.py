"""The planar Reissner beam element, the clamp and the meshing helper (elements/beam.py).

Kernel checks: Jacobians against central finite differences, internal forces
as the gradient of the strain energy, objectivity (rigid motions produce no
strain and no viscous stress), the stress-free reference of curved beams, the
mass matrix and gravity, the clamp's constraint derivatives, the meshing
helper, and the VTK output round trip.
"""
import math

import meshio
import numpy as np

from femb.system import kernels
import pytest

from femb import Mechanism
from femb.system import assembly
from femb.elements import (Clamp, Force, Gravity, Hinge, ReissnerBeam, RigidBody, Section, add_beam,
                           beam_resultants, beam_strain_energy)
from femb.errors import ModelError
from femb.io.frames import model_blocks
from femb.io.vtk import merge_blocks, write_vtu

SEC = Section(EA=1e3, GA=4e2, EI=2.0, rhoA=1.5, rhoI=2e-3)
SEC_D = Section(EA=1e3, GA=4e2, EI=2.0, rhoA=1.5, rhoI=2e-3, damping=0.03)


def _beam_model(section=SEC, n=5, sweep=0.8):
    m = Mechanism("beam")
    hub = m.add(RigidBody("hub", 2.0, 0.1, position=(0.1, -0.2), angle=0.3))
    add_beam(m, "b", section, (hub, (0.2, 0.0)), (1.4, 0.7), n, sweep=sweep)
    return m.compile()


def _group(model, cls):
    (g,) = [g for g in model.groups if g.cls is cls]
    return g


def _fd(fun, x, eps=1e-6):
    """Central differences of fun: (nel, nd) -> (nel, ...) with respect to x, element-wise."""
    f0 = fun(x)
    J = np.zeros(f0.shape + (x.shape[1],))
    for j in range(x.shape[1]):
        xp, xm = x.copy(), x.copy()
        xp[:, j] += eps
        xm[:, j] -= eps
        J[..., j] = (fun(xp) - fun(xm)) / (2 * eps)
    return J


def _random_state(model, g, rng, scale=0.2):
    qx = model.ext(model.q0 + scale * rng.standard_normal(model.nq))
    qdx = model.ext_velocity(rng.standard_normal(model.nq))
    return qx[g.dofs].copy(), qdx[g.dofs].copy()


@pytest.mark.parametrize("section", [SEC, SEC_D], ids=["elastic", "damped"])
@pytest.mark.parametrize("seed", [0, 1])
def test_force_jacobians_match_finite_differences(section, seed):
    model = _beam_model(section)
    g = _group(model, ReissnerBeam)
    assert g.traits["force_depends_on_qd"] == (section.damping != 0.0)
    qe, qde = _random_state(model, g, np.random.default_rng(seed))
    f, f_q, f_qd = kernels.force(g, 0.0, qe, qde, True)
    f2, _, _ = kernels.force(g, 0.0, qe, qde, False)
    np.testing.assert_array_equal(f, f2)
    Jq = _fd(lambda x: kernels.force(g, 0.0, x, qde, False)[0], qe)
    Jv = _fd(lambda v: kernels.force(g, 0.0, qe, v, False)[0], qde)
    np.testing.assert_allclose(f_q, Jq, rtol=0, atol=1e-7 * np.abs(Jq).max())
    if section.damping:
        np.testing.assert_allclose(f_qd, Jv, rtol=0, atol=1e-7 * np.abs(Jv).max())
    else:
        assert f_qd is None and np.abs(Jv).max() == 0.0


def test_internal_force_is_minus_the_energy_gradient_and_stiffness_symmetric():
    model = _beam_model()
    g = _group(model, ReissnerBeam)
    qe, qde = _random_state(model, g, np.random.default_rng(5), scale=0.5)
    f, f_q, _ = kernels.force(g, 0.0, qe, qde, True)
    dW = _fd(lambda x: g.cls.strain_energy(g.params, x), qe)
    np.testing.assert_allclose(f, -dW, rtol=0, atol=1e-7 * np.abs(dW).max())
    np.testing.assert_allclose(f_q, np.swapaxes(f_q, 1, 2), rtol=0, atol=1e-9 * np.abs(f_q).max())


def test_assembled_tangent_stiffness_matches_finite_differences():
    """K_t of a beam clamped to a hinged rigid body, with multipliers (assembly level)."""
    model = _beam_model(SEC_D, n=3)
    rng = np.random.default_rng(7)
    q = model.q0 + 0.1 * rng.standard_normal(model.nq)
    qd = rng.standard_normal(model.nq)
    lam = rng.standard_normal(model.nc)
    from femb import State
    st = State(0.0, q, qd, np.zeros(model.nq), lam)
    K = assembly.tangent_stiffness(model, st).toarray()
    C = assembly.tangent_damping(model, st).toarray()

    def r(qq, vv):
        return (-assembly.force_vector(model, 0.0, qq, vv)
                + assembly.constraint_force(model, 0.0, qq, lam))

    eps = 1e-6
    Kfd = np.column_stack([(r(q + eps * e, qd) - r(q - eps * e, qd)) / (2 * eps) for e in np.eye(model.nq)])
    Cfd = np.column_stack([(r(q, qd + eps * e) - r(q, qd - eps * e)) / (2 * eps) for e in np.eye(model.nq)])
    np.testing.assert_allclose(K, Kfd, rtol=0, atol=1e-6 * np.abs(Kfd).max())
    np.testing.assert_allclose(C, Cfd, rtol=0, atol=1e-6 * np.abs(Cfd).max())


def test_rigid_motion_is_strain_free_and_forces_rotate():
    """Objectivity: strains are invariant and viscous stresses vanish under rigid motions."""
    model = _beam_model(SEC_D)
    g = _group(model, ReissnerBeam)
    qe, _ = _random_state(model, g, np.random.default_rng(3), scale=0.3)
    a, c = 0.9, np.array([0.3, -1.2])
    R = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    qr = qe.copy()
    for k in (0, 3):
        qr[:, k:k + 2] = qe[:, k:k + 2] @ R.T + c
        qr[:, k + 2] += a
    np.testing.assert_allclose(g.cls.strains(g.params, qr), g.cls.strains(g.params, qe), atol=1e-13)
    # rigid velocity field: v = v0 + ω J r, θ̇ = ω
    w, v0 = 1.7, np.array([0.4, -0.2])
    qd = np.zeros_like(qe)
    for k in (0, 3):
        qd[:, k] = v0[0] - w * qe[:, k + 1]
        qd[:, k + 1] = v0[1] + w * qe[:, k]
        qd[:, k + 2] = w
    np.testing.assert_allclose(g.cls.strain_rates(g.params, qe, qd), 0.0, atol=1e-13)
    f0 = kernels.force(g, 0.0, qe, np.zeros_like(qe), False)[0]
    fr = kernels.force(g, 0.0, qr, np.zeros_like(qe), False)[0]
    for k in (0, 3):
        np.testing.assert_allclose(fr[:, k:k + 2], f0[:, k:k + 2] @ R.T, atol=1e-10)
        np.testing.assert_allclose(fr[:, k + 2], f0[:, k + 2], atol=1e-10)


def test_curved_reference_is_stress_free():
    model = _beam_model(sweep=-2.5, n=7)
    f = assembly.force_vector(model, 0.0, model.q0, np.zeros(model.nq))
    assert np.abs(f).max() < 1e-12
    assert beam_strain_energy(model, model.q0) < 1e-25
    for N, V, M in beam_resultants(model, model.q0).values():
        assert abs(N) < 1e-12 and abs(V) < 1e-12 and abs(M) < 1e-12


@pytest.mark.parametrize("mass", ["consistent", "lumped"])
def test_mass_matrix_and_gravity(mass):
    L, n = 2.0, 4
    m = Mechanism("g")
    b = add_beam(m, "b", SEC, (0.0, 0.0), (L, 0.0), n, mass=mass)
    m.add(Gravity((0.0, -9.81)))
    model = m.compile()
    assert model.constant_mass
    M = assembly.mass_matrix(model).toarray()
    np.testing.assert_allclose(M, M.T)
    assert np.all(np.linalg.eigvalsh(M) > 0)
    ones_x = np.zeros(model.nq)
    ones_x[0::3] = 1.0
    assert ones_x @ M @ ones_x == pytest.approx(SEC.rhoA * L, rel=1e-14)      # total mass
    ones_t = np.zeros(model.nq)
    ones_t[2::3] = 1.0
    assert ones_t @ M @ ones_t == pytest.approx(SEC.rhoI * L, rel=1e-14)
    f = assembly.force_vector(model, 0.0, model.q0, np.zeros(model.nq))
    assert f[1::3].sum() == pytest.approx(-9.81 * SEC.rhoA * L, rel=1e-14)   # weight
    np.testing.assert_allclose(f[1::3], -9.81 * SEC.rhoA * L / n * np.r_[0.5, np.ones(n - 1), 0.5])
    assert len(b.nodes) == n + 1


def test_clamp_constraint_derivatives():
    m = Mechanism("clamp")
    a = m.add(RigidBody("a", 1.0, 0.1, position=(0.2, 0.1), angle=0.4))
    b = m.add(RigidBody("b", 1.0, 0.1, position=(0.9, -0.3), angle=-0.7))
    m.add(Clamp("c", a, b, point_a=(0.3, 0.2), point_b=(-0.2, 0.1)))
    m.add(Clamp("cg", "ground", b, point_a=(1.0, 1.0), point_b=(0.1, 0.0)))
    model = m.compile()
    g = _group(model, Clamp)
    rng = np.random.default_rng(2)
    qe, qde = _random_state(model, g, rng, scale=0.5)
    lame = rng.standard_normal((g.nel, 3))
    Phi, Phi_q, H = kernels.constraint(g, 0.0, qe, lame, jac=True)
    P2, Pq2, _ = kernels.constraint(g, 0.0, qe, jac=False)
    np.testing.assert_array_equal(Phi, P2)
    np.testing.assert_array_equal(Phi_q, Pq2)
    np.testing.assert_allclose(Phi_q, _fd(lambda x: kernels.constraint(g, 0.0, x, jac=False)[0], qe), atol=1e-9)
    Hfd = _fd(lambda x: np.einsum("ecd,ec->ed", kernels.constraint(g, 0.0, x, jac=False)[1], lame), qe)
    np.testing.assert_allclose(H, Hfd, atol=1e-9)
    np.testing.assert_allclose(kernels.constraint(g, 0.0, qe, lame, jac=True)[2], H)
    Phi_t, gam = kernels.rates(g, 0.0, qe, qde)
    # γ = (Φ_q q̇)_q q̇
    Pqv = _fd(lambda x: np.einsum("ecd,ed->ec", kernels.constraint(g, 0.0, x, jac=False)[1], qde), qe)
    np.testing.assert_allclose(gam, np.einsum("ecd,ed->ec", Pqv, qde), atol=1e-8)
    assert np.all(Phi_t == 0.0)
    # the initial configuration satisfies the clamps (at=None: points as given, so not here)
    assert model.nc == 6


def test_add_beam_geometry_names_and_joints():
    m = Mechanism("mesh")
    hub = m.add(RigidBody("hub", 1.0, 0.1, position=(0.0, 0.0)))
    slider = m.add(RigidBody("sl", 1.0, 0.1, position=(2.0, 1.0)))
    R_sweep = math.pi / 2
    b = add_beam(m, "arc", SEC, hub, slider, 8, sweep=R_sweep, end_joint="hinge")
    assert b.node_names == [f"arc.n{k}" for k in range(9)]
    assert isinstance(b.joints["start"], Clamp) and isinstance(b.joints["end"], Hinge)
    xy = np.array([nd.node.q0[:2] for nd in b.nodes])
    th = np.array([nd.node.q0[2] for nd in b.nodes])
    # quarter circle from (0, 0) to (2, 1): radius |chord| / (2 sin(π/4)), tangent turns by π/2
    R = math.hypot(2.0, 1.0) / (2 * math.sin(math.pi / 4))
    centre = xy[0] + R * np.array([-math.sin(th[0]), math.cos(th[0])])
    np.testing.assert_allclose(np.hypot(*(xy - centre).T), R, rtol=1e-12)
    np.testing.assert_allclose(np.diff(th), R_sweep / 8, rtol=1e-12)
    np.testing.assert_allclose(xy[-1], (2.0, 1.0), atol=1e-14)
    assert b.length == pytest.approx(R * R_sweep)
    model = m.compile()
    assert model.nc == 5
    # shared end: the beam's first node is the hub's node (no constraint)
    m2 = Mechanism("shared")
    hub2 = m2.add(RigidBody("hub", 1.0, 0.1, position=(0.0, 0.0)))
    b2 = add_beam(m2, "b", SEC, hub2, (1.0, 0.0), 4, start_joint="shared")
    assert b2.nodes[0] is hub2 and b2.joints["start"] is None
    model2 = m2.compile()
    assert model2.nc == 0 and model2.nq == 15
    # a free plain-point beam has no joints
    m3 = Mechanism("free")
    b3 = add_beam(m3, "b", SEC, (0.0, 0.0), (0.0, 1.0), 2)
    assert b3.joints == {"start": None, "end": None}


def test_add_beam_rejects_bad_input():
    m = Mechanism("bad")
    with pytest.raises(ModelError, match="n_elements"):
        add_beam(m, "b", SEC, (0, 0), (1, 0), 0)
    with pytest.raises(ModelError, match="coincide"):
        add_beam(m, "b", SEC, (0, 0), (0, 0), 2)
    with pytest.raises(ModelError, match="Section"):
        add_beam(m, "b", {"EA": 1.0}, (0, 0), (1, 0), 2)
    with pytest.raises(ModelError, match="start_joint"):
        add_beam(m, "b", SEC, (0, 0), (1, 0), 2, start_joint="weld")
    with pytest.raises(ModelError, match="shared"):
        add_beam(m, "b", SEC, (0, 0), (1, 0), 2, start_joint="shared")
    with pytest.raises(ModelError, match="positive"):
        Section(EA=0.0, GA=1.0, EI=1.0, rhoA=1.0, rhoI=1.0)
    hub = m.add(RigidBody("hub", 1.0, 0.1, position=(0.5, 0.0)))
    with pytest.raises(ModelError, match="shared end"):
        add_beam(m, "c", SEC, (hub, (0.1, 0.0)), (2, 0), 2, start_joint="shared")


def test_section_constructors():
    s = Section.rectangle(E=2e11, G=8e10, width=0.02, height=0.01, density=7800.0)
    assert s.EA == pytest.approx(2e11 * 2e-4)
    assert s.EI == pytest.approx(2e11 * 0.02 * 1e-6 / 12)
    assert s.GA == pytest.approx(5 / 6 * 8e10 * 2e-4)
    assert s.rhoI == pytest.approx(7800.0 * 0.02 * 1e-6 / 12)
    c = Section.circle(E=1.0, G=1.0, diameter=2.0, density=1.0)
    assert c.EA == pytest.approx(math.pi) and c.EI == pytest.approx(math.pi / 4)


def test_vtk_output_round_trip(tmp_path):
    """Beams as line cells through their nodes with axial/shear force and bending moment."""
    m = Mechanism("out")
    b = add_beam(m, "b", SEC_D, m.ground, (1.0, 0.0), 4)
    m.add(Force("P", b.nodes[-1], (0.0, -1.0)))
    model = m.compile()
    rng = np.random.default_rng(0)
    q = model.q0 + 0.01 * rng.standard_normal(model.nq)
    qd = rng.standard_normal(model.nq)
    lam = rng.standard_normal(model.nc)
    blocks = model_blocks(model, 0.0, q, qd, lam)
    (bb,) = [x for x in blocks if x.name == "ReissnerBeam"]
    assert bb.cells[0][0] == "line" and bb.cells[0][1].shape == (4, 2)
    np.testing.assert_allclose(bb.points[bb.cells[0][1][:, 0], :2], [model.node_coordinates(f"b.n{k}", q)[:2]
                                                                   for k in range(4)])
    res = beam_resultants(model, q, qd)
    np.testing.assert_allclose(bb.cell_data["axial_force"][0], [res[f"b.e{k}"][0] for k in range(4)])
    np.testing.assert_allclose(bb.cell_data["bending_moment"][0], [res[f"b.e{k}"][2] for k in range(4)])
    path = tmp_path / "beam.vtu"
    write_vtu(path, merge_blocks(blocks))
    back = meshio.read(path)
    lines = [c for c in back.cells if c.type == "line"]
    assert sum(len(c.data) for c in lines) == 4
    for name in ("axial_force", "shear_force", "bending_moment"):
        got = np.concatenate([d for c, d in zip(back.cells, back.cell_data[name]) if c.type == "line"])
        np.testing.assert_allclose(got, bb.cell_data[name][0])

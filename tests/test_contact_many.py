"""Many contacts on the sparse path, and a slip that ends within a step.

* diag(W M⁻¹ Wᵀ) (the prox parameters of the sparse path) with one solve per colour of rows on
  disjoint components of M equals the dense formula, rows spanning two components included;
* a sphere whose slip ends within a step (its solution a slip speed of 1e-5 m/s) converges in a few
  semismooth Newton iterations on every path (before the damped step: the 40 iterations failed, cycling
  across γ_F = 0, and the prox fixed point took 523), to the same state;
* the many-spheres scene against its closed form: each sphere starts rolling in the step holding
  t_r = |v_c| / (3.5 μ g), at the rolling velocity (5/7)(v_x + (2/5) R ω_y, v_y − (2/5) R ω_x).
"""
import numpy as np
import pytest
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from scipy.sparse import csgraph

from femb import Mechanism
from femb.benchmarks.scenes.contact import contact_spheres
from femb.contact import simulate
from femb.contact import step as contact_step
from femb.contact.step import diag_W_Minv_Wt
from femb.elements import SpatialGravity, SpatialRigidBody
from femb.elements.contact import SpatialSphereOnPlane


def test_prox_diagonal_by_components_equals_the_dense_formula():
    rng = np.random.default_rng(3)
    sizes = (3, 6, 6, 2, 6, 1)
    blocks = []
    for b in sizes:
        A = rng.normal(size=(b, b))
        blocks.append(A @ A.T + b * np.eye(b))
    M = sp.block_diag(blocks).tocsc()
    n = M.shape[0]
    comp = csgraph.connected_components(M, directed=False)[1]
    starts = np.concatenate(([0], np.cumsum(sizes)))
    rows = []
    for c in range(len(sizes)):                      # three rows on each component
        for _ in range(3):
            w = np.zeros(n)
            w[starts[c]:starts[c + 1]] = rng.normal(size=sizes[c])
            rows.append(w)
    for a, b in ((0, 1), (1, 2), (4, 5)):            # pair rows across two components
        w = np.zeros(n)
        w[starts[a]:starts[a + 1]] = rng.normal(size=sizes[a])
        w[starts[b]:starts[b + 1]] = rng.normal(size=sizes[b])
        rows.append(w)
    W = np.array(rows)
    G = diag_W_Minv_Wt(sp.csr_matrix(W), spla.splu(M), comp)
    G_dense = np.einsum("ij,ji->i", W, np.linalg.solve(M.toarray(), W.T))
    np.testing.assert_allclose(G, G_dense, rtol=1e-13)


def _sphere(v, w, mu=0.3, radius=0.05):
    th = 0.4 * radius * radius
    m = Mechanism("sphere_slip_ends")
    m.add(SpatialRigidBody("s", 1.0, (th, th, th), position=(0.0, 0.0, radius), velocity=v, omega=w))
    m.add(SpatialSphereOnPlane("c", "s", radius=radius, mu=mu))
    m.add(SpatialGravity((0.0, 0.0, -9.81)))
    return m.compile()


#: sphere 96 of contact_spheres.build(n=100): its slip ends 2e-5 m/s short of zero at the end of step 9
SLIP_ENDS = ((0.03916854039669164, -0.00807463806201366, 0.0), (-0.470175793281739, -0.9602824536814834,
                                                                 -0.4224914444756691))


@pytest.mark.parametrize("path", ["compiled", "python", "sparse"])
def test_a_slip_ending_within_a_step_converges_in_newton(path, monkeypatch):
    ref = simulate(_sphere(*SLIP_ENDS), 0.02, 1e-3, compiled=True)
    if path == "sparse":
        monkeypatch.setattr(contact_step, "DENSE_MAX_UNKNOWNS", 0)
    r = simulate(_sphere(*SLIP_ENDS), 0.02, 1e-3, compiled=(path == "compiled"))
    assert r.newton_iterations.max() <= 10          # 523 (prox fixed point) before the damped step
    v, w = np.array(SLIP_ENDS[0]), np.array(SLIP_ENDS[1])
    R = 0.05
    v_roll = 5.0 / 7.0 * np.array([v[0] + 0.4 * R * w[1], v[1] - 0.4 * R * w[0]])
    np.testing.assert_allclose(r.qd[-1, :2], v_roll, atol=1e-5)
    assert np.array(r.contact_state("c"))[-1] == "stick"
    np.testing.assert_allclose(r.q, ref.q, atol=1e-12)


def test_many_spheres_roll_as_the_closed_form():
    n, h = 30, 1e-3                                   # 30 spheres: the sparse path
    res = simulate(contact_spheres.build(n=n).compile(), 0.02, h)
    ref = contact_spheres.reference(n=n)
    assert res.newton_iterations.max() <= 10
    for i in range(n):
        st = np.array(res.contact_state(f"c{i}"))
        k = np.nonzero(st == "stick")[0]
        assert k.size and st[k[0]:].tolist() == ["stick"] * (st.size - k[0])
        t_stick = res.t[k[0]]
        assert t_stick - h - 1e-12 <= ref["t_roll"][i] <= t_stick + 1e-12
        v_end = [res.series(f"s{i}.x_d")[0][-1], res.series(f"s{i}.y_d")[0][-1]]
        np.testing.assert_allclose(v_end, ref["v_roll"][i], atol=1e-5)
    out = contact_spheres.outputs(res)
    assert out["lambda_N"][-1] == pytest.approx(n * 9.81, rel=1e-12)
    assert res.contact["gN"].min() >= -1e-10 * res.model.length_scale

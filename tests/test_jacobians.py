"""Analytic Jacobians of every element type against central finite differences."""
import numpy as np
import pytest

from femb import GeneralizedAlpha, State
from femb.system import assembly, kernels

def _random_qe(model, g, rng):
    qx = model.ext(model.q0 + 0.1 * rng.standard_normal(model.nq))
    qdx = model.ext_velocity(rng.standard_normal(model.nq))
    return qx[g.dofs].copy(), qdx[g.dofs].copy()


def _blockwise(fun, qe):
    """d fun(qe)/d qe element by element: fun maps (nel, nd) -> (nel, ...)."""
    nel, nd = qe.shape
    f0 = fun(qe)
    J = np.zeros(f0.shape + (nd,))
    eps = 1e-6
    for j in range(nd):
        qp = qe.copy()
        qm = qe.copy()
        qp[:, j] += eps
        qm[:, j] -= eps
        J[..., j] = (fun(qp) - fun(qm)) / (2 * eps)
    return J


@pytest.mark.parametrize("trial", range(3))
def test_force_jacobians(every_model, trial):
    rng = np.random.default_rng(trial)
    m = every_model
    t = 0.37 + trial
    checked = 0
    for g in m.force_groups:
        qe, qde = _random_qe(m, g, rng)
        f, f_q, f_qd = kernels.force(g, t, qe, qde, True)
        f2, _, _ = kernels.force(g, t, qe, qde, False)
        np.testing.assert_allclose(f, f2, rtol=0, atol=0)
        Jq = _blockwise(lambda x: kernels.force(g, t, x, qde, False)[0], qe)
        np.testing.assert_allclose(f_q, Jq, rtol=1e-6, atol=1e-7 * max(1.0, np.abs(Jq).max()),
                                   err_msg=f"{g.name} df/dq")
        Jv = _blockwise(lambda v: kernels.force(g, t, qe, v, False)[0], qde)
        if g.traits["force_depends_on_qd"]:
            np.testing.assert_allclose(f_qd, Jv, rtol=1e-6, atol=1e-7 * max(1.0, np.abs(Jv).max()),
                                       err_msg=f"{g.name} df/dqd")
        else:
            assert np.abs(Jv).max() == 0.0, f"{g.name} depends on qd but does not say so"
        checked += 1
    assert checked >= 4


@pytest.mark.parametrize("trial", range(3))
def test_constraint_jacobians_hessians_and_rates(every_model, trial):
    rng = np.random.default_rng(100 + trial)
    m = every_model
    t = 0.21 + 0.5 * trial
    names = set()
    for g in m.constraint_groups:
        qe, qde = _random_qe(m, g, rng)
        lame = rng.standard_normal((g.nel, g.nc))
        con = lambda x, tt=t: kernels.constraint(g, tt, x, jac=False)[:2]
        Phi, Phi_q = con(qe)
        Phi2, Phi_q2, H = kernels.constraint(g, t, qe, lame, jac=True)
        np.testing.assert_allclose(Phi, Phi2, atol=1e-15)
        np.testing.assert_allclose(Phi_q, Phi_q2, atol=1e-15)
        J = _blockwise(lambda x: con(x)[0], qe)
        np.testing.assert_allclose(Phi_q, J, rtol=1e-7, atol=1e-8, err_msg=f"{g.name} Phi_q")
        # ∂(Φ_qᵀλ)/∂q
        Hfd = _blockwise(lambda x: np.einsum("ecd,ec->ed", con(x)[1], lame), qe)
        np.testing.assert_allclose(H, Hfd, rtol=1e-6, atol=1e-7, err_msg=f"{g.name} hessian")
        # Φ_t and γ = d²/ds² Φ(q + s q̇, t + s) at s = 0
        Phi_t, gam = kernels.rates(g, t, qe, qde)
        eps = 1e-6
        Pt = (con(qe, t + eps)[0] - con(qe, t - eps)[0]) / (2 * eps)
        np.testing.assert_allclose(Phi_t, Pt, rtol=1e-6, atol=1e-8, err_msg=f"{g.name} Phi_t")
        e2 = 1e-4
        d2 = (con(qe + e2 * qde, t + e2)[0] - 2 * Phi + con(qe - e2 * qde, t - e2)[0]) / e2 ** 2
        np.testing.assert_allclose(gam, d2, rtol=1e-5, atol=1e-5, err_msg=f"{g.name} gamma")
        names.add(g.name)
    assert names == {"Hinge", "Slider", "PointOnLine", "DrivenAngle", "DrivenDisplacement"}


@pytest.mark.parametrize("scaled", [True, False])
def test_global_iteration_matrix_matches_newton_residual(every_model, scaled):
    """S_t = d(residual)/d(Δq, Δλ) along the Newton update of Algorithm 1."""
    rng = np.random.default_rng(7)
    m = every_model
    al = GeneralizedAlpha.from_rho_inf(0.6)
    h = 1e-2
    bp, gp = al.newton_factors(h)
    c = al.beta * h * h if scaled else 1.0
    q = m.q0 + 0.05 * rng.standard_normal(m.nq)
    qd = rng.standard_normal(m.nq)
    qdd = rng.standard_normal(m.nq)
    lam = rng.standard_normal(m.nc)
    t = 0.3

    def res(x):
        dq, dl = x[:m.nq], x[m.nq:] / c
        st = State(t, q + dq, qd + gp * dq, qdd + bp * dq, lam + dl)
        r_q, r_l = assembly.residual(m, st)
        return np.concatenate((c * r_q, r_l))

    S = assembly.iteration_matrix(m, State(t, q, qd, qdd, lam), h, al, scaled=scaled).toarray()
    x0 = np.zeros(m.nq + m.nc)
    eps = 1e-7 if scaled else 1e-8
    J = np.zeros_like(S)
    for j in range(x0.size):
        xp = x0.copy()
        xm = x0.copy()
        xp[j] += eps
        xm[j] -= eps
        J[:, j] = (res(xp) - res(xm)) / (2 * eps)
    np.testing.assert_allclose(S, J, rtol=1e-5, atol=1e-6 * np.abs(S).max())


@pytest.mark.parametrize("ordering", ["rcm", "natural"])
def test_compiled_evaluate_equals_user_functions(every_model, ordering):
    """The generated compiled evaluate() (band storage, reordered) and the documented functions agree."""
    from femb.solve.codegen import evaluate_dense
    rng = np.random.default_rng(3)
    m = every_model
    al = GeneralizedAlpha.from_rho_inf(0.8)
    h = 2e-3
    st = State(0.4, m.q0 + 0.05 * rng.standard_normal(m.nq), rng.standard_normal(m.nq),
               rng.standard_normal(m.nq), rng.standard_normal(m.nc))
    S_ref = assembly.iteration_matrix(m, st, h, al, scaled=True).toarray()
    r_ref = assembly.residual(m, st)
    r_q, Phi, scale, S = evaluate_dense(m, st, h, al, scaled=True, ordering=ordering)
    np.testing.assert_allclose(S, S_ref, rtol=1e-12, atol=1e-12 * np.abs(S_ref).max())
    np.testing.assert_allclose(r_q, r_ref[0], rtol=1e-12, atol=1e-12 * np.abs(r_ref[0]).max())
    np.testing.assert_allclose(Phi, r_ref[1], rtol=1e-12, atol=1e-15)
    assert scale > 0

"""Finite-difference checks of contact kernels (docs/contact.md §3).

For every contact batch of a model, at a randomly moved state with random velocities and
forces, compare

* W_N with central differences of g_N along x ∘ exp(εw) (each velocity direction w);
* ζ = (W v)_x v with the central difference of W(x ∘ exp(εv)) v in ε;
* H = ∂(Wᵀλ)/∂x with central differences of Wᵀλ along x ∘ exp(εw);
* W_F with the central difference, along x ∘ exp(εv), of the tangent displacement of the
  contact point, t·(position of the contact point), only where the type provides it
  (``slip_points``); otherwise W_F enters through ζ_F and H only.
"""
from __future__ import annotations

import numpy as np

from femb.analysis.checks import JacobianCheck, JacobianReport
from femb.contact import assemble
from femb.errors import ParameterError


def _rel(A, B):
    A, B = np.asarray(A), np.asarray(B)
    scale = max(float(np.max(np.abs(B))) if B.size else 0.0, 1e-12)
    return float(np.max(np.abs(A - B))) / scale if A.size else 0.0, scale


def check_contact_kernels(model, seed=0, eps=1e-6, rtol=1e-6, move=0.3, q=None):
    """Compare the contact kernels' derivatives with central differences.

    Parameters
    ----------
    model : Model
        A compiled model with contact elements.
    seed : int
    eps : float
        Difference step (along unit-size directions of the velocity coordinates).
    rtol : float
        Relative error counted as agreement.
    move : float
        Size of the random move of the state away from the initial one.
    q : ndarray, shape like ``model.q0``, optional
        The state to move from (default: the model's initial coordinates ``model.q0``).

    Returns
    -------
    femb.analysis.checks.JacobianReport
    """
    rng = np.random.default_rng(seed)
    nq = model.nq
    q0 = model.q0 if q is None else np.asarray(q, dtype=float)
    if q0.shape != model.q0.shape or not np.all(np.isfinite(q0)):
        raise ParameterError(f"check_contact_kernels: q must be {model.q0.size} finite coordinates of model "
                             f"'{model.name}', got shape {q0.shape}")
    q = model.compose(q0, move * rng.standard_normal(nq))
    u = rng.standard_normal(nq)
    lN = rng.standard_normal(model.n_contacts)
    lF = rng.standard_normal(model.n_friction)
    rep = JacobianReport(rtol=rtol)
    base = assemble.evaluate(model, 0.0, q, u, lN, lF, jac=True)
    WN, WF = base["WN"].toarray(), base["WF"].toarray()
    W = np.vstack((WN, WF))
    fdN = np.zeros_like(WN)
    fdH = np.zeros((nq, nq))
    for j in range(nq):
        d = np.zeros(nq)
        d[j] = eps
        p = assemble.evaluate(model, 0.0, model.compose(q, d), u)
        m = assemble.evaluate(model, 0.0, model.compose(q, -d), u)
        fdN[:, j] = (p["gN"] - m["gN"]) / (2 * eps)
        fp = p["WN"].T @ lN + p["WF"].T @ lF
        fm = m["WN"].T @ lN + m["WF"].T @ lF
        fdH[:, j] = (fp - fm) / (2 * eps)
    p = assemble.evaluate(model, 0.0, model.compose(q, eps * u), u)
    m = assemble.evaluate(model, 0.0, model.compose(q, -eps * u), u)
    fdZ = (np.vstack((p["WN"].toarray(), p["WF"].toarray())) @ u
           - np.vstack((m["WN"].toarray(), m["WF"].toarray())) @ u) / (2 * eps)
    Z = np.concatenate((base["zN"], base["zF"]))
    types = ", ".join(sorted({g.cls.__name__ for g in model.contact_groups}))
    for what, A, B in (("W_N = ∂g_N/∂q", WN, fdN), ("ζ = (W v)_q v", Z, fdZ),
                       ("H = ∂(Wᵀλ)/∂q", base["H"].toarray(), fdH)):
        err, scale = _rel(A, B)
        rep.checks.append(JacobianCheck(types, model.name, what, err, scale, err <= rtol))
    del W
    return rep

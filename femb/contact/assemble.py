"""Global contact quantities of a model: gaps, W_N, W_F, curvature terms, ∂(Wᵀλ)/∂q.

The contact batches of a model (element types with ``n_contacts`` > 0, role ``"contact"``,
docs/contact.md §3) are evaluated by their compiled kernels and scattered into global,
sparse operators in the model's velocity coordinates (size ``nq``).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from femb.system import kernels


@dataclass
class ContactLayout:
    """The contacts of a model, fixed at compile time.

    Attributes
    ----------
    nN, nF : int
        Normal contacts and tangent directions.
    names : list of str
        Element name of each normal contact (nN,).
    e_N, e_F, mu : ndarray, shape (nN,)
        Impact and friction laws per contact.
    friction : list of ndarray
        Indices of the tangent directions of each contact (into the nF rows).
    """

    nN: int
    nF: int
    names: list
    e_N: np.ndarray
    e_F: np.ndarray
    mu: np.ndarray
    friction: list

    @property
    def e_F_rows(self):
        """e_F per tangent direction (nF,)."""
        out = np.zeros(self.nF)
        for i, idx in enumerate(self.friction):
            out[idx] = self.e_F[i]
        return out


def layout(model):
    """The :class:`ContactLayout` of a compiled model."""
    nN, nF = int(getattr(model, "n_contacts", 0)), int(getattr(model, "n_friction", 0))
    names = [""] * nN
    e_N, e_F, mu = np.zeros(nN), np.zeros(nN), np.zeros(nN)
    fr = [np.zeros(0, dtype=np.int64)] * nN
    for g in getattr(model, "contact_groups", []):
        kN = g.cN.shape[1]
        for j, el in enumerate(g.elements):
            for k in range(kN):
                i = g.cN[j, k]
                names[i] = el.name if kN == 1 else f"{el.name}.{k}"
                e_N[i], e_F[i], mu[i] = el.e_N, el.e_F, el.mu
                fr[i] = g.cF[j].copy() if kN == 1 else np.zeros(0, dtype=np.int64)
    return ContactLayout(nN, nF, names, e_N, e_F, mu, fr)


def _rows(g):
    """Global row of each of a batch's kernel rows (normal rows first, then tangent rows + nN)."""
    return g.cN, g.cF


def evaluate(model, t, q, u, lam_N=None, lam_F=None, jac=False, dense=False):
    """Gaps and contact operators at (t, q, u).

    Parameters
    ----------
    model : Model
    t : float
    q : ndarray, shape (nx,)
    u : ndarray, shape (nq,)
    lam_N, lam_F : ndarray, shapes (nN,), (nF,), optional
        Contact forces for the curvature matrix ``H`` (with ``jac``).
    jac : bool
    dense : bool
        Return WN, WF, H as dense arrays (small models: no sparse overhead).

    Returns
    -------
    dict
        ``gN (nN,)``; ``WN (nN, nq)`` and ``WF (nF, nq)`` (csr); ``zN (nN,)``, ``zF (nF,)``
        (g̈_N = W_N u̇ + ζ_N, γ̇_F = W_F u̇ + ζ_F); ``H (nq, nq)`` csr = ∂(W_Nᵀλ_N + W_Fᵀλ_F)/∂q
        with ``jac``.
    """
    nq, nN, nF = model.nq, model.n_contacts, model.n_friction
    qx = model.ext(np.asarray(q, dtype=float))
    ux = model.ext_velocity(np.asarray(u, dtype=float))
    gN = np.zeros(nN)
    zN, zF = np.zeros(nN), np.zeros(nF)
    rN, cN, vN, rF, cF, vF = [], [], [], [], [], []
    Hr, Hc, Hv = [], [], []
    for g in model.contact_groups:
        kN = g.cN.shape[1]
        le = None
        if jac:
            le = np.hstack((np.zeros(g.cN.shape) if lam_N is None else lam_N[g.cN],
                            np.zeros(g.cF.shape) if lam_F is None else lam_F[g.cF]))
        G, W, Z, H = kernels.contact(g, t, qx[g.xdofs], ux[g.dofs], le, jac)
        gN[g.cN] = G
        zN[g.cN] = Z[:, :kN]
        zF[g.cF] = Z[:, kN:]
        free = g.dofs < nq
        for rows, blk, R, C, V in ((g.cN, W[:, :kN], rN, cN, vN), (g.cF, W[:, kN:], rF, cF, vF)):
            if rows.shape[1] == 0:
                continue
            m = np.broadcast_to(free[:, None, :], blk.shape)
            R.append(np.broadcast_to(rows[:, :, None], blk.shape)[m])
            C.append(np.broadcast_to(g.dofs[:, None, :], blk.shape)[m])
            V.append(blk[m])
        if jac:
            m = free[:, :, None] & free[:, None, :]
            Hr.append(np.broadcast_to(g.dofs[:, :, None], H.shape)[m])
            Hc.append(np.broadcast_to(g.dofs[:, None, :], H.shape)[m])
            Hv.append(H[m])

    def mat(R, C, V, n):
        if dense:
            out = np.zeros((n, nq))
            for r, c, v in zip(R, C, V):
                np.add.at(out, (r, c), v)
            return out
        if not R:
            return sp.csr_matrix((n, nq))
        return sp.csr_matrix((np.concatenate(V), (np.concatenate(R), np.concatenate(C))), shape=(n, nq))

    out = {"gN": gN, "WN": mat(rN, cN, vN, nN), "WF": mat(rF, cF, vF, nF), "zN": zN, "zF": zF}
    if jac:
        out["H"] = mat(Hr, Hc, Hv, nq)
    return out

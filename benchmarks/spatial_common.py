"""Helpers shared by the spatial scenes: rotations of results, initial constraint checks.

The spatial scenes (:mod:`.heavy_top`, :mod:`.spatial_slider_crank`,
:mod:`.bricard`, :mod:`.spatial_double_pendulum`) need the Lie-group time loop
to run; until it exists, :func:`initial_constraints` evaluates their joints'
compiled kernels in the initial configuration (Φ, B, B v0 + Φ_t) without the
model compiler, and :func:`redundancy` reports the rank of B there.

Result access assumed by the scenes' ``outputs`` (the planar ``Result`` API
extended to frame nodes): ``result.body(name)`` → (nt, 7) node coordinates
(r, p), ``result.body(name, "qd")`` → (nt, 6) (ṙ, Ω body axes),
``result.body(name, "qdd")`` → (nt, 6), ``result.reaction(name)`` → (nt, nc).
"""
from __future__ import annotations

import numpy as np

from femb import rotations as rt
from femb.elements.forces import Gravity
from femb.elements.spatial_bodies import FrameNode


def rotation_matrices(x):
    """Rotation matrices of node coordinates x (..., 7) (quaternion in x[..., 3:7]), shape (..., 3, 3)."""
    x = np.asarray(x, dtype=float)
    flat = x.reshape(-1, x.shape[-1])
    R = np.array([rt.quat_to_matrix(np.ascontiguousarray(row[3:7] / np.linalg.norm(row[3:7]))) for row in flat])
    return R.reshape(x.shape[:-1] + (3, 3))


def point_positions(x, X):
    """Inertial positions (nt, 3) of the body point X (body axes) for node coordinates x (nt, 7)."""
    R = rotation_matrices(x)
    return np.asarray(x)[:, :3] + np.einsum("nij,j->ni", R, np.asarray(X, dtype=float))


def resolve(mech):
    """Resolve and validate the elements of a spatial mechanism (as the model compiler does)."""
    def lookup(ref, role):
        return mech[ref] if isinstance(ref, str) else ref

    els = [e for e in mech.elements if not isinstance(e, Gravity)]
    for e in els:
        e.resolve(lookup)
        e.validate()
    return els


def _numbering(els):
    nodes, seen = [], set()
    for e in els:
        for nd in e.nodes():
            if id(nd) not in seen:
                seen.add(id(nd))
                nodes.append(nd)
    index, k = {}, 0
    for nd in nodes:
        if not isinstance(nd, FrameNode):
            raise TypeError(f"node '{nd.name}' is not a spatial frame node")
        idx = np.full(6, -1)
        for c in range(6):
            if not nd.fixed_v[c]:
                idx[c] = k
                k += 1
        index[id(nd)] = idx
    return nodes, index, k


def initial_constraints(mech, t=0.0):
    """Constraint values, Jacobian and velocity residual of a spatial mechanism at t0.

    Returns
    -------
    dict with ``Phi`` (nc,), ``B`` (nc, nv) (free velocity columns), ``v0``
    (nv,), ``velocity_residual`` = B v0 + Φ_t (nc,), ``rows`` (list of
    "joint.row" names), ``nv``.
    """
    els = resolve(mech)
    nodes, index, nv = _numbering(els)
    Phi, B, rows, Phi_t = [], [], [], []
    v0 = np.zeros(nv)
    for nd in nodes:
        idx = index[id(nd)]
        v0[idx[idx >= 0]] = nd.qd0[idx >= 0]
    for e in els:
        if not e.n_constraints:
            continue
        cls = type(e)
        P = cls.pack([e])["P"]
        nc = e.n_constraints
        x = np.concatenate([nd.q0 for nd in e.nodes()])[None]
        v = np.concatenate([nd.qd0 for nd in e.nodes()])[None]
        fns = cls.time_functions(e) if hasattr(cls, "time_functions") else []
        tf = np.array([[[fn.f(t), fn.df(t), fn.ddf(t)] for fn in fns]]).reshape(1, len(fns), 3)
        ph = np.zeros((1, nc))
        Be = np.zeros((1, nc, 12))
        He = np.zeros((1, 12, 12))
        e.kernels["constraint"](P, float(t), tf, x, np.zeros((1, nc)), False, ph, Be, He)
        pt = np.zeros((1, nc))
        gam = np.zeros((1, nc))
        e.kernels["rates"](P, float(t), tf, x, v, pt, gam)
        Bg = np.zeros((nc, nv))
        for k, nd in enumerate(e.nodes()):
            idx = index[id(nd)]
            for c in range(6):
                if idx[c] >= 0:
                    Bg[:, idx[c]] += Be[0, :, 6 * k + c]
        Phi.append(ph[0])
        B.append(Bg)
        Phi_t.append(pt[0])
        rows += [f"{e.name}.{n}" for n in cls.constraint_names]
    Phi = np.concatenate(Phi)
    B = np.vstack(B)
    Phi_t = np.concatenate(Phi_t)
    return {"Phi": Phi, "B": B, "v0": v0, "velocity_residual": B @ v0 + Phi_t, "rows": rows, "nv": nv}


def redundancy(B, tol=1e-9):
    """Rank of B by pivoted QR of Bᵀ (docs/spatial.md §5) and the dependent rows.

    Returns (rank, dependent row indices, |R_ii| / |R_11| at the rank gap).
    """
    from scipy.linalg import qr

    _, R, piv = qr(B.T, mode="economic", pivoting=True)
    d = np.abs(np.diag(R))
    r = int(np.sum(d > tol * d[0]))
    gap = d[r] / d[0] if r < d.size else 0.0
    return r, sorted(piv[r:].tolist()), gap

"""Helpers shared by the spatial scenes: rotations of results, initial constraint checks.

The spatial scenes (:mod:`femb.benchmarks.scenes.spatial.heavy_top`, :mod:`femb.benchmarks.scenes.spatial.spatial_slider_crank`,
:mod:`femb.benchmarks.scenes.spatial.bricard`, :mod:`femb.benchmarks.scenes.spatial.spatial_double_pendulum`) need the Lie-group time loop
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

from femb.base import rotations as rt
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


class Index1Check:
    """A slow, dense index-1 evaluation of a spatial mechanism from its kernels (a check, not a solver).

    State y = (x of every node that is not fully fixed (7 each), free v). The
    right-hand side assembles M, f (+ gravity M ĝ), Φ, B, γ from the element
    kernels, solves [M Bᵀ; B 0][v̇; λ] = [f; −γ] (least squares: redundant rows
    allowed, λ then minimum-norm) and returns (ṙ, ½ p ⊗ (0, Ω), v̇). Integrated
    tightly with scipy it reproduces the references, which validates the kernels'
    conventions (signs, λ meaning, gyroscopic term, γ) independently of any time
    integration scheme.
    """

    def __init__(self, mech):
        self.els = resolve(mech)
        grav = [e for e in mech.elements if isinstance(e, Gravity)]
        self.g = grav[0].g if grav else np.zeros(3)
        self.nodes, self.vindex, self.nv = _numbering(self.els)
        self.moving = [nd for nd in self.nodes if not np.all(nd.fixed)]
        self.xslot = {id(nd): 7 * k for k, nd in enumerate(self.moving)}
        self.nx = 7 * len(self.moving)
        self.groups = []
        for e in self.els:
            cls = type(e)
            fns = cls.time_functions(e) if hasattr(cls, "time_functions") else []
            self.groups.append((e, cls.pack([e])["P"], fns))
        self.nc = sum(e.n_constraints for e in self.els)

    def y0(self):
        x = np.concatenate([nd.q0 for nd in self.moving])
        v = np.zeros(self.nv)
        for nd in self.nodes:
            idx = self.vindex[id(nd)]
            v[idx[idx >= 0]] = nd.qd0[idx >= 0]
        return np.concatenate((x, v))

    def _gather(self, e, y):
        x, v = [], []
        for nd in e.nodes():
            if id(nd) in self.xslot:
                s = self.xslot[id(nd)]
                x.append(y[s:s + 7])
            else:
                x.append(nd.q0)
            idx = self.vindex[id(nd)]
            ve = np.zeros(6)
            ve[idx >= 0] = y[self.nx + idx[idx >= 0]]
            v.append(ve)
        return np.concatenate(x)[None], np.concatenate(v)[None]

    def _cols(self, e):
        return np.concatenate([self.vindex[id(nd)] for nd in e.nodes()])

    def solve(self, t, y):
        """(v̇ (nv,), λ (nc,), dict of per-element λ) at (t, y)."""
        nv, nc = self.nv, self.nc
        M = np.zeros((nv, nv))
        f = np.zeros(nv)
        B = np.zeros((nc, nv))
        gam = np.zeros(nc)
        rows = {}
        r = 0
        for e, P, fns in self.groups:
            x, v = self._gather(e, y)
            cols = self._cols(e)
            ok = cols >= 0
            ndv = v.shape[1]
            tf = np.array([[[fn.f(t), fn.df(t), fn.ddf(t)] for fn in fns]]).reshape(1, len(fns), 3)
            k = e.kernels
            if "mass" in k:
                Me = np.zeros((1, ndv, ndv))
                k["mass"](P, x, Me)
                M[np.ix_(cols[ok], cols[ok])] += Me[0][np.ix_(ok, ok)]
                gh = np.zeros(ndv)
                for j in range(len(e.nodes())):
                    gh[6 * j:6 * j + 3] = self.g
                f[cols[ok]] += (Me[0] @ gh)[ok]
            if "force" in k:
                fe = np.zeros((1, ndv))
                z = np.zeros((1, ndv, ndv))
                k["force"](P, float(t), tf, x, v, False, fe, z, z.copy())
                f[cols[ok]] += fe[0][ok]
            if e.n_constraints:
                n = e.n_constraints
                ph = np.zeros((1, n))
                Be = np.zeros((1, n, ndv))
                k["constraint"](P, float(t), tf, x, np.zeros((1, n)), False, ph, Be, np.zeros((1, ndv, ndv)))
                pt = np.zeros((1, n))
                ge = np.zeros((1, n))
                k["rates"](P, float(t), tf, x, v, pt, ge)
                B[r:r + n, cols[ok]] += Be[0][:, ok]
                gam[r:r + n] = ge[0]
                rows[e.name] = slice(r, r + n)
                r += n
        K = np.block([[M, B.T], [B, np.zeros((nc, nc))]])
        sol = np.linalg.lstsq(K, np.concatenate((f, -gam)), rcond=1e-13)[0]
        lam = sol[nv:]
        return sol[:nv], lam, {name: lam[s] for name, s in rows.items()}

    def rhs(self, t, y):
        vd, _, _ = self.solve(t, y)
        out = np.empty_like(y)
        for nd in self.moving:
            s = self.xslot[id(nd)]
            idx = self.vindex[id(nd)]
            ve = np.zeros(6)
            ve[idx >= 0] = y[self.nx + idx[idx >= 0]]
            p = y[s + 3:s + 7]
            W = ve[3:6]
            out[s:s + 3] = ve[:3]
            out[s + 3:s + 7] = 0.5 * np.array([-p[1] * W[0] - p[2] * W[1] - p[3] * W[2],
                                               p[0] * W[0] + p[2] * W[2] - p[3] * W[1],
                                               p[0] * W[1] + p[3] * W[0] - p[1] * W[2],
                                               p[0] * W[2] + p[1] * W[1] - p[2] * W[0]])
        out[self.nx:] = vd
        return out

    def node_state(self, y, name):
        """(x (7,), v (6,)) of the node of body ``name``."""
        for nd in self.moving:
            if nd.name == name:
                s = self.xslot[id(nd)]
                idx = self.vindex[id(nd)]
                v = np.zeros(6)
                v[idx >= 0] = y[self.nx + idx[idx >= 0]]
                return y[s:s + 7], v
        raise KeyError(name)

    def trajectory(self, t, Y):
        """A result-like view of states Y (n, nt) at times t (nt,) for the scenes' ``outputs``.

        Offers ``t``, ``body(name, what)`` with what in {"q", "qd", "qdd"} and
        ``reaction(name)``, as the scenes expect from femb's ``Result``.
        """
        return _Trajectory(self, np.asarray(t, dtype=float), np.asarray(Y, dtype=float))


class _Trajectory:
    def __init__(self, chk, t, Y):
        self.chk, self.t, self.Y = chk, t, Y
        sols = [chk.solve(tk, Y[:, k]) for k, tk in enumerate(t)]
        self._vd = np.array([s[0] for s in sols])
        self._lam = [s[2] for s in sols]

    def body(self, name, what="q"):
        rows = []
        for k in range(self.t.size):
            x, v = self.chk.node_state(self.Y[:, k], name)
            if what == "q":
                rows.append(x / np.concatenate((np.ones(3), [np.linalg.norm(x[3:7])] * 4)))
            elif what == "qd":
                rows.append(v)
            else:
                nd = next(nd for nd in self.chk.moving if nd.name == name)
                idx = self.chk.vindex[id(nd)]
                a = np.zeros(6)
                a[idx >= 0] = self._vd[k][idx[idx >= 0]]
                rows.append(a)
        return np.array(rows)

    def reaction(self, name):
        return np.array([lam[name] for lam in self._lam])

"""Compiled evaluation of a model's force, constraint and contact batches into dense arrays.

Each batch of a model is one record (a tuple of arrays of the same types for every batch, so
that a model's batches form one ``numba.typed.List``): its kernels' addresses, parameters, the
arrays its kernels write and the flat positions of their entries in the global dense arrays
(:class:`femb.contact.dense.DenseModel` builds them). :func:`evaluate_batches` gathers each
batch's coordinates, calls its kernels through their addresses (as the engine does,
:mod:`femb.base.jit`; the contact role through :func:`call_contact`) and scatters the results:

* force batches: f += f_e, K1 −= ∂f_e/∂q, C1 −= ∂f_e/∂q̇;
* constraint batches: Φ, Φ_q, Φ_t, γ and K1 += ∂(Φ_qᵀλ_g)/∂q;
* contact batches: g_N, W_N, W_F, ζ_N, ζ_F and K1 −= ∂(W_Nᵀλ_N + W_Fᵀλ_F)/∂q.

A record is ``(meta, bf, bi)``: ``meta`` (int64) = (kind 0/1/2, address, rates address, damped,
k_N); ``bf`` = (P, tf, xe, ve, le, V2, V3a, V2b, V3b, V2c) and ``bi`` = (xdofs, dofs, rows, vec_sel,
vec_idx, mat_sel, mat_idx, A_sel, A_idx, F_sel, F_idx, zN_sel, zF_sel, cF) — what each holds per
kind is in :meth:`femb.contact.dense.DenseModel._records`.
"""
from __future__ import annotations

import numpy as np
from numba.core import cgutils, types
from numba.typed import List
from numba.extending import intrinsic

from femb.base.jit import (_PY_KERNELS, call_constraint, call_force, call_rates, jit_disabled, kernel,
                           kernel_args_match)
from femb.system.kernels import CONTACT_SIGNATURE


@intrinsic
def call_contact(typingctx, addr, args):
    """Call the compiled contact kernel at ``addr`` with ``args`` = (P, t, tf, xe, ve, le, jac, gN, W, zeta, H)
    (docs/contact.md §2; the arguments travel as one tuple)."""
    ksig = CONTACT_SIGNATURE
    if not isinstance(addr, types.Integer) or not isinstance(args, types.BaseTuple) \
            or not kernel_args_match(tuple(args), ksig.args):
        return None
    sig = types.none(addr, args)

    def codegen(context, builder, sig_, llargs):
        tup = llargs[1]
        vals = [context.cast(builder, builder.extract_value(tup, i), have, want)
                for i, (have, want) in enumerate(zip(args, ksig.args))]
        fnty = context.call_conv.get_function_type(types.void, ksig.args)
        fptr = builder.inttoptr(llargs[0], fnty.as_pointer())
        status, _ = context.call_conv.call_function(builder, fptr, types.void, ksig.args, vals)
        with cgutils.if_unlikely(builder, status.is_error):
            context.call_conv.return_status_propagate(builder, status)
        return context.get_dummy_value()

    return sig, codegen


if jit_disabled():
    def call_contact(addr, args):    # noqa: F811 (plain Python for NUMBA_DISABLE_JIT=1)
        _PY_KERNELS[addr](*args)


@kernel(allocates=True)
def _records_list(rec):
    """A typed list holding ``rec``: formed in compiled code kept in the disk cache (``List(recs)`` from
    Python compiles the list's methods for the records' type anew in every process: 1.5 s)."""
    out = List()
    out.append(rec)
    return out


@kernel(allocates=True)
def _records_append(out, rec):
    out.append(rec)


def records_list(recs):
    """The batch records ``recs`` (a non-empty Python list of records, all of one type) as a
    ``numba.typed.List`` (what :func:`evaluate_batches` and the compiled loop take)."""
    if jit_disabled():
        return List(recs)
    out = _records_list(recs[0])
    for rec in recs[1:]:
        _records_append(out, rec)
    return out


@kernel(allocates=True)
def _zero(a):
    a.reshape(a.size)[:] = 0.0


@kernel(allocates=True)
def _gather(bf, bi, qx, ux):
    xe, ve = bf[2], bf[3]
    xdofs, dofs = bi[0], bi[1]
    for e in range(xe.shape[0]):
        for j in range(xe.shape[1]):
            xe[e, j] = qx[xdofs[e, j]]
        for j in range(ve.shape[1]):
            ve[e, j] = ux[dofs[e, j]]


@kernel(allocates=True)
def _add(out, idx, src, sel, sign):
    """out[idx[a]] += sign src[sel[a]] (flat; repeated indices add up)."""
    v = src.reshape(src.size)
    for a in range(idx.size):
        out[idx[a]] += sign * v[sel[a]]


@kernel(allocates=True)
def _force_batch(meta, bf, bi, t, jac, dq):
    P, tf, xe, ve, le, fe, fq, _, fv, _ = bf
    _zero(fe)
    _zero(fq)
    _zero(fv)
    call_force(meta[1], P, t, tf, xe, ve, jac, fe, fq, fv)
    _add(dq[0], bi[4], fe, bi[3], 1.0)
    if jac:
        _add(dq[1], bi[6], fq, bi[5], -1.0)
        if meta[3]:
            _add(dq[2], bi[6], fv, bi[5], -1.0)


@kernel(allocates=True)
def _constraint_batch(meta, bf, bi, t, lg, jac, dq):
    P, tf, xe, ve, le, Phi, B, Pt, H, gam = bf
    rows = bi[2]
    for e in range(le.shape[0]):
        for j in range(le.shape[1]):
            le[e, j] = lg[rows[e, j]] if jac else 0.0
    _zero(Phi)
    _zero(B)
    _zero(H)
    _zero(Pt)
    _zero(gam)
    call_constraint(meta[1], P, t, tf, xe, le, jac, Phi, B, H)
    call_rates(meta[2], P, t, tf, xe, ve, Pt, gam)
    for e in range(rows.shape[0]):
        for j in range(rows.shape[1]):
            dq[3][rows[e, j]] = Phi[e, j]
            dq[4][rows[e, j]] = Pt[e, j]
            dq[5][rows[e, j]] = gam[e, j]
    _add(dq[6], bi[8], B, bi[7], 1.0)
    if jac:
        _add(dq[1], bi[6], H, bi[5], 1.0)


@kernel(allocates=True)
def _contact_batch(meta, bf, bi, t, mult, jac, dq):
    P, tf, xe, ve, le, G, W, Z, H, _ = bf
    rows, cF = bi[2], bi[13]
    lN, lF = mult
    kN = meta[4]
    for e in range(le.shape[0]):
        for j in range(kN):
            le[e, j] = lN[rows[e, j]] if jac else 0.0
        for j in range(cF.shape[1]):
            le[e, kN + j] = lF[cF[e, j]] if jac else 0.0
    _zero(G)
    _zero(W)
    _zero(Z)
    _zero(H)
    call_contact(meta[1], (P, t, tf, xe, ve, le, jac, G, W, Z, H))
    zf = Z.reshape(Z.size)
    for e in range(rows.shape[0]):
        for j in range(kN):
            dq[7][rows[e, j]] = G[e, j]
    sel, cFf = bi[11], cF.reshape(cF.size)
    rf = rows.reshape(rows.size)
    for a in range(sel.size):
        dq[8][rf[a]] = zf[sel[a]]
    sel = bi[12]
    for a in range(sel.size):
        dq[9][cFf[a]] = zf[sel[a]]
    _add(dq[10], bi[8], W, bi[7], 1.0)
    _add(dq[11], bi[10], W, bi[9], 1.0)
    if jac:
        _add(dq[1], bi[6], H, bi[5], -1.0)


@kernel(allocates=True)
def evaluate_batches(recs, t, qx, ux, mult, jac, dq, f0, removed):
    """Evaluate every batch record (module docstring) at (t, qx, ux) into the global arrays.

    ``mult`` = (λ_g, λ_N, λ_F); ``dq`` = (f, K1, C1, Φ, Φ_t, γ, Φ_q, g_N, ζ_N, ζ_F, W_N, W_F), flat;
    f starts from ``f0`` (constant forces, gravity), K1 and C1 from zero (with ``jac``; else they are
    left alone); ``removed``: equations removed as redundant, set to zero.
    """
    dq[0][:] = f0
    if jac:
        dq[1][:] = 0.0
        dq[2][:] = 0.0
    dq[6][:] = 0.0
    dq[10][:] = 0.0
    dq[11][:] = 0.0
    for r in recs:
        meta, bf, bi = r
        _gather(bf, bi, qx, ux)
        if meta[0] == 0:
            _force_batch(meta, bf, bi, t, jac, dq)
        elif meta[0] == 1:
            _constraint_batch(meta, bf, bi, t, mult[0], jac, dq)
        else:
            _contact_batch(meta, bf, bi, t, (mult[1], mult[2]), jac, dq)
    if removed.size:
        ncol = dq[6].size // dq[3].size
        for i in removed:
            dq[3][i] = 0.0
            dq[4][i] = 0.0
            dq[5][i] = 0.0
            for c in range(ncol):
                dq[6][i * ncol + c] = 0.0

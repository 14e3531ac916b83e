"""The broad phase: a step solves for the contacts that can close in it.

A model that declares many pairs (``SpatialSpherePair``, ``DiscOnDisc``: types whose
``sphere_pairs`` describes each element as two spheres, docs/contact.md §2) has most of them far
apart at any time. An open contact whose gap stays positive adds rows to the step that give its
unknowns at once (λ_N = Λ_N = κ_N = 0, λ_F = Λ_F = 0: eqs. (129)–(142) off the index set A), so the
step's solution is the same with or without them. :class:`BroadPhaseStep` therefore solves each
step with a :class:`femb.contact.step.NonsmoothStep` on a subset of the contacts:

* every contact of a type that is not a pair;
* the pairs whose gap at the step's start is at most ``NEAR`` (R_a + R_b) + 2 h abs(v_b − v_a) (the
  step's own relative motion counted twice), and those that were in the step before and are still
  within ``HOLD`` times that (so that a pair on the margin does not come and go every step);
* the pairs that still carry a force or an auxiliary force λ̄ (eq. (96)) that could move a coordinate
  by more than 1e-3 of the Newton tolerance (h² λ̄ / m > 1e-3 tol): λ̄ of an open contact enters the
  position correction through κ̂_N (eq. (102)).

After the step it checks every pair it left out at the step's end: one whose gap there is at most
``RECHECK`` (R_a + R_b) is added and the step solved again (``RETRIES`` times, then with every
contact). The pairs left out of an accepted step are open at its end by more than that, so the
solution is the one with every contact in the step, except for the auxiliary forces λ̄ that the rule
above neglects (set to zero). The cost of a step is that of its subset plus one vectorized pass over
every declared pair's spheres at each end (``sphere_pairs``): linear in the contacts near each other,
not in the pairs declared.

What the step returns is what :class:`NonsmoothStep` returns, for every contact of the model: the
pairs left out have zero forces, their exact gaps and normal velocities (from their spheres), and
their slip velocities and g̈_N (which need their kernels) computed only where they are read:
the rows a result stores (:class:`Rows`) and a pair joining a step (``StepState.fresh``).
"""
from __future__ import annotations

import dataclasses
import types

import numpy as np

from femb.contact import assemble
from femb.contact.step import NonsmoothStep, StepFailure, StepState
from femb.system import kernels

#: the broad phase runs when the model has at least this many pair contacts ...
BROAD_PHASE_MIN = 32
#: ... and its steps take the sparse path, or the dense one with at least this many unknowns: below, the
#: compiled loop on every contact is faster than the Python loop on the subsets (docs/contact.md §7)
BROAD_PHASE_DENSE_MIN = 400
#: a pair joins a step when its gap is at most NEAR (R_a + R_b) + 2 h abs(v_b − v_a) at the step's start
NEAR = 0.05
#: ... and stays in the next steps while its gap is at most HOLD times that
HOLD = 2.0
#: a step that brings a pair it left out to a gap of at most RECHECK (R_a + R_b) is solved again with it
RECHECK = 0.005
#: such repeats before the step is solved with every contact
RETRIES = 3


def _time_functions(g, idx):
    """The time functions of a batch's elements ``idx`` (the batch's own list where they have none: only
    its first entry's length is read then, :func:`femb.system.kernels.time_values`)."""
    fns = g.time_functions
    if not fns or not len(fns[0]):
        return fns
    return [fns[i] for i in idx]


class ContactSubset:
    """A model seen with a subset of its contacts: what :class:`NonsmoothStep` and
    :func:`femb.contact.assemble.evaluate` read (``contact_groups``, ``n_contacts``, ``n_friction``), the
    rest the model's own.

    Parameters
    ----------
    model : Model
    keep : list of ndarray of int
        Per contact group of the model, the elements kept (sorted).

    Attributes
    ----------
    rows_N, rows_F : ndarray of int
        The model's normal contacts and tangent directions kept, in the subset's order.
    """

    def __init__(self, model, keep):
        self._model = model
        groups, rows_N, rows_F = [], [], []
        nN = nF = 0
        for g, idx in zip(model.contact_groups, keep):
            if idx.size == 0:
                continue
            cN, cF = g.cN[idx], g.cF[idx]
            rows_N.append(cN.ravel())
            rows_F.append(cF.ravel())
            groups.append(dataclasses.replace(
                g, elements=[g.elements[i] for i in idx], names=[g.names[i] for i in idx], dofs=g.dofs[idx],
                lam=g.lam[idx], P=g.P[idx], xdofs=g.xdofs[idx],
                tf_index=None if g.tf_index is None else g.tf_index[idx], time_functions=_time_functions(g, idx),
                mu=None if g.mu is None else g.mu[idx],
                cN=(nN + np.arange(cN.size, dtype=np.int64)).reshape(cN.shape),
                cF=(nF + np.arange(cF.size, dtype=np.int64)).reshape(cF.shape)))
            nN += cN.size
            nF += cF.size
        # the subset's rows in the model's order, so that its unknowns keep the model's order
        rN = np.concatenate(rows_N) if rows_N else np.zeros(0, dtype=np.int64)
        rF = np.concatenate(rows_F) if rows_F else np.zeros(0, dtype=np.int64)
        newN, newF = np.empty(nN, dtype=np.int64), np.empty(nF, dtype=np.int64)
        newN[np.argsort(rN, kind="stable")] = np.arange(nN)
        newF[np.argsort(rF, kind="stable")] = np.arange(nF)
        self.contact_groups = [dataclasses.replace(g, cN=newN[g.cN], cF=newF[g.cF]) for g in groups]
        self.n_contacts, self.n_friction = nN, nF
        self.rows_N, self.rows_F = np.sort(rN), np.sort(rF)

    def __getattr__(self, key):
        return getattr(self._model, key)


class BroadPhase:
    """The pair contacts of a model and their spheres (``sphere_pairs`` of their types).

    Attributes
    ----------
    pairs : list of (group index, ndarray of int)
        The contact groups of pair types and their elements' normal contacts (one per element).
    n : int
        Pair contacts.
    """

    def __init__(self, model):
        self.model = model
        self.pairs = []
        for k, g in enumerate(model.contact_groups):
            if g.cN.shape[1] != 1 or g.nel == 0:
                continue
            probe = g.cls.sphere_pairs(g.P[:1], model.ext(model.q0)[g.xdofs[:1]], np.zeros((1, g.dofs.shape[1])))
            if probe is not None:
                self.pairs.append((k, g.cN[:, 0].copy()))
        self.rows = np.concatenate([r for _, r in self.pairs]) if self.pairs else np.zeros(0, dtype=np.int64)
        self.n = int(self.rows.size)
        self._memo = None

    def spheres(self, q, u):
        """Gap, normal velocity, relative speed and radii sum of every pair at (q, u), in ``rows``' order.

        Returns
        -------
        gN, gNd, speed, size : ndarray, shape (n,)
            g_N = abs(c_b − c_a) − R_a − R_b, ġ_N = n·(v_b − v_a), abs(v_b − v_a), R_a + R_b.
        """
        if self._memo is not None and self._memo[0] is q and self._memo[1] is u:     # a step's end, the next's start
            return self._memo[2]
        m = self.model
        qx, ux = m.ext(np.asarray(q, dtype=float)), m.ext_velocity(np.asarray(u, dtype=float))
        out = [], [], [], []
        for k, _ in self.pairs:
            g = m.contact_groups[k]
            ca, cb, va, vb, Ra, Rb = g.cls.sphere_pairs(g.P, qx[g.xdofs], ux[g.dofs])
            d, dv = cb - ca, vb - va
            L = np.sqrt(np.einsum("ej,ej->e", d, d))
            with np.errstate(invalid="ignore", divide="ignore"):
                rate = np.einsum("ej,ej->e", d, dv) / L
            for o, v in zip(out, (L - Ra - Rb, rate, np.sqrt(np.einsum("ej,ej->e", dv, dv)), Ra + Rb)):
                o.append(v)
        res = tuple(np.concatenate(o) if o else np.zeros(0) for o in out)
        self._memo = (q, u, res)
        return res


def for_model(model, stepper, enabled=True):
    """The broad phase of a model with at least ``BROAD_PHASE_MIN`` pair contacts whose steps take the sparse
    path or have at least ``BROAD_PHASE_DENSE_MIN`` unknowns on the dense one, else None."""
    if not enabled or not getattr(model, "contact_groups", None):
        return None
    if stepper.dense and stepper.nx < BROAD_PHASE_DENSE_MIN:
        return None
    bp = BroadPhase(model)
    return bp if bp.n >= BROAD_PHASE_MIN else None


class Rows:
    """W_N or W_F of every contact at a step's end, as the products W v that a result stores.

    The rows of the step's contacts are the step's; those of the pairs it left out come from their
    kernels at the step's end, evaluated when a product is first asked for (:class:`_LeftOut`).
    """

    def __init__(self, W, rows, n, rest, key):
        self.W, self.rows, self.n, self.rest, self.key = W, rows, n, rest, key
        self.shape = (n, W.shape[1])

    def __matmul__(self, v):
        out = self.rest.products(v)[self.key] if self.rest is not None else np.zeros(self.n)
        out[self.rows] = self.W @ v
        return out


class _LeftOut:
    """The pairs a step left out, their W_N v and W_F v from their kernels at the step's end (t, q)."""

    def __init__(self, model, keep, t, q):
        self.model, self.keep, self.t, self.q = model, keep, t, q
        self._memo = None

    def products(self, v):
        """dict N: W_N v (nN,), F: W_F v (nF,) with the left-out pairs' entries (the others zero)."""
        if self._memo is not None and self._memo[0] is v:
            return {k: a.copy() for k, a in self._memo[1].items()}
        m = self.model
        qx, vx = m.ext(np.asarray(self.q, dtype=float)), m.ext_velocity(np.asarray(v, dtype=float))
        out = dict(N=np.zeros(m.n_contacts), F=np.zeros(m.n_friction))
        for g, idx in zip(m.contact_groups, self.keep):
            if idx.size == 0:
                continue
            sub = dataclasses.replace(g, P=g.P[idx], dofs=g.dofs[idx], xdofs=g.xdofs[idx],
                                      time_functions=_time_functions(g, idx))
            _, W, _, _ = kernels.contact(sub, self.t, qx[sub.xdofs], vx[sub.dofs], None, False)
            Wv = np.einsum("erj,ej->er", W, vx[sub.dofs])
            kN = g.cN.shape[1]
            out["N"][g.cN[idx]] = Wv[:, :kN]
            out["F"][g.cF[idx]] = Wv[:, kN:]
        self._memo = (v, out)
        return {k: a.copy() for k, a in out.items()}


class BroadPhaseStep:
    """A :class:`NonsmoothStep` for the whole model whose steps are solved on the contacts that can close
    (module docstring). It answers what the time loops ask of a stepper (``solve``, ``set_h``, ``split``,
    ``offsets``, ``nx``, ``lay``, ``model``, ``tol``, ``h``, ``h_fixed``, ``h_acc``, ``remember_W``) with
    the whole model's sizes.

    Parameters
    ----------
    full : NonsmoothStep
        The stepper of the whole model (either path): sizes, layout, parameters, the mass matrix's
        factors (shared with the steppers of the subsets).
    bp : BroadPhase

    Attributes
    ----------
    stats : dict
        ``solves`` (steps solved), ``rebuilt`` (steppers built for a new subset), ``repeated`` (steps solved
        again with pairs that came close), ``contacts`` (contacts summed over the solves).
    """

    dense = False

    def __init__(self, full, bp):
        self.full, self.bp = full, bp
        self.model, self.lay, self.tol = full.model, full.lay, full.tol
        self.offsets, self.nx, self.split = full.offsets, full.nx, full.split
        self.max_iter, self.max_fp = full.max_iter, full.max_fp
        self._alpha = types.SimpleNamespace(alpha_m=full.am, alpha_f=full.af, beta=full.beta, gamma=full.gamma)
        self._pair = np.zeros(self.lay.nN, dtype=bool)
        self._pair[bp.rows] = True
        self._where = np.full(self.lay.nN, -1, dtype=np.int64)     # a contact's place in bp.rows
        self._where[bp.rows] = np.arange(bp.n)
        self._elem = [(g.cN, g.cN.shape[0]) for g in self.model.contact_groups]
        self._sub = None                    # (mask of the model's contacts, subset, stepper, x index)
        self._last = np.ones(self.lay.nN, dtype=bool)
        self.stats = dict(solves=0, rebuilt=0, repeated=0, contacts=0)

    # what the loops read of a stepper
    @property
    def h(self):
        return self.full.h

    @property
    def h_fixed(self):
        return self.full.h_fixed

    @property
    def h_acc(self):
        return self.full.h_acc

    @h_acc.setter
    def h_acc(self, value):
        self.full.h_acc = value

    def set_h(self, h):
        self.full.set_h(h)

    def remember_W(self, q, t, WN, WF):
        """(The steppers of the subsets form their prox parameters from their own W.)"""

    # the subset
    def _negligible(self, s):
        """Contacts whose forces and auxiliary forces at s cannot move a coordinate by 1e-3 tol in a step."""
        h, lay = self.full.h, self.lay
        cap = 1e-3 * self.tol * self.full.m_ref / (h * h)
        big = (np.abs(s.lam_N) > cap) | (np.abs(s.lbar_N) > cap)
        F = (np.abs(s.lam_F) > cap) | (np.abs(s.lbar_F) > cap)
        if F.any():
            big[self.full.owner[F]] = True
        return ~big

    def _mask(self, want):
        """Whole elements: a contact group's element is in when any of its contacts is; returns (mask of
        the model's contacts, per group the elements)."""
        keep, mask = [], np.zeros(self.lay.nN, dtype=bool)
        for cN, nel in self._elem:
            idx = np.nonzero(want[cN].any(axis=1))[0] if nel else np.zeros(0, dtype=np.int64)
            keep.append(idx)
            mask[cN[idx].ravel()] = True
        return mask, keep

    def _candidates(self, s):
        """The contacts of a step from s (module docstring)."""
        h = self.full.h
        gN, _, speed, size = self.bp.spheres(s.q, s.u)
        reach = NEAR * size + 2.0 * h * speed
        near = ~(gN > reach)                            # NaN (centres coincide): in, its kernel says why
        held = self._last[self.bp.rows] & ~(gN > HOLD * reach)
        want = ~self._pair
        want[self.bp.rows] = near | held
        want |= ~self._negligible(s)
        return want

    def _stepper(self, mask, keep):
        if self._sub is not None and np.array_equal(self._sub[0], mask):
            return self._sub
        sub = ContactSubset(self.model, keep)
        lay = assemble.layout(sub)
        st = NonsmoothStep(sub, self.full.h, self._alpha, lay, self.tol, self.max_iter, self.max_fp,
                           like=self.full)
        o = self.offsets
        xi = np.concatenate((np.arange(o[6]), o[6] + sub.rows_N, o[7] + sub.rows_N, o[8] + sub.rows_N,
                             o[9] + sub.rows_F, o[10] + sub.rows_F))
        self._sub = (mask, sub, st, xi)
        self.stats["rebuilt"] += 1
        return self._sub

    def _state(self, s, sub, xi, mask):
        """s for the subset: its contacts' entries; those whose slip velocities and g̈_N at s were not
        computed (``s.fresh``: pairs left out of the step that ended at s) from their kernels."""
        rN, rF = sub.rows_N, sub.rows_F
        gNd, gFd, gN, gNdd = s.gNd[rN], s.gFd[rF], s.gN[rN], s.gNdd[rN]
        if s.fresh is not None:
            stale = mask & ~s.fresh
            if stale.any():
                new = ContactSubset(self.model, [np.nonzero(stale[cN].any(axis=1))[0] for cN, _ in self._elem])
                ev = assemble.evaluate(new, s.t, s.q, s.u)
                iN, iF = np.searchsorted(rN, new.rows_N), np.searchsorted(rF, new.rows_F)
                gN[iN], gNd[iN] = ev["gN"], ev["WN"] @ s.u
                gNdd[iN], gFd[iF] = ev["WN"] @ s.ud + ev["zN"], ev["WF"] @ s.u
                # and in s itself, which the loop reads too (the impact time of a pair that joins)
                s.gN[new.rows_N], s.gNd[new.rows_N], s.gNdd[new.rows_N] = gN[iN], gNd[iN], gNdd[iN]
                s.gFd[new.rows_F] = gFd[iF]
                s.fresh[new.rows_N] = True
        return StepState(s.t, s.q, s.u, s.ud, s.abar, s.lam_N[rN], s.lam_F[rF], s.lbar_N[rN], s.lbar_F[rF],
                         gNd, gFd, None if s.x is None else s.x[xi], gN=gN, gNdd=gNdd)

    def solve(self, s):
        """One step from s (:meth:`NonsmoothStep.solve`), on the contacts that can close in it; the
        solution for every contact of the model."""
        want = self._candidates(s)
        for attempt in range(RETRIES + 2):
            if attempt == RETRIES + 1:
                want = np.ones(self.lay.nN, dtype=bool)
            mask, keep = self._mask(want)
            _, sub, st, xi = self._stepper(mask, keep)
            st.set_h(self.full.h)
            st.h_fixed, st.h_acc = self.full.h_fixed, self.full.h_acc
            ss = self._state(s, sub, xi, mask)
            self.stats["solves"] += 1
            self.stats["contacts"] += sub.n_contacts
            try:
                x, ev, sets, info = st.solve(ss)
            except StepFailure as fail:
                raise StepFailure(str(fail), None if fail.x is None else self._x(fail.x, xi),
                                  None if fail.sets is None else self._sets(fail.sets, sub)) from None
            gN, gNd, _, size = self.bp.spheres(ev["q"], ev["u"])
            out = ~mask[self.bp.rows]
            close = out & ~(gN > RECHECK * size)
            if not close.any() or mask.all():
                break
            self.stats["repeated"] += 1
            want = mask.copy()
            want[self.bp.rows[close]] = True
        self._last = mask
        return self._x(x, xi), self._ev(ev, sub, mask, keep, (gN, gNd), s.t + self.full.h), \
            self._sets(sets, sub), info

    # the solution for every contact
    def _x(self, x, xi):
        out = np.zeros(self.nx)
        out[xi] = x
        return out

    def _sets(self, sets, sub):
        out = []
        for a in sets:
            b = np.zeros(self.lay.nN, dtype=bool)
            b[sub.rows_N] = a
            out.append(b)
        return tuple(out)

    def _ev(self, ev, sub, mask, keep, pairs, t1):
        lay, rN, rF = self.lay, sub.rows_N, sub.rows_F

        def wide(v, n, rows):
            out = np.zeros(n)
            out[rows] = v
            return out

        gN, gNd = pairs
        full = dict(q=ev["q"], u=ev["u"], abar=ev["abar"])
        for k in ("lbar_N", "PN", "gN", "gNd", "gNdd"):
            full[k] = wide(ev[k], lay.nN, rN)
        for k in ("lbar_F", "PF", "gF"):
            full[k] = wide(ev[k], lay.nF, rF)
        out = ~mask[self.bp.rows]
        full["gN"][self.bp.rows[out]] = gN[out]
        full["gNd"][self.bp.rows[out]] = gNd[out]
        full["fresh"] = mask.copy()
        rest = None
        if not mask.all():
            rest = _LeftOut(self.model, [np.setdiff1d(np.arange(nel), k) for (_, nel), k in zip(self._elem, keep)],
                            t1, ev["q"])
        full["WN"] = Rows(ev["WN"], rN, lay.nN, rest, "N")
        full["WF"] = Rows(ev["WF"], rF, lay.nF, rest, "F")
        return full

"""Checks of element kernels against finite differences on the configuration manifold.

:func:`check_jacobians` compares every Jacobian a model's kernels return (∂f/∂x,
∂f/∂v, B = Φ_x, H = ∂(Bᵀλ)/∂x, Φ_t, γ) with central differences of the kernels'
own outputs, perturbing the model's coordinates as the time loop does:
x ∘ exp(εw) (additive coordinates x + εw; rotations R exp(εw̃), in body axes).
A sign error in a Jacobian only slows Newton down, and a damping force whose
type does not declare ``force_depends_on_qd`` is silently left out of the
iteration matrix: neither shows in the results. Run this on every element type
you write (``docs/kernels.md``).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from femb.system import kernels as K
from femb.system.model import Model, State


@dataclass
class JacobianCheck:
    """One compared Jacobian: element type, batch, role, what, relative error, verdict."""
    element_type: str
    batch: str
    what: str
    error: float
    scale: float
    ok: bool
    note: str = ""


@dataclass
class JacobianReport:
    """The result of :func:`check_jacobians`: one :class:`JacobianCheck` per Jacobian and batch."""
    checks: list = field(default_factory=list)
    rtol: float = 1e-6

    @property
    def ok(self):
        return all(c.ok for c in self.checks)

    @property
    def failures(self):
        return [c for c in self.checks if not c.ok]

    def __str__(self):
        rows = [f"{'element type':<24s} {'batch':<20s} {'Jacobian':<28s} {'rel. error':>10s}  verdict"]
        for c in self.checks:
            rows.append(f"{c.element_type:<24s} {c.batch[:20]:<20s} {c.what:<28s} {c.error:10.2e}  "
                        f"{'ok' if c.ok else 'WRONG'}{(' — ' + c.note) if c.note else ''}")
        rows.append("all Jacobians agree with finite differences" if self.ok else
                    f"{len(self.failures)} Jacobian(s) disagree with finite differences (rtol = {self.rtol:g})")
        return "\n".join(rows)

    __repr__ = __str__


#: round-off of a central difference: about this many ε of the function's size, over the step
FD_NOISE = 1e3 * np.finfo(float).eps


def _rel(A, B, noise=0.0, rtol=1.0):
    """max|A − B| relative to the larger of max|A|, max|B| and the finite differences' own
    round-off (``noise / rtol``: differences below the round-off always pass)."""
    scale = max(float(np.max(np.abs(A), initial=0.0)), float(np.max(np.abs(B), initial=0.0)))
    den = max(scale, noise / rtol if rtol > 0 else 0.0)
    if den == 0.0:
        return 0.0, 0.0
    return float(np.max(np.abs(A - B))) / den, scale


def check_jacobians(model: Model, state: State | None = None, t: float | None = None, rtol: float = 1e-5,
                    eps: float | None = None, seed: int = 0, perturb: bool = True) -> JacobianReport:
    """Compare every kernel Jacobian of ``model`` with central finite differences.

    Parameters
    ----------
    model : femb.system.model.Model
    state : femb.system.model.State, optional
        Where to check (default: the initial state, moved by a small random
        increment so that no Jacobian vanishes by symmetry, with random
        velocities and multipliers).
    t : float, optional
        Time of the check (default the state's).
    rtol : float
        Largest accepted ``max|J − J_fd| / max(|J|, |J_fd|)``.
    eps : float, optional
        Finite-difference step (default 1e-6 times the model's length scale for
        coordinates, 1e-6 for times).
    seed : int
        Seed of the random state.
    perturb : bool
        Move the state randomly (default True).

    Returns
    -------
    JacobianReport
        ``report.ok``; ``print(report)`` lists every check; ``report.failures``.
    """
    rng = np.random.default_rng(seed)
    st = model.initial_state() if state is None else state
    t = float(st.t if t is None else t)
    q = np.array(st.q, dtype=float)
    L = float(getattr(model, "length_scale", 1.0) or 1.0)
    nv = model.nq
    if perturb:
        d = rng.uniform(-1.0, 1.0, nv) * 0.05 * L
        for _, vs in getattr(model, "rot_blocks", np.zeros((0, 2), dtype=int)):
            d[vs:vs + 3] = rng.uniform(-0.3, 0.3, 3)
        q = model.compose(q, d)
    qd = rng.uniform(-1.0, 1.0, nv) if perturb or state is None else np.array(st.qd, dtype=float)
    lam = rng.uniform(-1.0, 1.0, model.nc)
    fd = _FiniteDifferences(model, t, q, qd, (1e-6 * L) if eps is None else float(eps), rtol)
    for g in model.force_groups:
        fd.check_force(g)
    for g in model.constraint_groups:
        fd.check_constraint(g, lam[g.lam])
    mu = rng.uniform(-1.0, 1.0, getattr(model, "nn", 0))
    for g in getattr(model, "velocity_constraint_groups", []):
        _check_velocity_constraint(g, mu[g.mu], t, fd.gather(g, q, qd), fd.gather, fd.columns, fd.add)
    return fd.report


class _FiniteDifferences:
    """The kernels of one model checked against central differences at (t, q, q̇) (step h in
    coordinates), the results collected in ``report``."""

    def __init__(self, model, t, q, qd, h, rtol):
        self.model, self.t, self.q, self.qd, self.h, self.rtol = model, t, q, qd, h, rtol
        self.nv = model.nq
        self.report = JacobianReport(rtol=rtol)
        # an absolute floor for force Jacobians: 1e-9 of the largest mass-matrix entry (per s or s²),
        # below which a difference is round-off of a force that vanishes (e.g. the gyroscopic force
        # of a body with equal principal inertias), not a wrong Jacobian
        Mc = getattr(model, "M_const", None)
        self.f_floor = 1e-9 * (float(np.max(np.abs(Mc.data), initial=0.0)) if Mc is not None else 0.0)

    def gather(self, group, qq, vv):
        return self.model.ext(qq)[group.xdofs], self.model.ext_velocity(vv)[group.dofs]

    def columns(self, group, fun, what, wrt):
        """FD of fun(q or v) per free global coordinate, mapped to the element columns."""
        model, q, qd, nv = self.model, self.q, self.qd, self.nv
        dofs = group.dofs
        nel, nd = dofs.shape
        f0 = fun(q, qd)
        J = np.zeros(f0.shape + (nd,))
        smallest = np.inf
        for d_ in np.unique(dofs[dofs < nv]):
            e_ = np.zeros(nv)
            e_[d_] = 1.0
            if wrt == "x":
                step = self.h if (getattr(model, "xmap", None) is None or model.xmap[d_] >= 0) else 1e-6
                fp_, fm_ = fun(model.compose(q, step * e_), qd), fun(model.compose(q, -step * e_), qd)
            else:
                step = 1e-6
                fp_, fm_ = fun(q, qd + step * e_), fun(q, qd - step * e_)
            smallest = min(smallest, step)
            col = (fp_ - fm_) / (2.0 * step)
            for e in range(nel):
                hits = np.nonzero(dofs[e] == d_)[0]
                if hits.size:
                    J[e, ..., hits[0]] = col[e]
        noise = FD_NOISE * float(np.max(np.abs(f0), initial=0.0)) / (smallest if np.isfinite(smallest) else 1.0)
        return J, noise

    def free_cols(self, group, A):
        mask = group.dofs < self.nv
        return np.where(mask[:, None, :], A, 0.0) if A.ndim == 3 else A

    def add(self, group, what, A, B, note="", noise=0.0):
        if isinstance(B, tuple):
            B, noise = B
        if what.startswith("force"):
            noise = max(noise, self.f_floor)
        err, scale = _rel(self.free_cols(group, A), self.free_cols(group, B), noise, self.rtol)
        ok = err <= self.rtol
        self.report.checks.append(JacobianCheck(group.cls.__name__, group.name, what, err, scale, ok,
                                                note if not ok else ""))

    def check_force(self, g):
        """fq and fv of a force group (or that its force does not depend on v, when it says so)."""
        t, rtol = self.t, self.rtol
        xe, ve = self.gather(g, self.q, self.qd)
        fe, fq, fv = K.force(g, t, xe, ve, jac=True, raw=True)

        def f_of(qq, vv):
            x_, v_ = self.gather(g, qq, vv)
            return K.force(g, t, x_, v_, jac=False)[0]

        self.add(g, "force: df/dx (fq)", fq, self.columns(g, f_of, "fq", "x"),
                 "the force kernel's fq disagrees with finite differences of fe")
        fd_v, noise_v = self.columns(g, f_of, "fv", "v")
        if g.traits.get("force_depends_on_qd", False):
            self.add(g, "force: df/dv (fv)", fv, fd_v, "the force kernel's fv disagrees with finite differences "
                     "of fe", noise=noise_v)
            return
        big = float(np.max(np.abs(self.free_cols(g, fd_v)), initial=0.0))
        fscale = max(float(np.max(np.abs(fe), initial=0.0)), 1e-300)
        ok = big <= rtol * max(fscale, 1.0) or big <= max(noise_v, self.f_floor)
        self.report.checks.append(JacobianCheck(
            g.cls.__name__, g.name, "force: depends on v?", big / max(fscale, 1.0), big, ok,
            "" if ok else "the force depends on the velocities but the element type does not declare "
                          "force_depends_on_qd = True: its damping is left out of the iteration matrix"))

    def check_constraint(self, g, le):
        """B and H of a constraint group (multipliers ``le``), then its rates."""
        t = self.t
        xe, _ = self.gather(g, self.q, self.qd)
        Phi, B, H = K.constraint(g, t, xe, le, jac=True)

        def phi_of(qq, vv):
            x_, _ = self.gather(g, qq, vv)
            return K.constraint(g, t, x_, None, jac=False)[0]

        def btl_of(qq, vv):
            x_, _ = self.gather(g, qq, vv)
            _, B_, _ = K.constraint(g, t, x_, le, jac=False)
            return np.einsum("ejd,ej->ed", B_, le)

        self.add(g, "constraint: dPhi/dx (B)", B, self.columns(g, phi_of, "B", "x"),
                 "the constraint kernel's B disagrees with finite differences of Phi")
        self.add(g, "constraint: d(B^T lam)/dx (H)", H, self.columns(g, btl_of, "H", "x"),
                 "the constraint kernel's H disagrees with finite differences of B^T lam")
        self.check_rates(g)

    def check_rates(self, g):
        """Φ_t and γ of a constraint group's rates kernel."""
        t, model, q, qd = self.t, self.model, self.q, self.qd
        xe, ve = self.gather(g, q, qd)
        Pt, gam = K.rates(g, t, xe, ve)
        ht = 1e-6 * max(1.0, abs(t))
        Pp = K.constraint(g, t + ht, xe, None, jac=False)[0]
        Pm = K.constraint(g, t - ht, xe, None, jac=False)[0]
        self.add(g, "rates: dPhi/dt (Phi_t)", Pt, (Pp - Pm) / (2.0 * ht),
                 "the rates kernel's Phi_t disagrees with finite differences of Phi in t",
                 noise=FD_NOISE * float(np.max(np.abs(Pp), initial=0.0)) / ht)

        def psi(s):
            # ψ(s) = B(x(s), t + s) v + Φ_t(x(s), t + s) along x(s) = x ∘ exp(s v): dψ/ds = γ
            qs = model.compose(q, s * qd)
            x_, v_ = self.gather(g, qs, qd)
            _, B_, _ = K.constraint(g, t + s, x_, None, jac=False)
            Pt_, _ = K.rates(g, t + s, x_, v_)
            return np.einsum("ejd,ed->ej", B_, v_) + Pt_

        hs = 1e-5
        pp = psi(hs)
        self.add(g, "rates: gamma", gam, (pp - psi(-hs)) / (2.0 * hs),
                 "the rates kernel's gam disagrees with d/dt (B v + Phi_t) along the motion",
                 noise=FD_NOISE * float(np.max(np.abs(pp), initial=0.0)) / hs)


def _check_velocity_constraint(g, me, t, xv, gather, columns, add):
    """A = ∂Ψ/∂v, Dq = ∂Ψ/∂x, H = ∂(Aᵀμ)/∂x and Ψ_t of a velocity-constraint batch against differences."""
    def psi_of(qq, vv):
        x_, v_ = gather(g, qq, vv)
        return K.velocity_constraint(g, t, x_, v_, None, jac=False)[0]

    def atm_of(qq, vv):
        x_, v_ = gather(g, qq, vv)
        return np.einsum("ejd,ej->ed", K.velocity_constraint(g, t, x_, v_, None, jac=False)[1], me)

    _, A, Pt, Dq, H = K.velocity_constraint(g, t, xv[0], xv[1], me, jac=True)
    add(g, "velocity constraint: A", A, columns(g, psi_of, "A", "v"),
        "the velocity_constraint kernel's A disagrees with finite differences of Psi in v")
    add(g, "velocity constraint: dPsi/dx (Dq)", Dq, columns(g, psi_of, "Dq", "x"),
        "the velocity_constraint kernel's Dq disagrees with finite differences of Psi")
    add(g, "velocity constraint: H", H, columns(g, atm_of, "H", "x"),
        "the velocity_constraint kernel's H disagrees with finite differences of A^T mu")
    ht = 1e-6 * max(1.0, abs(t))
    Pp = K.velocity_constraint(g, t + ht, xv[0], xv[1], None, jac=False)[0]
    Pm = K.velocity_constraint(g, t - ht, xv[0], xv[1], None, jac=False)[0]
    add(g, "velocity constraint: Psi_t", Pt, (Pp - Pm) / (2.0 * ht),
        "the velocity_constraint kernel's Psi_t disagrees with finite differences of Psi in t",
        noise=FD_NOISE * float(np.max(np.abs(Pp), initial=0.0)) / ht)

"""Energies and momenta of a simulation, from the element contract.

For every stored step of a :class:`~femb.results.result.Result`:

=================  ============================================================
``kinetic``        T = ½ q̇ᵀ M q̇ (the constant mass matrix of the ``"mass"``
                   kernels: rigid bodies, point masses, beams — translational
                   and rotary inertia)
``gravitational``  V_g = −Σᵢ (M ĝ)ᵢ xᵢ over the translational coordinates,
                   the potential of the gravity force M ĝ that the model
                   assembles (ĝ: g at the translations of every node). For a
                   body with its node at the centre of mass it is −m gᵀr_G;
                   for a beam element, −ρA L gᵀ(r_a + r_b)/2 with any of its
                   translational mass matrices (their rows sum to ρA L/2)
``elastic``        Σ V_e, the potential of every element type whose force
                   derives from one: the ``"energy"`` kernel of its type
                   (``docs/kernels.md``): springs, rotational springs,
                   bushings, planar and spatial beams (½ L εᵀ C ε)
``work_loads``     ∫ Σ f_e·v_e dt over element types that declare
                   ``work = "load"`` (applied forces and torques)
``work_drives``    ∫ λᵀ Φ_t dt, the work of driven (rheonomic) constraints
                   (the power of the constraint forces −Φ_qᵀλ is
                   −λᵀ Φ_q q̇ = λᵀ Φ_t)
``dissipated``     ∫ −(f_e(q, q̇) − f_e(q, 0))·v_e dt over the velocity-dependent
                   forces of the other types (dampers); for damped deformable
                   elements (beams) their work deficit −∫ f_e·v_e dt − ΔV_e
                   (:func:`dissipated_energy`; the gyroscopic moments contribute
                   nothing)
``balance``        T + V_g + V_el − (T + V_g + V_el)(t₀) − W_loads − W_drives
                   + D: zero for the exact motion; for a simulation, the
                   numerical dissipation of the scheme (ρ∞ < 1) plus the
                   error of the trapezoidal rule used for the integrals
``not_counted``    the element types with a force that none of the above
                   covers (they declare neither an ``"energy"`` kernel nor
                   ``work``): a tuple of type names, each warned about once
=================  ============================================================

The integrals use the trapezoidal rule over the *stored* steps: store every
step (``stride=1``) for a sharp balance.

Momenta (:func:`momentum`) are the Noether momenta of the discrete kinetic
energy: p·u = vᵀ M δv_u and H·ω = vᵀ M δv_ω for a rigid translation u and a
rigid rotation ω of the whole model (δṙ = ω × (r − o), δΩ = Rᵀω at frame nodes,
δθ̇ = ω at planar nodes), i.e. p = Σ (M v)_r and
H = Σ (r − o) × (M v)_r + R (M v)_Ω, summed over nodes. They are conserved by
the exact motion of a free model for any mass matrix (consistent or lumped),
since internal forces of objective elements have no resultant.

No element type is named here: what a type contributes comes from its kernels
and class attributes (:mod:`femb.system.element`).
"""
from __future__ import annotations

import warnings

import numpy as np
import scipy.sparse as sp

from femb.errors import ModelError
from femb.system import assembly
from femb.system import kernels as _kernels

KINDS = ("kinetic", "gravitational", "elastic", "work_loads", "work_drives", "dissipated", "total", "balance")
#: the values of an element type's ``work`` attribute (:class:`femb.system.element.Element`)
WORK_KINDS = ("potential", "load", "none")


# ---------------------------------------------------------------------------
# what each batch contributes
# ---------------------------------------------------------------------------
def energy_role(group):
    """What a batch's force contributes to the energies.

    Returns
    -------
    str or None
        ``"potential"`` (its type has an ``"energy"`` kernel), ``"load"``, ``"none"``
        (no force, or a force that stores no energy: workless or purely dissipative),
        or None: a force that the energies do not cover (not counted).
    """
    cls = group.cls
    ks = getattr(cls, "kernels", None) or {}
    work = getattr(cls, "work", None)
    if work is not None and work not in WORK_KINDS:
        raise ModelError(f"element type {cls.__name__}: work = {work!r}; give one of {', '.join(WORK_KINDS)} "
                         f"or None (docs/kernels.md)")
    if "energy" in ks:
        return "potential"
    if not group.traits.get("has_force", False):
        return "none"
    if work in ("load", "none"):
        return work
    return None


def not_counted(model):
    """Names of the element types whose forces the energies do not cover (sorted tuple)."""
    return tuple(sorted({g.cls.__name__ for g in model.groups if energy_role(g) is None}))


def _ext_steps(result):
    """x_ext (nt, nx + nfix) and v_ext (nt, nq + nfix_v) of the stored steps."""
    m = result.model
    nt = result.t.size
    qx = np.concatenate((result.q, np.broadcast_to(m.q_fixed, (nt, m.q_fixed.size))), axis=1)
    vx = np.concatenate((result.qd, np.zeros((nt, m.nfix_v))), axis=1)
    return qx, vx


def _trapz(t, p):
    out = np.zeros_like(p)
    if p.size > 1:
        out[1:] = np.cumsum(0.5 * (p[1:] + p[:-1]) * np.diff(t))
    return out


# ---------------------------------------------------------------------------
# energies
# ---------------------------------------------------------------------------
def kinetic_energy(result):
    """T = ½ q̇ᵀ M q̇ at every stored step, shape (nt,) (J)."""
    m = result.model
    if m.constant_mass:
        M = m.M_const
        return 0.5 * np.einsum("ti,ti->t", result.qd, (M @ result.qd.T).T)
    return np.array([0.5 * qd @ (assembly.mass_matrix(m, q) @ qd) for q, qd in zip(result.q, result.qd)])


def _gravity_force(model):
    """M ĝ over the extended velocity coordinates (n_ext,): the gravity force the model assembles."""
    n_ext = model.nq + model.nfix_v
    f = np.zeros(n_ext)
    qx0 = model.ext(model.q0)
    for g in model.mass_groups:
        Me = _kernels.mass(g, qx0[g.xdofs])
        fe = np.einsum("eij,ej->ei", Me, model.g_hat[g.dofs])
        f += np.bincount(g.dofs.ravel(), fe.ravel(), minlength=n_ext)
    return f


def _nodes(model):
    """Every node of the model's elements, each once (list of Node)."""
    seen, out = set(), []
    for g in model.groups:
        for e in g.elements:
            for nd in e.nodes():
                if id(nd) not in seen and nd.name in model.node_index:
                    seen.add(id(nd))
                    out.append(nd)
    return out


class _Layout:
    """Where the nodes' translations and rotations sit in x_ext and v_ext (index arrays).

    ``rx, rv (n, 3)``: position / velocity indices of each node's translations (−1 where a
    planar node has no z); ``qx (ns, 4), wv (ns, 3)``: quaternion and Ω indices of the
    rotations of spatial nodes; ``tv (np,)``: θ̇ indices of planar nodes.
    """

    def __init__(self, model):
        rx, rv, qx, wv, tv = [], [], [], [], []
        self.spatial = False
        for nd in _nodes(model):
            xi, vi = model.node_index[nd.name], model.node_vindex[nd.name]
            tr = list(nd.translational)
            rx.append([int(xi[c]) for c in tr] + [-1] * (3 - len(tr)))
            rv.append([int(vi[c]) for c in tr] + [-1] * (3 - len(tr)))
            blocks = getattr(nd, "rotation_blocks", ())
            for bx, bv in blocks:
                qx.append(xi[bx:bx + 4])
                wv.append(vi[bv:bv + 3])
            self.spatial |= bool(blocks)
            if not blocks and "theta" in getattr(nd, "coord_names", ()):
                tv.append(int(vi[list(nd.coord_names).index("theta")]))
        self.rx = np.array(rx, dtype=np.int64).reshape(-1, 3)
        self.rv = np.array(rv, dtype=np.int64).reshape(-1, 3)
        self.qx = np.array(qx, dtype=np.int64).reshape(-1, 4)
        self.wv = np.array(wv, dtype=np.int64).reshape(-1, 3)
        self.tv = np.array(tv, dtype=np.int64)


def _take(a, idx):
    """a[..., idx] with zeros where idx < 0."""
    out = a[..., np.where(idx >= 0, idx, 0)]
    out[..., idx < 0] = 0.0
    return out


def gravitational_energy(result):
    """V_g = −Σᵢ (M ĝ)ᵢ xᵢ over the translational coordinates, shape (nt,) (J).

    The potential of the gravity force M ĝ (module table); a planar gravity acts on
    the x and y translations of spatial nodes, a spatial one with its x and y
    components on planar nodes (as the assembled force). Zeros without gravity.
    """
    m = result.model
    if m.g_hat is None:
        return np.zeros(result.t.size)
    f = _gravity_force(m)
    lay = _Layout(m)
    free = (lay.rx >= 0) & (lay.rx < m.nx)
    xi, vi = lay.rx[free], lay.rv[free]
    return -(result.q[:, xi] @ f[vi])


def _warn_not_counted(names):
    if names:
        warnings.warn(f"energies: the forces of the element type{'s' if len(names) > 1 else ''} "
                      f"{', '.join(names)} are not counted (the type declares neither an 'energy' kernel "
                      f"for its potential nor its work = 'load' or 'none'; docs/kernels.md); the energy "
                      f"balance leaves them out", _kernels.ContractWarning, stacklevel=3)


def elastic_energy(result, by_element=False):
    """Potential energy of the elements (springs, bushings, beams, ...), shape (nt,) (J).

    The sum of the ``"energy"`` kernels of every batch whose type has one.

    Parameters
    ----------
    result : Result
    by_element : bool
        Return a dict ``{element name: (nt,) array}`` instead of the sum.
    """
    m = result.model
    nt = result.t.size
    groups = [g for g in m.groups if energy_role(g) == "potential"]
    qx, _ = _ext_steps(result)
    total = np.zeros(nt)
    parts = {g.name: np.zeros((nt, g.nel)) for g in groups} if by_element else None
    for k in range(nt):
        for g in groups:
            Ve = _kernels.energy(g, result.t[k], qx[k][g.xdofs])
            total[k] += Ve.sum()
            if by_element:
                parts[g.name][k] = Ve
    if not by_element:
        return total
    return {name: parts[g.name][:, i].copy() for g in groups for i, name in enumerate(g.names)}


def _force_groups(model, role):
    return [g for g in model.groups if g.traits.get("has_force", False) and energy_role(g) == role]


def load_power(result):
    """Power of the applied loads, Σ f_e·v_e over types with ``work = "load"``, shape (nt,) (W)."""
    m = result.model
    qx, vx = _ext_steps(result)
    P = np.zeros(result.t.size)
    for g in _force_groups(m, "load"):
        force = _kernels.ForceValues(g)
        for k, t in enumerate(result.t):
            ve = vx[k][g.dofs]
            P[k] += np.einsum("ei,ei->", force(t, qx[k][g.xdofs], ve), ve)
    return P


def drive_power(result):
    """Power of the constraint forces, λᵀ Φ_t (nonzero for driven constraints only), shape (nt,) (W)."""
    m = result.model
    if not m.nc or not m.rheonomic:
        return np.zeros(result.t.size)
    return np.array([lam @ assembly.constraint_rates(m, t, q, qd)[0]
                     for t, q, qd, lam in zip(result.t, result.q, result.qd, result.lam)])


def _damped_groups(model):
    """The batches whose forces depend on q̇ and are not loads."""
    return [g for g in model.groups if g.traits.get("has_force", False) and g.traits.get("force_depends_on_qd", False)
            and energy_role(g) != "load"]


def _deformable(model, g):
    """A batch of elements with mass, a potential and material damping (a damped beam: ∂f/∂q̇ ≠ 0
    at zero velocity, which gyroscopic moments are not), whose dissipated energy is its work
    deficit (:func:`dissipated_energy`)."""
    if not (g.traits.get("has_mass", False) and energy_role(g) == "potential"):
        return False
    qx = model.ext(model.q0)
    _, _, fv = _kernels.force(g, 0.0, qx[g.xdofs], np.zeros((g.nel, g.ndv)), True)
    return fv is not None and bool(np.any(fv != 0.0))


def _power(result, groups, elastic):
    """−Σ (f_e(q, q̇) − f_e(q, 0))·v_e over ``groups`` at every stored step, shape (nt,) (W);
    with ``elastic`` the whole force's power −Σ f_e(q, q̇)·v_e."""
    qx, vx = _ext_steps(result)
    D = np.zeros(result.t.size)
    for g in groups:
        z = np.zeros((g.nel, g.ndv))
        force = _kernels.ForceValues(g)
        for k, t in enumerate(result.t):
            xe, ve = qx[k][g.xdofs], vx[k][g.dofs]
            f = force(t, xe, ve) if elastic else force(t, xe, ve) - force(t, xe, z)
            D[k] -= np.einsum("ei,ei->", f, ve)
    return D


def dissipation_power(result):
    """Power taken out by velocity-dependent forces, −Σ (f_e(q, q̇) − f_e(q, 0))·v_e ≥ 0, shape (nt,) (W).

    Over the batches whose forces depend on q̇ and are not loads.
    """
    return _power(result, _damped_groups(result.model), False)


def dissipated_energy(result):
    """Energy taken out by the velocity-dependent forces up to every stored step, shape (nt,) (J).

    Dampers (batches without mass): ∫ of :func:`dissipation_power`. Damped deformable elements
    (beams with material damping: mass and a potential V_e): their work deficit

        D_e(t) = −∫ f_e(q, q̇)·v_e dt − (V_e(t) − V_e(t₀)),

    the energy their forces took from the motion that their strain does not hold, with the
    integral over the stored steps (trapezoidal rule) as every integral here. For the exact
    motion it is ∫ of their damping power; for a simulation it is the residual of the energy
    identity of these elements, the dissipation of the scheme in them. Their damping power
    alone was not: the index-3 velocities carry an O(h²) strain rate (the velocity defect of the
    joints, taken up by a stiff beam's strain) that the positions do not, so that where η ω² h ≫ 1
    the damping power −C q̇·q̇ counted energy that the motion never lost (a flexible rod
    with E × 10⁴ and η = 10⁻³ s at h = 1 ms: 0.57 J over 0.1 s against a kinetic energy that
    equals the undamped run's to 10⁻⁴, balance 0.124), while the elastic forces, which balance the
    damping forces in such modes, do the opposite work on the same strain rate.
    """
    m = result.model
    t = result.t
    groups = _damped_groups(m)
    deformable = [g for g in groups if _deformable(m, g)]
    D = _trapz(t, _power(result, [g for g in groups if g not in deformable], False))
    if deformable:
        qx, _ = _ext_steps(result)
        V = np.array([sum(_kernels.energy(g, tk, qx[k][g.xdofs]).sum() for g in deformable)
                      for k, tk in enumerate(t)])
        D = D + _trapz(t, _power(result, deformable, True)) - (V - V[0])
    return D


def energies(result):
    """All energies and the balance at every stored step (see the module table).

    Returns
    -------
    dict
        ``kinetic``, ``gravitational``, ``elastic``, ``work_loads``, ``work_drives``,
        ``dissipated``, ``total`` (T + V_g + V_el) and ``balance``: arrays of shape (nt,),
        in J; ``not_counted``: a tuple of the element type names whose forces none of
        them covers (one :class:`femb.system.kernels.ContractWarning` names them).
    """
    if result.qd is None or result.t.size == 0:
        raise ModelError("energies need a result with stored steps and velocities")
    t = result.t
    skipped = not_counted(result.model)
    _warn_not_counted(skipped)
    out = {"kinetic": kinetic_energy(result), "gravitational": gravitational_energy(result),
           "elastic": elastic_energy(result)}
    out["work_loads"] = _trapz(t, load_power(result))
    out["work_drives"] = _trapz(t, drive_power(result))
    out["dissipated"] = dissipated_energy(result)
    out["total"] = out["kinetic"] + out["gravitational"] + out["elastic"]
    out["balance"] = (out["total"] - out["total"][0] - out["work_loads"] - out["work_drives"]
                      + out["dissipated"])
    out["not_counted"] = skipped
    return out


def balance_ratio(e):
    """Largest |balance| of the energies ``e`` (:func:`energies`) relative to the run's energy scale.

    The scale is the largest of: the kinetic energy T at any stored step (the
    energy of the motion, whatever part of it stays constant: a body spinning
    steadily about a principal axis has its whole T in it), and the ranges
    (max − min) of T, V_g, V_el and of the work and dissipation integrals (the
    energy that changes form; the gravity datum does not enter). A relative
    balance error of order h² (ρ∞ = 1) or the numerical dissipation (ρ∞ < 1) is
    expected. With the ranges alone a steady spin would read ≈ 1 for any h: its
    T is constant, so the range of T is the scheme's error itself.
    """
    scale = max([float(np.abs(e["kinetic"]).max())]
                + [float(np.ptp(e[k])) for k in ("kinetic", "gravitational", "elastic", "work_loads",
                                                 "work_drives", "dissipated")])
    err = float(np.abs(e["balance"]).max())
    return err / scale if scale > 0.0 else err


def energy_balance(result):
    """Largest |balance| relative to the energy scale of the run (:func:`balance_ratio`).

    Returns
    -------
    float
    """
    return balance_ratio(energies(result))


# ---------------------------------------------------------------------------
# momenta
# ---------------------------------------------------------------------------
def _mass_ext(model, names=None):
    """The constant mass matrix over the extended velocity coordinates (csr, n_ext × n_ext),
    of every element or of the elements named in ``names`` (a set)."""
    n_ext = model.nq + model.nfix_v
    qx0 = model.ext(model.q0)
    rows, cols, vals = [], [], []
    for g in model.mass_groups:
        sel = np.arange(g.nel) if names is None else np.array(
            [i for i, n in enumerate(g.names) if n in names], dtype=np.int64)
        if sel.size == 0:
            continue
        Me = _kernels.mass(g, qx0[g.xdofs])[sel]
        d = g.dofs[sel]
        rows.append(np.repeat(d, d.shape[1], axis=1).ravel())
        cols.append(np.tile(d, (1, d.shape[1])).ravel())
        vals.append(Me.ravel())
    if not vals:
        return sp.csr_matrix((n_ext, n_ext))
    return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                         shape=(n_ext, n_ext))


def _rotate(p, w):
    """R(p) w for unit quaternions p (..., 4) = (p0, p1, p2, p3) and vectors w (..., 3):
    w + 2 p_v × (p_v × w + p0 w)."""
    p = p / np.linalg.norm(p, axis=-1, keepdims=True)
    pv = p[..., 1:]
    return w + 2.0 * np.cross(pv, np.cross(pv, w) + p[..., :1] * w)


def _select(model, of):
    """The set of element names that ``of`` selects (None: all)."""
    if of is None:
        return None
    if isinstance(of, str):
        of = [of]
    elif isinstance(of, (list, tuple, set, frozenset)) and all(isinstance(n, str) for n in of):
        of = list(of)
    else:
        raise ModelError(f"momentum: of must be a name or a sequence of names of bodies or beams, got {of!r}")
    if not of or not all(of):
        raise ModelError(f"momentum: of names nothing ({of!r}); give a body, a beam element or the name of a "
                         f"meshed beam, or leave it out for the whole model")
    known = [n for g in model.mass_groups for n in g.names]
    out = set()
    for name in of:
        hit = [n for n in known if n == name or n.startswith(f"{name}.")]
        if not hit:
            raise ModelError(f"momentum: '{name}' names no element with mass of model '{model.name}' "
                             f"(give a body, a beam element, or the name of a meshed beam)")
        out.update(hit)
    return out


def momentum(result, about=None, of=None):
    """Linear and angular momentum at every stored step (module docstring).

    Parameters
    ----------
    result : Result
    about : array_like, optional
        The point o of the angular momentum, (3,) (spatial) or (2,) (planar) (m);
        default the origin.
    of : str or sequence of str, optional
        The bodies / beam elements to sum over, by name; the name of a meshed beam
        (``spatial_beam(mech, "arm", ...)``, ``add_beam``) selects its elements
        (``"arm.<k>"``). Default: the whole model.

    Returns
    -------
    p : ndarray, shape (nt, 3) (spatial) or (nt, 2) (planar)
        Linear momentum (kg m/s), space axes.
    H : ndarray, shape (nt, 3) (spatial) or (nt,) (planar, about z)
        Angular momentum about ``about`` (kg m²/s), space axes.
        A model with spatial nodes gives 3-vectors; its planar nodes move in the
        plane z = 0 with no velocity along z.
    """
    m = result.model
    if result.qd is None or result.t.size == 0:
        raise ModelError("momentum needs a result with stored steps and velocities")
    lay = _Layout(m)
    dim = 3 if lay.spatial else 2
    o = np.zeros(3)
    if about is not None:
        try:
            a = np.asarray(about, dtype=float).reshape(-1)
        except (TypeError, ValueError):
            a = np.array([np.nan])
        if a.size not in (dim, 3) or not np.all(np.isfinite(a)):
            raise ModelError(f"momentum: about must be a finite point of {dim} coordinates, got {about!r}")
        o[:a.size] = a
    M = _mass_ext(m, _select(m, of))[:, :m.nq].tocsr()
    nt = result.t.size
    p, H = np.zeros((nt, 3)), np.zeros((nt, 3))
    chunk = max(1, 2_000_000 // max(1, M.shape[0] + lay.rx.size))
    for k0 in range(0, nt, chunk):                          # steps in chunks: bounded memory
        sl = slice(k0, min(nt, k0 + chunk))
        q = result.q[sl]
        qx = np.concatenate((q, np.broadcast_to(m.q_fixed, (q.shape[0], m.q_fixed.size))), axis=1)
        Mv = (M @ result.qd[sl].T).T                         # (n, n_ext)
        f = _take(Mv, lay.rv)                                # (n, nodes, 3)
        r = _take(qx, lay.rx) - o                            # planar nodes: z = 0
        p[sl] = f.sum(axis=1)
        H[sl] = np.cross(r, f).sum(axis=1)
        if lay.qx.size:
            H[sl] += _rotate(qx[:, lay.qx], Mv[:, lay.wv]).sum(axis=1)
        if lay.tv.size:
            H[sl, 2] += Mv[:, lay.tv].sum(axis=1)
    if lay.spatial:
        return p, H
    return p[:, :2], H[:, 2]

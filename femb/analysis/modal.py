"""Linearized free vibrations (modes) of a constrained model about a reference state.

Small motions q = q_ref + δq about a state satisfying the equations of motion
with q̇ = q̈ = 0 (an equilibrium: the unloaded initial configuration, or the
result of :func:`femb.analysis.static.solve_static`) obey

    M δq̈ + K_t δq + Φ_qᵀ δλ = 0,    Φ_q δq = 0,

with K_t = ∂(M q̈ − f + Φ_qᵀλ)/∂q the tangent stiffness of the solver
(method.md eq. 7; it includes the geometric stiffness of pre-stressed
elements and the constraint term ∂(Φ_qᵀλ)/∂q), evaluated by
:func:`femb.system.assembly.tangent_stiffness`. The constraints are eliminated with a
basis N of the null space of Φ_q (δq = N y, Φ_q N = 0), leaving the symmetric
generalized eigenproblem

    (Nᵀ K_t N) y = ω² (Nᵀ M N) y

(Géradin & Cardona 2001, Sect. 10.3; Géradin & Rixen, Mechanical
Vibrations, 3rd ed., Wiley 2015, Sect. 2.6 and 4.4). For large models
the null-space basis is replaced by the equivalent augmented pencil
([K_t, Φ_qᵀ; Φ_q, 0], [M, 0; 0, 0]), solved in shift-invert mode by
ARPACK; its infinite eigenvalues (the constraint directions) never appear
near the shift. Damping and gyroscopic terms are ignored (undamped modes);
a non-symmetric K_t (follower loads) is symmetrized and the asymmetry is
reported.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from femb.errors import ModelError, ParameterError, SingularMatrixError
from femb.system import assembly
from femb.system.initial import refuse_contacts
from femb.system.model import Model, State

#: models with at most this many free coordinates use the dense null-space method
DENSE_LIMIT = 400


@dataclass(repr=False)
class ModalResult:
    """Eigenfrequencies and mode shapes of a linearized model.

    Attributes
    ----------
    model : Model
    state : State
        The reference state.
    omega : ndarray, shape (k,)
        Circular eigenfrequencies (rad/s), ascending; a negative value −√|ω²|
        flags a negative eigenvalue ω² (an unstable equilibrium).
    modes : ndarray, shape (k, nq)
        Mode shapes, mass normalized (φᵀ M φ = 1), satisfying Φ_q φ = 0; in the tangent
        coordinates (on rotation nodes δθ in body axes: q = q_ref ∘ exp(δq)).
    method : str
        ``"dense"`` (null space) or ``"sparse"`` (shift-invert).
    asymmetry : float
        ‖K_t − K_tᵀ‖ / ‖K_t‖ (max-abs norms) of the tangent stiffness before
        symmetrization.
    """

    model: object
    state: State
    omega: np.ndarray
    modes: np.ndarray
    method: str
    asymmetry: float = 0.0
    info: dict = field(default_factory=dict)

    @property
    def frequency(self):
        """Eigenfrequencies in Hz, shape (k,)."""
        return self.omega / (2.0 * np.pi)

    def _summary(self):
        """(title, rows) for :meth:`__repr__` and :meth:`_repr_html_`."""
        from femb.base.summary import short_list

        rows = [("modes", f"{len(self.omega)} of nq = {self.model.nq}, {self.method} method"),
                ("frequency", short_list((f"{f:.5g}" for f in self.frequency), 6) + " Hz"),
                ("reference", f"t = {float(self.state.t):.6g} s; modes {tuple(self.modes.shape)}, "
                              "mass normalized"),
                ("asymmetry", f"{self.asymmetry:.2e} (of K_t, before symmetrization)")]
        return f"femb ModalResult of '{self.model.name}'", rows

    def __repr__(self):
        from femb.base.summary import text

        return text(*self._summary())

    def _repr_html_(self):
        from femb.base.summary import html

        return html(*self._summary())

    def node_mode(self, name, k):
        """Components of mode ``k`` at node ``name`` (fixed coordinates are 0), shape (ncoord,).

        Modes live in the velocity (tangent) coordinates: for a frame node the 6 components
        (δx in space axes, δθ in body axes).
        """
        try:
            idx = self.model.node_vindex[name]
        except KeyError:
            raise ModelError(f"no node named '{name}'") from None
        phi = self.modes[k]
        return np.array([phi[i] if i < self.model.nq else 0.0 for i in idx])


def _reference_state(model, state, t):
    if state is None:
        return State(float(t or 0.0), model.q0.copy(), np.zeros(model.nq), np.zeros(model.nq),
                     np.zeros(model.nc))
    st = getattr(state, "state", state)        # a StaticResult gives its last equilibrium
    st = State(float(st.t if t is None else t), np.asarray(st.q, float).copy(), np.zeros(model.nq),
               np.zeros(model.nq), np.asarray(st.lam, float).copy())
    if st.q.shape != model.q0.shape or st.lam.shape != (model.nc,):
        raise ParameterError(f"state does not fit model '{model.name}' (nx = {model.q0.size}, nc = {model.nc})")
    return st


def modal_analysis(model: Model, state: State | None = None, n_modes: int = 6, *, t: float | None = None,
                   method: str = "auto", sigma: float | None = None) -> ModalResult:
    """Lowest eigenfrequencies and modes of the linearized constrained model.

    Parameters
    ----------
    model : Model
    state : State or StaticResult, optional
        Reference equilibrium (q and λ are used; q̇ = q̈ = 0 is assumed).
        Default: the model's initial coordinates with λ = 0 (an unloaded,
        stress-free configuration).
    n_modes : int
        Number of modes (the lowest ones).
    t : float, optional
        Time for rheonomic constraints (default: the state's time).
    method : {"auto", "dense", "sparse"}
        Dense null space + ``scipy.linalg.eigh`` (up to ``DENSE_LIMIT`` free
        coordinates with "auto"), or sparse shift-invert Lanczos
        (``scipy.sparse.linalg.eigsh``) on the augmented pencil.
    sigma : float, optional
        Shift (rad²/s²) of the sparse method; default 0 (then a model with
        rigid-body modes needs a small negative shift).

    Returns
    -------
    ModalResult
    """
    refuse_contacts(model, 'modal analysis (modal_analysis)')
    st = _reference_state(model, state, t)
    nq, nc = model.nq, model.nc
    k = int(n_modes)
    if k < 1:
        raise ParameterError(f"n_modes must be at least 1, got {n_modes!r}")
    K = assembly.tangent_stiffness(model, st).tocsr()
    Kn = abs(K).max() if K.nnz else 0.0
    asym = float(abs(K - K.T).max() / Kn) if Kn > 0 else 0.0
    K = 0.5 * (K + K.T)
    M = assembly.mass_matrix(model, st.q).tocsr()
    B = assembly.constraint_jacobian(model, st.t, st.q).tocsr()
    if method == "auto":
        method = "dense" if nq <= DENSE_LIMIT else "sparse"
    if method == "dense":
        if nc:
            Nb = sla.null_space(B.toarray())
        else:
            Nb = np.eye(nq)
        ndof = Nb.shape[1]
        if ndof == 0:
            raise ModelError(f"model '{model.name}' has no degree of freedom left by its constraints")
        k = min(k, ndof)
        Kr = Nb.T @ (K @ Nb)
        Mr = Nb.T @ (M @ Nb)
        Kr = 0.5 * (Kr + Kr.T)
        Mr = 0.5 * (Mr + Mr.T)
        try:
            w2, Y = sla.eigh(Kr, Mr, subset_by_index=[0, k - 1])
        except np.linalg.LinAlgError:
            raise SingularMatrixError(
                "the reduced mass matrix Nᵀ M N is not positive definite: some unconstrained "
                "coordinate carries no mass (e.g. a section with ρI = 0)") from None
        Phi = (Nb @ Y).T
        info = {"dof": ndof}
    elif method == "sparse":
        s = 0.0 if sigma is None else float(sigma)
        A = sp.bmat([[K, B.T], [B, None]], format="csc") if nc else K.tocsc()
        Mb = sp.block_diag((M, sp.csr_matrix((nc, nc))), format="csc") if nc else M.tocsc()
        try:
            w2, X = spla.eigsh(A, k=k, M=Mb, sigma=s, which="LM")
        except RuntimeError as err:
            raise SingularMatrixError(
                f"shift-invert factorization failed at sigma = {s:g} ({err}); for a model with "
                "rigid-body modes give a small negative sigma") from None
        order = np.argsort(w2)
        w2, Phi = w2[order], X[:nq, order].T
        info = {"sigma": s}
    else:
        raise ParameterError(f"method must be 'auto', 'dense' or 'sparse', got {method!r}")
    # mass normalization (dense eigh already normalizes; the sparse modes carry λ parts)
    for i in range(Phi.shape[0]):
        m = float(Phi[i] @ (M @ Phi[i]))
        if m > 0:
            Phi[i] /= np.sqrt(m)
    omega = np.sign(w2) * np.sqrt(np.abs(w2))
    return ModalResult(model=model, state=st, omega=omega, modes=Phi, method=method, asymmetry=asym,
                       info=info)


@dataclass(repr=False)
class BucklingResult:
    """Linearized buckling load factors and modes.

    Attributes
    ----------
    model : Model
    factors : ndarray, shape (k,)
        Load factors μ (multiples of the applied loads) at which K_0 + μ K_G is singular,
        the k smallest in magnitude, real ones only, ascending by |μ|; negative values are
        the critical factors of the reversed loads.
    modes : ndarray, shape (k, nq)
        Buckling modes (tangent coordinates, max-abs normalized), Φ_q φ = 0.
    delta : float
        The load factor of the two equilibria that gave K_G.
    """

    model: object
    factors: np.ndarray
    modes: np.ndarray
    delta: float

    def _summary(self):
        """(title, rows) for :meth:`__repr__` and :meth:`_repr_html_`."""
        from femb.base.summary import short_list

        rows = [("load factors", short_list((f"{f:.6g}" for f in self.factors), 6)),
                ("modes", f"{tuple(self.modes.shape)}, max-abs normalized"),
                ("K_G", f"central difference at load factors ±{self.delta:.3g}")]
        return f"femb BucklingResult of '{self.model.name}'", rows

    def __repr__(self):
        from femb.base.summary import text

        return text(*self._summary())

    def _repr_html_(self):
        from femb.base.summary import html

        return html(*self._summary())


def buckling_analysis(model: Model, n_modes: int = 4, *, t: float = 0.0, load_types: tuple[type, ...] | None = None,
                      delta: float = 1e-3) -> BucklingResult:
    """Linearized (eigenvalue) buckling about the unloaded initial configuration.

    The tangent stiffness along the equilibrium path q(μ) of the load factor μ
    (:func:`femb.analysis.static.solve_static`) is linearized at μ = 0,
    K_t(μ) ≈ K_0 + μ K_G, and the critical factors solve (K_0 + μ K_G) φ = 0 on the
    admissible motions (Φ_q φ = 0; null-space basis as in :func:`modal_analysis`).
    K_G = dK_t/dμ at μ = 0 is the central difference of the tangents at the two
    equilibria μ = ±δ, (K_t(q(δ), δ) − K_t(q(−δ), −δ))/(2δ), accurate to O(δ²): it holds
    the stress (geometric) stiffness of the pre-buckling state, the load stiffness and the
    change of the material stiffness with the pre-buckling displacements (Crisfield 1991,
    Vol. 1, Sect. 9.9 and Vol. 2, Ch. 17; Géradin & Cardona 2001, Ch. 10). Classical
    linear buckling: valid where the pre-buckling path is nearly linear.

    Parameters
    ----------
    model : Model
    n_modes : int
    t : float
    load_types : tuple of element classes, optional
        The loads scaled by μ (as :func:`femb.analysis.static.solve_static`).
    delta : float
        Load factor of the two equilibria (small compared with the critical factor).

    Returns
    -------
    BucklingResult
    """
    refuse_contacts(model, 'buckling analysis (buckling_analysis)')
    from femb.analysis.static import solve_static

    z = np.zeros(model.nq)
    K = []
    for mu in (delta, -delta):
        r = solve_static(model, load_factors=[mu], t=t, load_types=load_types)
        K.append(assembly.tangent_stiffness(model, State(t, r.q[-1], z, z, r.lam[-1])).toarray())
    st = State(t, model.q0.copy(), z, z, np.zeros(model.nc))
    K0 = assembly.tangent_stiffness(model, st).toarray()
    KG = (K[0] - K[1]) / (2.0 * delta)
    B = assembly.constraint_jacobian(model, t, model.q0).toarray()
    Nb = sla.null_space(B) if model.nc else np.eye(model.nq)
    mu, Y = sla.eig(Nb.T @ K0 @ Nb, -(Nb.T @ KG @ Nb))
    ok = np.isfinite(mu) & (np.abs(mu.imag) <= 1e-8 * np.abs(mu))
    mu, Y = mu[ok].real, Y[:, ok].real
    order = np.argsort(np.abs(mu))[:int(n_modes)]
    modes = (Nb @ Y[:, order]).T
    modes /= np.abs(modes).max(axis=1, keepdims=True)
    return BucklingResult(model=model, factors=mu[order], modes=modes, delta=float(delta))

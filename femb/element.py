"""The element contract.

An element type is a class. Its instances are what a user adds to a
:class:`~femb.mechanism.Mechanism`: each names its nodes and holds its own
parameters. At compile time the instances of one type (and one
:meth:`Element.group_key`) are *packed* into stacked parameter arrays, and from
then on the type's **batch kernels** evaluate all of them at once. Kernels are
class methods; they receive

``p``
    the packed parameters (a dict of arrays with leading dimension ``nel``),
``t``
    the time (float),
``qe, qde`` : ndarray, shape (nel, nd)
    the stacked coordinates and velocities of each element's nodes, in node
    order (``nd`` = sum of the nodes' coordinate counts; fixed coordinates
    included),
``lame`` : ndarray, shape (nel, nc)
    the element's Lagrange multipliers,

and return stacked arrays. Python loops run over element *types*, never over
elements. Multi-node elements with numerical integration (beams) evaluate their
integration points inside the kernel, vectorized over ``(nel, ngauss)``;
spatial nodes simply have more coordinates per node. Neither needs a change to
assembly or solver: the contract sees only ``(nel, nd)`` arrays.

Class-level metadata tells the compiled model what a scene needs:

=========================  ===================================================
``has_mass``                contributes to M via :meth:`mass`
``constant_mass``           M of this type does not depend on q (assembled once)
``has_force``               contributes to f via :meth:`force`
``force_depends_on_qd``     f depends on q̇ (C_t is needed)
``constant_force``          f does not depend on t, q, q̇ (evaluated once at compile)
``n_constraints``           constraints per element (0: none)
``rheonomic``               Φ depends explicitly on t
=========================  ===================================================

Sign conventions follow Arnold & Brüls (2007): M q̈ = f − Φ_qᵀ λ, Φ = 0.
"""
from __future__ import annotations

from .errors import ModelError


class Element:
    """Base class of all elements (see the module docstring for the contract)."""

    has_mass = False
    constant_mass = True
    has_force = False
    force_depends_on_qd = False
    constant_force = False
    n_constraints = 0
    rheonomic = False
    #: names of this type's constraint equations, for named reactions
    constraint_names: tuple = ()
    #: compiled kernels by role ("mass", "force", "constraint", "rates"), see docs/kernels.md
    kernels: dict = {}

    def __init__(self, name):
        if not isinstance(name, str) or not name:
            raise ModelError(f"{type(self).__name__}: name must be a non-empty string, got {name!r}")
        self.name = name

    # ------------------------------------------------------------------ topology
    def nodes(self):
        """Nodes whose coordinates form ``qe``, in order (list of Node)."""
        return []

    def resolve(self, lookup):
        """Replace body names by body objects; ``lookup(name, role)`` raises if absent."""

    def group_key(self):
        """Key splitting a type into batches of equal layout (default: one batch)."""
        return type(self).__name__

    def validate(self):
        """Check parameters once the references are resolved; raise ModelError."""

    @classmethod
    def traits(cls, elements):
        """Metadata of one batch (default: the class attributes).

        A type may refine them per batch, e.g. springs without damping report
        ``force_depends_on_qd = False`` so the model needs no C_t for them.
        """
        return {k: getattr(cls, k) for k in (
            "has_mass", "constant_mass", "has_force", "force_depends_on_qd",
            "constant_force", "n_constraints", "rheonomic")}

    @classmethod
    def time_functions(cls, element):
        """The element's TimeFunctions (same count for every element of a batch)."""
        return []

    # -------------------------------------------------------------- packing
    @classmethod
    def pack(cls, elements):
        """Stack the parameters of ``elements`` into a dict of arrays."""
        return {}

    # -------------------------------------------------------------- kernels
    @classmethod
    def mass(cls, p, qe):
        """Element mass matrices, shape (nel, nd, nd)."""
        raise NotImplementedError(f"{cls.__name__} declares has_mass but has no mass kernel")

    @classmethod
    def force(cls, p, t, qe, qde, jac):
        """Element forces.

        Returns
        -------
        f : ndarray, shape (nel, nd)
        f_q : ndarray, shape (nel, nd, nd), or None when ``jac`` is False
            ∂f/∂q.
        f_qd : ndarray, shape (nel, nd, nd), or None
            ∂f/∂q̇ (only for types with ``force_depends_on_qd``).
        """
        raise NotImplementedError(f"{cls.__name__} declares has_force but has no force kernel")

    @classmethod
    def constraint(cls, p, t, qe):
        """Constraint values and gradients.

        Returns
        -------
        Phi : ndarray, shape (nel, nc)
        Phi_q : ndarray, shape (nel, nc, nd)
        """
        raise NotImplementedError(f"{cls.__name__} declares constraints but has no kernel")

    @classmethod
    def constraint_hessian(cls, p, t, qe, lame):
        """∂(Φ_qᵀ λ)/∂q per element, shape (nel, nd, nd), or None if zero."""
        raise NotImplementedError(f"{cls.__name__} declares constraints but has no constraint_hessian kernel")

    @classmethod
    def constraint_all(cls, p, t, qe, lame, jac):
        """Φ, Φ_q and (when ``jac``) ∂(Φ_qᵀλ)/∂q in one call.

        The solver calls this; the default combines :meth:`constraint` and
        :meth:`constraint_hessian`. Types override it to share work (trigonometry)
        between the three.
        """
        Phi, Phi_q = cls.constraint(p, t, qe)
        return Phi, Phi_q, (cls.constraint_hessian(p, t, qe, lame) if jac else None)

    @classmethod
    def constraint_rates(cls, p, t, qe, qde):
        """Time derivatives needed for consistent initial values.

        Returns
        -------
        Phi_t : ndarray, shape (nel, nc)
            ∂Φ/∂t.
        gamma : ndarray, shape (nel, nc)
            (Φ_q q̇)_q q̇ + 2 Φ_qt q̇ + Φ_tt, so that Φ_q q̈ = −gamma.
        """
        raise NotImplementedError(f"{cls.__name__} declares constraints but has no constraint_rates kernel")

    @classmethod
    def geometry(cls, p, t, qe, qde, lame, names):
        """Plain geometry for output: list of :class:`femb.geometry.GeometryBlock`."""
        return []

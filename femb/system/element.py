"""The element contract.

An element type is a class. Its instances are what a user adds to a
:class:`~femb.system.mechanism.Mechanism`: each names its nodes and holds its own
parameters. At compile time the instances of one type (and one
:meth:`Element.group_key`) are *packed* into a batch: a parameter array ``P``
(``pack(elements)["P"]``, shape (nel, npar)) and index arrays into the global
coordinates. From then on the type's **compiled kernels** (``kernels``, a dict
of ``femb.base.jit.kernel`` functions by role: ``"mass"``, ``"force"``,
``"constraint"``, ``"rates"``, ``"energy"``) evaluate all elements of the batch at once.
Their signatures and output shapes are the contract of ``docs/kernels.md``;
the compiled time loop (``femb/engine/``) calls them, and so does every Python
path (:mod:`femb.system.kernels`), so each element's equations exist once.

Class-level metadata tells the compiled model what a scene needs:

==========================  ==================================================
``has_mass``                contributes to M via ``kernels["mass"]``
``constant_mass``           M of this type does not depend on q (assembled once)
``has_force``               contributes to f via ``kernels["force"]``
``force_depends_on_qd``     f depends on q̇ (C_t is needed)
``constant_force``          f does not depend on t, q, q̇ (evaluated once at compile)
``n_constraints``           constraints per element (0: none)
``rheonomic``               Φ depends explicitly on t
``work``                    how the type's force enters the energies
                            (:mod:`femb.results.energy`): ``"potential"`` (it derives
                            from the potential of ``kernels["energy"]``; its
                            velocity-dependent part is dissipation), ``"load"``
                            (an applied load: its work ∫ f_e·v_e dt; static
                            analysis scales it), ``"none"`` (stores no energy:
                            gyroscopic or purely dissipative); None (default):
                            not declared, the energies report the type as not
                            counted
``spatial``                 acts on spatial frame nodes
``glyph``                   how pictures draw the type (:mod:`femb.io.frames`)
``n_velocity_constraints``  velocity-level (non-holonomic) constraints per
                            element, A(q, t) v + a(q, t) = 0, via
                            ``kernels["velocity_constraint"]`` (0: none)
``n_contacts``              unilateral contacts per element (gaps g_N ≥ 0, role
                            ``"contact"``, docs/contact.md; 0: none)
``n_friction``              tangent (friction) directions per element
==========================  ==================================================

Kinetic and gravitational energy and the momenta need no trait: they follow
from the ``"mass"`` kernel (T = ½ vᵀMv; the gravity force is M ĝ).

Sign conventions follow Arnold & Brüls (2007): M q̈ = f − Φ_qᵀ λ, Φ = 0.
"""
from __future__ import annotations

from femb.errors import ModelError


class Element:
    """Base class of all elements (see the module docstring for the contract)."""

    has_mass = False
    constant_mass = True
    has_force = False
    force_depends_on_qd = False
    constant_force = False
    n_constraints = 0
    rheonomic = False
    #: how the force enters the energies: "potential", "load", "none" or None (see above)
    work = None
    n_contacts = 0
    n_friction = 0
    #: names of this type's constraint equations, for named reactions
    constraint_names: tuple = ()
    #: velocity-level (non-holonomic) constraints per element and their names (docs/kernels.md)
    n_velocity_constraints = 0
    velocity_constraint_names: tuple = ()
    #: compiled kernels by role ("mass", "force", "constraint", "rates", "energy", "velocity_constraint"),
    #: see docs/kernels.md
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
            "constant_force", "n_constraints", "rheonomic", "n_velocity_constraints",
            "n_contacts", "n_friction")}

    @classmethod
    def time_functions(cls, element):
        """The element's TimeFunctions (same count for every element of a batch)."""
        return []

    # -------------------------------------------------------------- packing
    @classmethod
    def pack(cls, elements):
        """Stack the parameters of ``elements`` into a dict of arrays."""
        return {}

    @classmethod
    def geometry(cls, p, t, qe, qde, lame, names):
        """Plain geometry for output: list of :class:`femb.base.geometry.GeometryBlock`."""
        return []

"""The user's builder: a mutable mechanism that compiles into a frozen model."""
from __future__ import annotations

from femb.errors import ModelError
from femb.system.element import Element
from femb.system.model import Model


class Mechanism:
    """A mechanism under construction: bodies, joints, forces, beams.

    Examples
    --------
    >>> from femb import Mechanism
    >>> from femb.elements import RigidBody, Hinge, Gravity
    >>> mech = Mechanism("pendulum")
    >>> bar = mech.add(RigidBody("bar", mass=1.0, inertia=1/12, position=(0.5, 0.0),
    ...                          points={"O": (-0.5, 0.0)}))
    >>> _ = mech.add(Hinge("pivot", "ground", bar, point_b="O"))
    >>> _ = mech.add(Gravity((0.0, -9.81)))
    >>> model = mech.compile()
    >>> model.nq, model.nc
    (3, 2)
    """

    def __init__(self, name: str = "mechanism") -> None:
        from femb.elements.bodies import Ground  # the ground is a body of the element library

        self.name = str(name)
        self.ground = Ground("ground")
        self._elements = []
        self._by_name = {"ground": self.ground}

    def add(self, *elements: Element) -> Element | tuple[Element, ...]:
        """Add elements; returns the element (or a tuple of them)."""
        if not elements:
            raise ModelError("Mechanism.add: nothing to add")
        for e in elements:
            if not isinstance(e, Element):
                raise ModelError(f"Mechanism.add: {e!r} is not a femb element")
            if e.name in self._by_name:
                raise ModelError(f"duplicate name '{e.name}': names of elements and bodies must be unique")
            self._by_name[e.name] = e
            self._elements.append(e)
        return elements[0] if len(elements) == 1 else elements

    def __getitem__(self, name: str) -> Element:
        try:
            return self._by_name[name]
        except KeyError:
            raise ModelError(f"mechanism '{self.name}' has no element named '{name}'") from None

    def __contains__(self, name):
        return name in self._by_name

    # ------------------------------------------------------------ display
    def _summary(self):
        """(title, rows) for :meth:`__repr__` and :meth:`_repr_html_`."""
        from collections import Counter

        from femb.base.summary import short_list

        kinds = Counter(type(e).__name__ for e in self._elements)
        spatial = any(getattr(type(e), "spatial", False) for e in self._elements)
        rows = [("elements", f"{len(self._elements)}: " + short_list(f"{n} {k}" for k, n in kinds.items())),
                ("names", short_list(e.name for e in self._elements) or "none"),
                ("kind", "spatial" if spatial else "planar")]
        return f"femb Mechanism '{self.name}'", rows

    def __repr__(self):
        from femb.base.summary import text

        return text(*self._summary())

    def _repr_html_(self):
        from femb.base.summary import html

        return html(*self._summary())

    @property
    def elements(self):
        """The elements, in the order they were added (list)."""
        return list(self._elements)

    def compile(self, *, length_scale: float | None = None, redundant: str = "error",
                max_initial_move: float | None = None) -> Model:
        """Freeze the mechanism into a :class:`~femb.system.model.Model`.

        Parameters
        ----------
        length_scale : float, optional
            Characteristic length (m) used to scale the constraint tolerance;
            default: the size of the initial configuration.
        redundant : {"error", "eliminate"}
            What to do with constraint equations that depend on others at the
            initial configuration (two identical hinges, a parallelogram with a
            fifth bar). "error" (default): initialization raises an
            :class:`~femb.errors.InitializationError` naming the joints and
            equations. "eliminate": the dependent equations are found now
            (rank-revealing QR, :func:`femb.system.initial.redundancy`) and dropped
            without a warning (``model.removed_constraints`` lists them); they
            keep their place in λ with λ_i = 0, so the reactions of the joints
            involved are one admissible distribution, not *the* reactions
            (they are not unique): :meth:`femb.results.result.Result.reaction` of such
            a joint warns with a :class:`~femb.system.initial.RedundantConstraintWarning`.
        max_initial_move : float, optional
            Largest move (m) of a body when the initial positions are
            projected onto the constraints (see
            :func:`femb.system.initial.consistent_initial_state`; default 1 % of the
            length scale).

        Returns
        -------
        Model
            With ``active_constraints`` (bool array, shape (nc,)),
            ``removed_constraints`` (list of (element, equation)) and
            ``max_initial_move`` (float or None).
        """
        import numpy as np

        from femb.system.initial import eliminate_redundant
        from femb.system.model import compile_model

        if redundant not in ("error", "eliminate"):
            raise ModelError(f"Mechanism.compile: redundant must be 'error' or 'eliminate', got {redundant!r}")
        if max_initial_move is not None:
            try:
                max_initial_move = float(max_initial_move)
            except (TypeError, ValueError):
                max_initial_move = -1.0
            if not max_initial_move > 0.0:
                raise ModelError("Mechanism.compile: max_initial_move must be a positive length (m)")
        model = compile_model(self, length_scale=length_scale)
        # attributes of the frozen model set once here, before anyone sees it
        extra = {"active_constraints": np.ones(model.nc, dtype=bool), "removed_constraints": [],
                 "max_initial_move": max_initial_move}
        model.__dict__.update(extra)
        if redundant == "eliminate" and model.nc:
            # asked for: no warning here (model.removed_constraints lists the equations; reading the
            # reaction of a joint involved warns, Result.reaction)
            active, removed, _ = eliminate_redundant(model)
            if removed:
                active.flags.writeable = False
                model.__dict__.update(active_constraints=active, removed_constraints=removed)
        return model

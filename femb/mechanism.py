"""The user's builder: a mutable mechanism that compiles into a frozen model."""
from __future__ import annotations

from femb.element import Element
from femb.errors import ModelError


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

    def __init__(self, name="mechanism"):
        from femb.elements.bodies import Ground  # the ground is a body of the element library

        self.name = str(name)
        self.ground = Ground("ground")
        self._elements = []
        self._by_name = {"ground": self.ground}

    def add(self, *elements):
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

    def __getitem__(self, name):
        try:
            return self._by_name[name]
        except KeyError:
            raise ModelError(f"mechanism '{self.name}' has no element named '{name}'") from None

    def __contains__(self, name):
        return name in self._by_name

    @property
    def elements(self):
        """The elements, in the order they were added (list)."""
        return list(self._elements)

    def compile(self, *, length_scale=None):
        """Freeze the mechanism into a :class:`~femb.model.Model`.

        Parameters
        ----------
        length_scale : float, optional
            Characteristic length (m) used to scale the constraint tolerance;
            default: the size of the initial configuration.
        """
        from femb.model import compile_model

        return compile_model(self, length_scale=length_scale)

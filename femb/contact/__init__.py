"""Unilateral contact with Coulomb friction: the nonsmooth generalized-α scheme (docs/contact.md).

:func:`simulate` integrates a model with contact elements (:mod:`femb.elements.contact`)
by the nonsmooth generalized-α method of Capobianco, Harsch, Eugster & Leine (IJNME 122,
2021), with bilateral joints at index-3 exactness and contacts enforced at position and
velocity level.
"""
from femb.contact.check import check_contact_kernels
from femb.contact.simulate import ContactResult, simulate

__all__ = ["simulate", "ContactResult", "check_contact_kernels"]

"""Input checks shared by the beam meshers (:func:`~femb.elements.beam.add_beam`,
:func:`~femb.elements.spatial_beam.spatial_beam`): element counts and the size of the model
they would make, checked before anything is allocated."""
from __future__ import annotations

import math
import numbers
import os

import numpy as np

from femb.errors import ModelError

#: bytes per element a meshed beam needs, at least: the node and element objects and the
#: compiled model's arrays (measured with tracemalloc on 4000-element meshes: spatial 18 kB,
#: planar 6.9 kB; the result of a run comes on top)
BYTES_PER_ELEMENT = {"spatial": 18_000, "planar": 7_000}


def element_count(owner, what, value):
    """``value`` as an element count ≥ 1: an integer, or a float with an integral value (4.0).

    Raises
    ------
    ModelError
        Not a number, not finite, not integral (2.7 is not silently 2), or below 1; names
        ``owner``, ``what`` and the value.
    """
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (numbers.Real, np.number)):
        raise ModelError(f"{owner}: {what} must be a whole number ≥ 1, got {value!r}")
    v = float(value)
    if not math.isfinite(v) or v != math.floor(v):
        raise ModelError(f"{owner}: {what} must be a whole number ≥ 1, got {value!r}")
    if v < 1:
        raise ModelError(f"{owner}: {what} must be at least 1, got {value!r}")
    return int(v)


def physical_memory():
    """This machine's physical memory in bytes, or None where the OS does not say."""
    try:
        return int(os.sysconf("SC_PAGE_SIZE")) * int(os.sysconf("SC_PHYS_PAGES"))
    except (AttributeError, ValueError, OSError):
        return None


def check_model_size(owner, n_elements, kind):
    """Refuse a mesh of ``n_elements`` whose model would not fit in this machine's memory.

    Called before any node is made, so that ``n_elements=10**9`` is an error at once instead of
    a MemoryError after minutes or a machine swapping.

    Raises
    ------
    ModelError
        With the element count, the memory the model would need (at least
        :data:`BYTES_PER_ELEMENT` per element) and the machine's memory.
    """
    need = n_elements * BYTES_PER_ELEMENT[kind]
    have = physical_memory()
    if have is not None and need > have:
        raise ModelError(f"{owner}: {n_elements} elements would need at least {need / 2 ** 30:.3g} GiB "
                         f"(about {BYTES_PER_ELEMENT[kind] // 1000} kB per element for the mesh and the "
                         f"compiled model), more than this machine's {have / 2 ** 30:.3g} GiB of memory")

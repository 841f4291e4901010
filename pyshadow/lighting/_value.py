"""Lights as values: equality and hashing of frozen dataclasses whose fields hold small NumPy arrays.

The dataclasses' own ``==`` compares the fields' tuples, which for arrays
raises "the truth value of an array ... is ambiguous" (so ``light in
lights`` and ``lights.remove(light)`` failed), and arrays make them
unhashable. Two lights are equal when they are of the same class and every
field is equal (arrays element by element, -0.0 equal to 0.0); equal lights
hash alike.
"""
from __future__ import annotations

from dataclasses import fields

import numpy as np

__all__ = ["ArrayValue"]


class ArrayValue:
    """Mixin for ``@dataclass(frozen=True, eq=False)`` classes of array and scalar fields."""

    __slots__ = ()

    def __eq__(self, other):
        if type(other) is not type(self):
            return NotImplemented
        return all(np.array_equal(getattr(self, f.name), getattr(other, f.name)) for f in fields(self))

    def __hash__(self):
        return hash((type(self).__qualname__, *(_key(getattr(self, f.name)) for f in fields(self))))


def _key(v):
    """A hashable stand-in for field value ``v`` that equal values share."""
    if isinstance(v, np.ndarray):
        return v.shape, (v.astype(np.float64) + 0.0).tobytes()     # + 0.0: -0.0 as 0.0
    return v

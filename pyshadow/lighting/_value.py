"""Lights as values: equality and hashing of frozen dataclasses whose fields hold small NumPy arrays.

The dataclasses' own ``==`` compares the fields' tuples, which for arrays
raises "the truth value of an array ... is ambiguous" (so ``light in
lights`` and ``lights.remove(light)`` failed), and arrays make them
unhashable. Two lights are equal when they are of the same class and every
field is equal (arrays element by element, -0.0 equal to 0.0); equal lights
hash alike. Their array fields are read-only copies (:meth:`ArrayValue._set`): a light
changed in place would have left its checks behind (a NaN position) and changed its hash while a set
or a dict held it. That holds for the copies ``pickle`` and ``copy.deepcopy`` make too (they set the
fields without ``__post_init__``: :meth:`ArrayValue.__setstate__`), and an array field given as a
list or tuple to a class that does not check its fields (:class:`~pyshadow.lighting.SunLight`) is
kept as an array (a tuple hashed unlike the equal array, a list did not hash at all).
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

    def __post_init__(self):
        """Every array field as a read-only copy, a list or tuple as an array (classes that check their
        fields set them by :meth:`_set`)."""
        for f in fields(self):
            v = getattr(self, f.name)
            if isinstance(v, (list, tuple)):
                try:
                    v = np.array(v)
                except ValueError:              # ragged
                    raise ValueError(f"{f.name}: expected an array (got {v!r})") from None
            self._set(f.name, v)

    def __setstate__(self, state):
        """The fields of a copy (``pickle``, ``copy.deepcopy``), arrays as read-only copies as in
        ``__post_init__``: a copied light's arrays were writeable."""
        for name, value in state.items():
            self._set(name, value)

    def _set(self, name: str, value) -> None:
        """Set field ``name`` of the frozen instance: an array as a read-only copy (the caller's array is
        neither kept nor locked)."""
        if isinstance(value, np.ndarray):
            value = value.copy()
            value.flags.writeable = False
        object.__setattr__(self, name, value)


def _key(v):
    """A hashable stand-in for field value ``v`` that equal values share."""
    if isinstance(v, np.ndarray):
        return v.shape, (v.astype(np.float64) + 0.0).tobytes()     # + 0.0: -0.0 as 0.0
    return v

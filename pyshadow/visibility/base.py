"""The visibility protocol and the registry of its backends.

A backend answers two questions about a :class:`pyshadow.Scene`:

``visible(scene, points, directions, *, bias=None, surface_ids=None)``
    ``(N,)`` bool: does each ray from a world point along a world direction
    reach the sky (no caster, no ground plane in the way)? Backends with
    finite rays also take ``max_distance=`` and ``straddle=``
    (:mod:`pyshadow.visibility.finite`); they are passed only when given.
``ambient_occlusion(scene, points, normals, *, sampling, return_bent_normals=False, bias=None, indices=None, surface_ids=None)``
    ``(N,)`` float32 in [0, 1] (1 = open), the unoccluded fraction of
    cosine-weighted directions about each normal, drawn as
    :class:`pyshadow.Sampling` says (and ``(N, 3)`` float32 bent normals).

Backends are registered by name (:func:`register`); :func:`get_backend`
returns one, :func:`backends` lists them. Built in: ``"csm"`` (the
one-texel CSM lookup kernel), ``"csm-vote"`` (the vote over four maps times
four texels), ``"numpy"`` (the float64 mirror of the CSM lookup, small
inputs) and ``"embree"`` (ray tracing: the ground truth).
"""
from __future__ import annotations

import numbers
from typing import Protocol, runtime_checkable

import numpy as np

from .._validate import FLOAT32_MAX, flag

__all__ = ["VisibilityBackend", "register", "get_backend", "backends", "check_bias", "check_sampling"]


@runtime_checkable
class VisibilityBackend(Protocol):
    """What a visibility backend provides (see the module docstring for the contract)."""

    name: str

    def visible(self, scene, points, directions, *, bias=None, surface_ids=None) -> np.ndarray:
        ...

    def ambient_occlusion(self, scene, points, normals, *, sampling, return_bent_normals=False,
                          bias=None, indices=None, surface_ids=None):
        ...


_REGISTRY: dict = {}


def register(name: str, backend, *, replace: bool = False) -> None:
    """Make ``backend`` answer visibility queries under ``name``.

    Parameters
    ----------
    name : str
    backend : VisibilityBackend
        An object with a ``name`` (str) and ``visible`` and
        ``ambient_occlusion`` as in the module docstring.
    replace : bool, optional
        Allow replacing a registered backend of the same name (True or
        False: the string "no" replaced it).
    """
    replace = flag(replace, "replace")
    if not isinstance(name, str) or not name:
        raise ValueError(f"a backend name must be a non-empty string, got {name!r}")
    _not_a_class(backend)
    _not_callable(backend)
    if not isinstance(backend, VisibilityBackend):
        raise TypeError(f"{backend!r} is not a visibility backend: it lacks {_lacks(backend)}")
    name = str(name)                    # a numpy str_ was listed by backends() as np.str_('...')
    if name in _REGISTRY and not replace:
        raise ValueError(f"a visibility backend named {name!r} is registered already (replace=True)")
    _REGISTRY[name] = backend


def get_backend(name):
    """The backend registered as ``name`` (a backend object passes through)."""
    if isinstance(name, str):
        try:
            return _REGISTRY[name]
        except KeyError:
            raise ValueError(f"unknown visibility backend {name!r}; registered: "
                             f"{', '.join(sorted(_REGISTRY))}") from None
    _not_a_class(name)
    _not_callable(name)
    if isinstance(name, VisibilityBackend):
        return name
    if any(hasattr(name, a) for a in _MEMBERS):     # meant as a backend: say what it lacks
        raise TypeError(f"visibility backend {name!r} lacks {_lacks(name)} (see pyshadow.visibility.base)")
    raise TypeError(f"visibility backend must be a name or a backend object, got {name!r}")


#: What the protocol asks of a backend object (:class:`VisibilityBackend`).
_MEMBERS = ("name", "visible", "ambient_occlusion")


def _lacks(backend) -> str:
    """The protocol's members ``backend`` lacks, in words (a backend class without ``name`` was refused as
    lacking "visible/ambient_occlusion", which it had)."""
    names = [f"'{a}'" for a in _MEMBERS if not hasattr(backend, a)]
    return " and ".join([", ".join(names[:-1]), names[-1]] if len(names) > 1 else names)


def _not_a_class(backend) -> None:
    """TypeError for a backend class given where its instance is meant (``EmbreeVisibility`` for
    ``EmbreeVisibility()``: it passed the protocol's check, then a query failed with "missing 1 required
    positional argument: 'directions'")."""
    if isinstance(backend, type):
        raise TypeError(f"visibility backend: got the class {backend.__name__}, not a backend object "
                        f"(pass an instance, {backend.__name__}(...), or a registered name)")


def _not_callable(backend) -> None:
    """TypeError for a backend whose ``visible`` or ``ambient_occlusion`` is there but not callable (``visible = 3``
    passed the protocol's check, then every query failed with "'int' object is not callable"; ``visible = None``
    was refused as lacking nothing: "it lacks ")."""
    bad = [f"'{a}' ({type(getattr(backend, a)).__name__})" for a in _MEMBERS[1:]
           if hasattr(backend, a) and not callable(getattr(backend, a))]
    if bad:
        raise TypeError(f"visibility backend {backend!r}: {' and '.join(bad)} must be callable "
                        f"(see pyshadow.visibility.base)")


def backends() -> list[str]:
    """Names of the registered backends."""
    return sorted(_REGISTRY)


def check_bias(bias):
    """Validate the ``bias`` of a query (None: the default bias); returns it unchanged.

    One real number (not a bool, a string or an array of several), >= 0, finite and
    within float32's range: the kernels take it as a float32 (beyond it the
    cast overflowed), and the mirror must refuse what they refuse (a NaN bias
    made every tap pass there).
    """
    if bias is None:
        return None
    scalar = isinstance(bias, np.ndarray) and bias.ndim == 0 and bias.dtype.kind in "iuf"
    if isinstance(bias, (bool, np.bool_)) or not (scalar or isinstance(bias, numbers.Real)):
        raise TypeError(f"bias must be one real number or None, got {bias!r}")
    try:
        value = float(bias)
    except OverflowError:               # an int beyond float64 (10**400): not a bare "int too large"
        value = None
    if value is None or not abs(value) <= FLOAT32_MAX:
        got = value if value is not None else f"an int of {int(bias).bit_length()} bits"
        raise ValueError(f"bias must be finite and within float32's range (the kernels take it as a "
                         f"float32), got {got}")
    if value < 0:                       # -1 shadowed the open rays off a box's lid, in every CSM backend
        raise ValueError(f"bias must be >= 0 (a depth tolerance: a point counts as in front of a stored "
                         f"depth within it), got {value}")
    return bias


def check_sampling(sampling):
    """Validate the ``sampling`` of a backend's AO query; returns it unchanged.

    A :class:`pyshadow.Sampling` (the backends take no default: ``None``, as an
    int such as ``8``, is refused with a TypeError naming it; the CSM backends
    raised "AttributeError: 'int' object has no attribute 'samples'").
    :func:`pyshadow.visibility.ambient_occlusion` turns ``None`` into ``Sampling()``.
    """
    from ..sampling import Sampling

    if not isinstance(sampling, Sampling):
        raise TypeError(f"sampling must be a pyshadow.Sampling, got {sampling!r} "
                        f"(e.g. sampling=pyshadow.Sampling(36))")
    return sampling

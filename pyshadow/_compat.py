"""Old names and argument orders that keep working for one release, with a DeprecationWarning.

Each old form warns once per process (the first call that uses it); the
warning names the new form. ``reset()`` forgets what was warned (tests).
"""
from __future__ import annotations

import functools
import inspect
import warnings

__all__ = ["deprecated", "reset", "legacy_sampling", "keyword_only"]

_warned: set[str] = set()


def deprecated(old: str, new: str, stacklevel: int = 3) -> None:
    """Warn once that ``old`` is deprecated in favour of ``new``."""
    if old in _warned:
        return
    _warned.add(old)
    warnings.warn(f"{old} is deprecated and goes in the next release; use {new}",
                  DeprecationWarning, stacklevel=stacklevel)


def reset() -> None:
    """Forget which old forms have warned (so a test can see the warning again)."""
    _warned.clear()


def keyword_only(where: str, old: int | None = None):
    """Decorate ``f(data..., *, option=default, ...)`` so that the old positional options still work.

    A call with more positional arguments than ``f`` has positional
    parameters (the data, ``self`` or ``cls`` included) passes the extra ones
    as the keyword-only parameters, in their declared order, and warns once
    (``"{where}'s positional resolution, layers arguments is deprecated ...;
    use keywords (resolution=, layers=)"``, pointing at the caller's line).
    Other calls cost one length check.

    Parameters
    ----------
    where : str
        Name of the callable, for messages (``"CoherentShadowMap.build"``).
    old : int, optional
        How many of the keyword-only parameters (the first ones) the old
        signature took by position; default all of them.

    Raises
    ------
    TypeError
        When called: more positional arguments than the old signature took,
        or an option given both by position and by keyword. When decorating:
        ``f`` has ``*args`` or no keyword-only parameter.
    """
    def wrap(f):
        params = inspect.signature(f).parameters.values()
        n_data = sum(p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD) for p in params)
        names = tuple(p.name for p in params if p.kind is p.KEYWORD_ONLY)[:old]
        if any(p.kind is p.VAR_POSITIONAL for p in params) or not names:
            raise TypeError(f"keyword_only({where!r}): {f.__qualname__} needs keyword-only options "
                            "and no *args")

        @functools.wraps(f)
        def call(*args, **kwargs):
            if len(args) <= n_data:
                return f(*args, **kwargs)
            extra = args[n_data:]
            if len(extra) > len(names):
                raise TypeError(f"{where} takes at most {len(names)} options by position (deprecated) "
                                f"after the data ({len(extra)} given)")
            moved = names[:len(extra)]
            for k in moved:
                if k in kwargs:
                    raise TypeError(f"{where} got {k!r} both by position and by keyword")
            deprecated(f"{where}'s positional {', '.join(moved)} argument{'s' if len(moved) > 1 else ''}",
                       f"keywords ({', '.join(k + '=' for k in moved)})", stacklevel=3)
            kwargs.update(zip(moved, extra))
            return f(*args[:n_data], **kwargs)

        return call

    return wrap


_SAMPLING_FIELDS = ("samples", "strategy", "patterns", "seed")


def legacy_sampling(where: str, args: tuple, order: tuple, sampling, given: dict, default, stacklevel: int = 4):
    """Resolve the sampling arguments of a call that may use the old forms.

    Parameters
    ----------
    where : str
        Name of the callable, for messages (``"Scene.ambient_occlusion"``).
    args : tuple
        Positional arguments after the data (the old forms took the sampling
        arguments positionally, in the order ``order``).
    order : tuple of str
        The old positional order, e.g. ``("samples", "strategy", "patterns",
        "seed", "bent_normals")``.
    sampling : Sampling or None
        The new keyword.
    given : dict
        Old keywords the caller passed (``None`` values mean "not passed");
        a key outside ``order`` is a TypeError, as for any unknown keyword.
    default : Sampling
        What ``sampling=None`` means for this callable.
    stacklevel : int, optional
        Of the warning, counted from :func:`deprecated`: 4 points at the
        caller of the function that calls this one.

    Returns
    -------
    sampling : Sampling
    extra : dict
        Old non-sampling arguments passed (e.g. ``bent_normals``).

    Raises
    ------
    TypeError
        Too many positional arguments, a :class:`Sampling` among them (it
        goes by keyword), an unknown keyword, or old and new forms together.
    """
    from .sampling import Sampling

    if len(args) > len(order):
        raise TypeError(f"{where} takes at most {len(order)} positional arguments after the data "
                        f"({len(args)} given)")
    if any(isinstance(a, Sampling) for a in args):     # was "samples must be an int, got Sampling(...)"
        raise TypeError(f"{where}: pass the Sampling by keyword, sampling=Sampling(...) (positional "
                        f"arguments after the data are the deprecated {', '.join(order)})")
    old = dict(zip(order, args))
    unknown = sorted(set(given) - set(order))
    if unknown:
        raise TypeError(f"{where} got an unexpected keyword argument {unknown[0]!r}")
    for k, v in given.items():
        if v is None:
            continue
        if k in old:
            raise TypeError(f"{where} got {k!r} both by position and by keyword")
        old[k] = v
    if not old:
        return (default if sampling is None else sampling), {}
    fields = [k for k in _SAMPLING_FIELDS if k in old]
    if fields and sampling is not None:
        raise TypeError(f"{where}: pass sampling=Sampling(...) or the old {', '.join(fields)}, not both")
    how = "positional " if args else ""
    deprecated(f"{where}'s {how}{', '.join(old)} argument{'s' if len(old) > 1 else ''}",
               "sampling=pyshadow.Sampling(samples, strategy, patterns, seed)"
               + (" and return_bent_normals=" if "bent_normals" in old else ""), stacklevel=stacklevel)
    if fields:
        base = default if sampling is None else sampling
        sampling = Sampling(**{k: old.get(k, getattr(base, k)) for k in _SAMPLING_FIELDS})
    elif sampling is None:
        sampling = default
    return sampling, {k: v for k, v in old.items() if k not in _SAMPLING_FIELDS}

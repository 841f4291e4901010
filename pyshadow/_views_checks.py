"""Argument checks of :mod:`pyshadow.views`: given directions and bases, query directions, and the
arrays of the octahedral map and the polar angles (kept apart so that views.py stays readable)."""
from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ._validate import check_rows, unit_normals

#: how far a given ViewSet's directions may be from unit length, and its bases from orthonormal (entries of
#: B B^T - I) and from ending with d_k: float32-rounded inputs pass (errors of a few 1e-8); 1e-6 moves a point
#: of the unit bounding sphere by ~1e-6 radius, under 1/400 texel at the largest resolution (4096)
BASIS_TOL = 1e-6
#: the layouts a ViewSet may name (zigzag and hilbert: its directions must be those of its params)
LAYOUTS = ("zigzag", "hilbert", "custom")
#: the parameters of a layout (ViewSet.from_params): required, and optional with their defaults
_LAYOUT_PARAMS = {"zigzag": (("theta", "phi"), {"row_offset": 0.0}), "hilbert": (("level",), {"hemispheres": False})}


def _unit_rows(dirs, caller: str) -> np.ndarray:
    """Directions (N, 3) (or one, (3,)) as (N, 3) float64, normalised (any length: unit_normals); ValueError
    naming ``caller`` for another shape, non-finite or zero rows (TypeError for non-numeric ones)."""
    a = np.asarray(dirs)
    d = check_rows(a.reshape(1, 3) if a.shape == (3,) else a, f"{caller}: directions").astype(np.float64)
    try:
        return unit_normals(d, None, caller)
    except ValueError:
        raise ValueError(f"{caller}: directions must be finite and non-zero") from None


def _check_frames(d, b):
    """ValueError unless ``d`` (D, 3) are unit vectors and ``b`` (D, 3, 3) right-handed orthonormal
    bases with ``d`` as their third rows, to :data:`BASIS_TOL`. An error that is NaN (huge entries whose
    products overflow to inf - inf) counts as beyond the tolerance; overflow warns nothing."""
    if not (np.isfinite(d).all() and np.isfinite(b).all()):
        raise ValueError("ViewSet: directions and bases must be finite")
    if len(d) == 0:
        return
    with np.errstate(over="ignore", under="ignore", invalid="ignore"):
        errors = {"directions are not unit vectors": lambda: np.abs(np.sqrt(np.einsum("ij,ij->i", d, d)) - 1.0),
                  "bases are not orthonormal (rows u, v, d of unit length, at right angles)":
                      lambda: np.abs(np.einsum("nij,nkj->nik", b, b) - np.eye(3)).max(axis=(1, 2)),
                  "bases do not end with their map's direction (row d_k)": lambda: np.abs(b[:, 2] - d).max(axis=1),
                  "bases are left-handed (u x v = -d)": lambda: -np.linalg.det(b)}
        for what, err in errors.items():
            bad = ~(err() <= BASIS_TOL)
            if bad.any():
                k = int(np.argmax(bad))
                raise ValueError(f"ViewSet: {int(bad.sum())} {what} (first: map {k}, direction {d[k].tolist()}, "
                                 f"basis {b[k].tolist()}; tolerance {BASIS_TOL:g})")


def real_array(a, name: str, last: int | None = None) -> np.ndarray:
    """``a`` as a float64 array of finite real numbers (with ``last``: of shape (..., last)); TypeError for
    other dtypes (bools, complex, objects, strings), ValueError for another shape or non-finite entries."""
    arr = np.asarray(a)
    if arr.dtype.kind not in "iuf":
        raise TypeError(f"{name} must hold real numbers, got dtype {arr.dtype}")
    if last is not None and arr.shape[-1:] != (last,):
        raise ValueError(f"{name} must have shape (..., {last}), got {arr.shape}")
    arr = arr.astype(np.float64, copy=False)
    if not np.isfinite(arr).all():
        raise ValueError(f"{name} must be finite")
    return arr


def scaled_vectors(d: np.ndarray, name: str) -> np.ndarray:
    """Finite float64 vectors (..., 3) whose length underflows to 0 or overflows to inf divided by their
    largest component (so that they normalise to unit vectors, to round-off); others unchanged, the array itself when none
    is; ValueError for zero vectors."""
    with np.errstate(over="ignore", under="ignore"):
        ss = np.einsum("...k,...k->...", d, d)
    odd = ~(ss >= np.finfo(np.float64).tiny) | (ss == np.inf)
    if not odd.any():
        return d
    big = np.abs(d[odd]).max(axis=-1)
    if not big.all():
        raise ValueError(f"{name}: {int((big == 0).sum())} zero vectors (a direction needs a length)")
    d = d.copy()
    d[odd] /= big[:, None]
    return d


def _layout_args(layout, params, caller="ViewSet.from_params") -> tuple:
    """The arguments of ViewSet.zigzag or ViewSet.hilbert in ``params``; ValueError for another layout or
    naming the keys ``params`` lacks (the message starts with ``caller``)."""
    required, optional = _LAYOUT_PARAMS.get(layout, (None, None)) if isinstance(layout, str) else (None, None)
    if required is None:
        raise ValueError(f"unknown view-set layout {layout!r}")
    if missing := [k for k in required if k not in params]:
        raise ValueError(f"{caller}: {layout} parameters miss {', '.join(map(repr, missing))} (expected "
                         f"{', '.join(map(repr, required))}; optional {', '.join(map(repr, optional))}), "
                         f"got {list(params)!r}")
    args = [params[k] for k in required] + [params.get(k, default) for k, default in optional.items()]
    return (args[0], bool(args[1])) if layout == "hilbert" else tuple(args)


def _check_layout(layout, params, d):
    """A given ViewSet's layout and params, checked: a zigzag or hilbert layout (whose O(1) lookups read the
    grid from the params) needs the params of the grid its directions ``d`` are, to BASIS_TOL."""
    if not isinstance(layout, str) or layout not in LAYOUTS:
        raise ValueError(f"ViewSet: layout must be one of {', '.join(map(repr, LAYOUTS))}, got {layout!r}")
    if params is not None and not isinstance(params, Mapping):
        raise TypeError(f"ViewSet: params must be a dict (or None), got {params!r}")
    if layout == "custom":
        return
    from . import views

    args = _layout_args(layout, params or {}, "ViewSet")
    want = (views._zigzag_grid if layout == "zigzag" else views._hilbert_grid)(*args)[0]
    err = np.abs(want - d).max(axis=1) if len(want) == len(d) else None
    if err is None or not (err <= BASIS_TOL).all():
        where = (f"{len(d)} directions for its {len(want)} maps" if err is None else
                 f"map {int(np.argmax(~(err <= BASIS_TOL)))} off by {float(err.max()):.3g}")
        raise ValueError(f"ViewSet: the directions are not those of the {layout} layout of params "
                         f"{dict(params or {})!r} ({where}); give layout='custom' for other directions")

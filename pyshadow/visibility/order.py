"""Coherent ray order: a sort key from each ray's direction and origin, and its permutation.

Stage "visibility kernel" (issue 25, item 1). The kernel ``scene_visible``
answers rays in the order given; each ray, for each caster whose sphere it
meets, reads the segment list of one texel of the map nearest its direction.
Neighbouring work-items (the lanes of one vector, a GPU's warp) that ask
different maps read far-apart tables. :func:`coherent_order` sorts a batch
so that rays of similar direction (hence the same or neighbouring maps of a
caster, up to the instance's rotation) and nearby origins (hence nearby
texels) are neighbours; :meth:`CSMVisibility._visible
<pyshadow.visibility.csm.CSMVisibility>` launches the kernel on the sorted
rows and scatters the answers back (:func:`reordered`). Every ray is
answered independently, so the answers are bit-identical in either order.

The key is a 16-bit integer (NumPy sorts it by a stable radix sort, linear
in the rays):

- major: the direction's cell in a ``DIR_BINS`` x ``DIR_BINS`` grid of
  the octahedral map of the sphere (world frame, +y up; no transcendental
  functions, the direction need not be unit);
- minor: the origin's cell in a ``CELLS`` ^ 3 grid over the bounding box
  of a subsample of the batch's origins (clipped to it).

Whether ``_visible`` reorders: :func:`enabled` (the module switch
:data:`COHERENT`, else the environment variable ``PYSHADOW_COHERENT``,
else :data:`DEFAULT`), and only for batches of at least :data:`MIN_RAYS`
rays. Off by default: on a CPU device (PoCL) the kernel gains little from
the order while the host's key, sort and gathers cost several times the
kernel's own time (``benchmarks/coherence.py`` measures both, and the
kernel on rays handed over already sorted). Callers that build their rays
can hand them over in this order themselves.
"""
from __future__ import annotations

import os

import numpy as np

__all__ = ["COHERENT", "DEFAULT", "MIN_RAYS", "DIR_BINS", "CELLS", "enabled", "ray_key", "coherent_order",
           "inverse_permutation", "reordered"]

#: Module switch: True / False force the reorder on / off; None defers to ``PYSHADOW_COHERENT``.
COHERENT: bool | None = None
#: What :func:`enabled` answers when neither the switch nor the environment variable is set
#: (off: see the module's notes and ``benchmarks/coherence.py``).
DEFAULT = False
#: Smallest batch (rays of one ``_visible`` call) that is reordered.
MIN_RAYS = 1 << 16
#: Direction cells per side of the octahedral map.
DIR_BINS = 32
#: Origin cells per axis of the batch's bounding box.
CELLS = 4


def enabled(n: int | None = None) -> bool:
    """Whether ``_visible`` reorders a batch of ``n`` rays.

    Parameters
    ----------
    n : int, optional
        Rays in the batch; None: the switch alone, whatever the size.

    Returns
    -------
    bool
        :data:`COHERENT` if it is not None, else ``PYSHADOW_COHERENT``
        (``0`` / ``1``; anything else is a ValueError), else
        :data:`DEFAULT`; and, with ``n``, ``n >= MIN_RAYS``.
    """
    on = COHERENT
    if on is None:
        env = os.environ.get("PYSHADOW_COHERENT", "").strip()
        if env not in ("", "0", "1"):
            raise ValueError(f"PYSHADOW_COHERENT must be 0 or 1, got {env!r}")
        on = DEFAULT if env == "" else env == "1"
    return bool(on) and (n is None or n >= MIN_RAYS)


def _octahedral_cell(w) -> np.ndarray:
    """(N, 3) non-zero directions -> (N,) uint32 cell of the DIR_BINS^2 octahedral grid (+y the pole)."""
    a = np.abs(w, dtype=np.float32)
    s = a.sum(axis=1)
    np.maximum(s, np.float32(1e-30), out=s)              # zero rows (refused upstream): any cell
    np.divide(np.float32(0.5 * DIR_BINS), s, out=s)
    u = np.multiply(w[:, 0], s, dtype=np.float32)         # x / |w|_1, scaled to [-B/2, B/2]
    v = np.multiply(w[:, 2], s, dtype=np.float32)
    low = np.flatnonzero(w[:, 1] < 0)                     # fold the lower hemisphere onto the corners
    if len(low):
        ul, vl = u[low], v[low]
        half = np.float32(0.5 * DIR_BINS)
        u[low] = np.copysign(half - np.abs(vl), ul)
        v[low] = np.copysign(half - np.abs(ul), vl)
    u += np.float32(0.5 * DIR_BINS)
    v += np.float32(0.5 * DIR_BINS)
    for a in (u, v):                                        # fmax / fmin: NaN -> 0, inf -> the edge
        np.fmin(np.fmax(a, np.float32(0), out=a), np.float32(DIR_BINS - 1), out=a)
    return u.astype(np.uint32) * np.uint32(DIR_BINS) + v.astype(np.uint32)


def _origin_cell(p) -> np.ndarray:
    """(N, 3) points -> (N,) uint32 cell of a CELLS^3 grid over their bounding box."""
    step = max(1, len(p) >> 12)                         # the box of a subsample: cells are clipped
    sub = p[::step]
    lo, hi = sub.min(axis=0).astype(np.float64), sub.max(axis=0).astype(np.float64)
    if not (np.isfinite(lo).all() and np.isfinite(hi).all()):
        # the box of the finite entries (one NaN row made the box NaN: every ray's cell 0); the rows
        # that are not finite get some cell (fmax / fmin below)
        fin = np.isfinite(sub)
        lo = np.where(fin, sub, np.inf).min(axis=0).astype(np.float64)
        hi = np.where(fin, sub, -np.inf).max(axis=0).astype(np.float64)
        lo = np.where(hi >= lo, lo, 0.0)                 # an axis without a finite entry: one cell
    scale = np.where(hi > lo, CELLS / np.where(hi > lo, hi - lo, 1.0), 0.0).astype(np.float32)
    q = np.empty(p.shape, np.float32)
    np.subtract(p, lo.astype(p.dtype), out=q, casting="same_kind")
    q *= scale
    np.fmin(np.fmax(q, np.float32(0), out=q), np.float32(CELLS - 1), out=q)
    c = q.astype(np.uint32)
    return (c[:, 0] * np.uint32(CELLS) + c[:, 1]) * np.uint32(CELLS) + c[:, 2]


def ray_key(points, directions) -> np.ndarray:
    """The coherence key of each ray.

    Parameters
    ----------
    points : array_like, shape (N, 3)
        Ray origins, world units, float32 or float64 (any frame that is a
        translation of the world frame: the key uses their bounding box, that
        of the finite entries).
    directions : array_like, shape (N, 3)
        Ray directions, world frame, any non-zero length.

    Returns
    -------
    ndarray, shape (N,), uint16 (uint32 where ``DIR_BINS ** 2 * CELLS ** 3`` exceeds 2 ** 16)
        ``octahedral cell of the direction * CELLS ** 3 + origin cell``.

    Raises
    ------
    ValueError
        ``points`` and ``directions`` not both of shape (N, 3).
    TypeError
        Either is not of real numbers (complex, bool, strings).
    """
    p, w = np.asarray(points), np.asarray(directions)
    if p.ndim != 2 or p.shape[1:] != (3,) or w.shape != p.shape:
        raise ValueError(f"points and directions must both be (N, 3), got {p.shape} and {w.shape}")
    for name, a in (("points", p), ("directions", w)):
        if a.dtype.kind not in "iuf":       # complex lost its imaginary part, bools read as 0 and 1
            raise TypeError(f"{name} must hold real numbers, got dtype {a.dtype}")
    if p.dtype not in (np.float32, np.float64):
        p = p.astype(np.float64)
    if w.dtype not in (np.float32, np.float64):
        w = w.astype(np.float64)
    kt = np.uint16 if DIR_BINS ** 2 * CELLS ** 3 <= 1 << 16 else np.uint32
    if len(p) == 0:
        return np.zeros(0, kt)
    with np.errstate(all="ignore"):         # extreme rows (1e300, subnormal) give some cell: a key only
        return _octahedral_cell(w).astype(kt) * kt(CELLS ** 3) + _origin_cell(p).astype(kt)


def coherent_order(points, directions) -> np.ndarray:
    """The permutation that sorts rays by :func:`ray_key` (stable: ties keep their order).

    Parameters
    ----------
    points, directions : array_like, shape (N, 3)
        As in :func:`ray_key`.

    Returns
    -------
    ndarray, shape (N,), int64
        ``perm``: row ``i`` of the sorted batch is row ``perm[i]`` of the
        given one. :func:`inverse_permutation` undoes it.
    """
    return np.argsort(ray_key(points, directions), kind="stable").astype(np.int64, copy=False)


def inverse_permutation(perm) -> np.ndarray:
    """``inv`` with ``inv[perm[i]] == i`` (so ``sorted_answers[inv]`` is in the original order).

    Parameters
    ----------
    perm : array_like of int, shape (N,)
        A permutation of ``0 .. N-1``.

    Returns
    -------
    ndarray, shape (N,), int64

    Raises
    ------
    TypeError
        ``perm`` is not of integers (an empty list is an empty permutation).
    ValueError
        ``perm`` is not one-dimensional, or not a permutation of ``0 .. N-1``
        (an index out of range, negative or repeated: the inverse read
        uninitialised memory or wrapped a negative index around).
    """
    perm = np.asarray(perm)
    if perm.ndim != 1:
        raise ValueError(f"perm must be one-dimensional, got shape {perm.shape}")
    n = len(perm)
    if perm.dtype.kind not in "iu" and n:
        raise TypeError(f"perm must hold integers, got dtype {perm.dtype}")
    if n and not (perm.min() >= 0 and perm.max() < n):
        raise ValueError(f"perm must be a permutation of 0 .. {n - 1}, got indices from {perm.min()} to {perm.max()}")
    inv = np.full(n, -1, np.int64)
    inv[perm.astype(np.int64, copy=False)] = np.arange(n, dtype=np.int64)
    if n and inv.min() < 0:             # within range, n indices miss one only if one repeats
        raise ValueError(f"perm must be a permutation of 0 .. {n - 1}: {int((inv < 0).sum())} of them are missing "
                         f"(others repeat)")
    return inv


def reordered(answer, points, directions, *rows):
    """``answer`` asked in the coherent order, its answers returned in the given order.

    Parameters
    ----------
    answer : callable
        ``answer(points, directions, *rows) -> ndarray, shape (N,)``, every
        row answered on its own (as the kernel of ``_visible``).
    points, directions : ndarray, shape (N, 3)
        As in :func:`ray_key`.
    *rows : ndarray with N rows, or None
        Further per-ray inputs (owners, normals, lengths), permuted alike;
        None passes through.

    Returns
    -------
    ndarray, shape (N,)
        ``answer``'s result for row ``i`` of the given order at index ``i``:
        bit-identical to ``answer(points, directions, *rows)`` when every row
        is answered independently of the others.
    """
    perm = coherent_order(points, directions)

    def take(a):
        return None if a is None else np.take(a, perm, axis=0)
    got = answer(take(points), take(directions), *(take(a) for a in rows))
    out = np.empty_like(got)
    out[perm] = got
    return out

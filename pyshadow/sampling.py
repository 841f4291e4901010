"""Sample patterns and cosine-weighted hemisphere directions (thesis 000, 5.3.1).

``M`` patterns of ``N`` 2-D points ``(xi1, xi2)`` in ``[0, 1)^2`` are made for
a strategy and a seed; every query point picks one pattern by a hash of its
index, and each 2-D point becomes the cosine-weighted direction
``(sqrt(xi1) cos 2 pi xi2, sqrt(1 - xi1), sqrt(xi1) sin 2 pi xi2)`` in the
frame ``(t, n, b)`` of the point's normal ``n`` (thesis eq. 5.9 and the
combined form after it).

Strategies
----------
``random``           independent uniform points.
``stratified``       jittered ``a x b`` grid, ``a*b = N`` (``a`` the largest
                     divisor of ``N`` not above ``sqrt(N)``).
``latin_hypercube``  N-rooks: one point per row and per column of an N x N grid.
``halton``           bases 2 and 3, a Cranley-Patterson rotation (random shift
                     modulo 1) per pattern (eq. 5.12).
``hammersley``       ``(k/N, Phi_2(k))``, each coordinate's 32 binary digits
                     XOR-scrambled by a random word per pattern (Kollig and
                     Keller's random digit scrambling); for ``N`` a power of
                     two the points stay a (0, m, 2)-net.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from . import _cl
from ._compat import legacy_sampling
from ._validate import check_indices, check_int, unit_normals

__all__ = ["Sampling", "STRATEGIES", "ao_from_samples", "sample_patterns", "pattern_indices", "sample_directions",
           "sample_directions_reference", "hemisphere_frame", "local_directions", "direction_table"]

STRATEGIES = ("random", "stratified", "latin_hypercube", "halton", "hammersley")
_CODES = {s: i for i, s in enumerate(STRATEGIES)}
MAX_SAMPLES = 4096
MAX_PATTERNS = 65536
#: The largest seed: the pattern generator is seeded with 32 bits of it.
MAX_SEED = 2**32 - 1


@dataclass(frozen=True)
class Sampling:
    """How the hemisphere of each point is sampled: one value wherever samples are drawn.

    Parameters
    ----------
    samples : int, optional
        Cosine-weighted directions per point, 1 .. 4096.
    strategy : str, optional
        One of :data:`STRATEGIES`: 'random', 'stratified',
        'latin_hypercube', 'halton' or 'hammersley'.
    patterns : int, optional
        Precomputed patterns, 1 .. 65536; point ``i`` uses pattern
        ``pattern_indices(indices[i], patterns, seed)``, so neighbouring
        pixels see different directions.
    seed : int, optional
        Seed of the pattern assignment (and of the 'random' strategies),
        0 .. 2**32 - 1 (:data:`MAX_SEED`): the patterns' generator takes 32
        bits of it, so larger or negative seeds would repeat the patterns
        of seeds in that range; they are refused.

    Raises
    ------
    TypeError
        ``samples`` or ``seed`` is not an int (bools and floats are refused).
    ValueError
        A value out of its range, an unknown ``strategy``, or ``patterns``
        not an int in 1 .. 65536 (a bool or a float included).

    Examples
    --------
    >>> Sampling(64, "halton").samples
    64
    """

    samples: int = 36
    strategy: str = "hammersley"
    patterns: int = 256
    seed: int = 0

    def __post_init__(self):
        check_sampling(self.samples, self.strategy, self.patterns)
        check_seed(self.seed)

    def directions(self, normals, indices=None) -> np.ndarray:
        """World directions (N, samples, 3) float32 about ``normals``: :func:`sample_directions`."""
        return sample_directions(normals, sampling=self, indices=indices)


def _check_patterns(patterns) -> None:
    """The number of sample patterns: an int (not a bool) in 1 .. MAX_PATTERNS (ValueError)."""
    if isinstance(patterns, bool) or not isinstance(patterns, (int, np.integer)) or not 1 <= patterns <= MAX_PATTERNS:
        raise ValueError(f"patterns must be an int in 1..{MAX_PATTERNS}, got {patterns!r}")


def check_sampling(samples, strategy, patterns):
    """Validate the sampling arguments shared by every AO entry point."""
    check_int(samples, "samples", 1, MAX_SAMPLES)
    if not isinstance(strategy, str) or strategy not in _CODES:
        raise ValueError(f"unknown strategy {strategy!r}; expected one of {', '.join(STRATEGIES)}")
    _check_patterns(patterns)


def check_seed(seed) -> int:
    """The seed of a sampling as an int in 0 .. :data:`MAX_SEED` (TypeError, ValueError otherwise)."""
    return check_int(seed, "seed", 0, MAX_SEED, "the pattern generator uses 32 bits of it")


def _radical_inverse(k, base):
    k = np.asarray(k, dtype=np.int64).copy()
    out = np.zeros(k.shape)
    f = 1.0 / base
    while (k > 0).any():
        out += (k % base) * f
        k //= base
        f /= base
    return out


def _bits_to_unit(b):
    """uint32 words to floats in [0, 1): the centre of each 2^-32 cell."""
    return (b.astype(np.float64) + 0.5) / 2.0**32


def sample_patterns(samples: int, strategy: str = "hammersley", patterns: int = 256,
                    seed: int = 0) -> np.ndarray:
    """The 2-D sample patterns of a strategy.

    Parameters
    ----------
    samples, strategy, patterns, seed
        As for :class:`Sampling` (``seed`` in 0 .. 2**32 - 1).

    Returns
    -------
    ndarray, shape (patterns, samples, 2), float64
        Points ``(xi1, xi2)`` in ``[0, 1)``; deterministic for ``seed``.
    """
    check_sampling(samples, strategy, patterns)
    check_seed(seed)
    N, M = int(samples), int(patterns)
    rng = np.random.default_rng([int(seed) & 0xFFFFFFFF, _CODES[strategy], N])
    k = np.arange(N)
    if strategy == "random":
        pts = rng.random((M, N, 2))
    elif strategy == "stratified":
        a = max(d for d in range(1, int(np.sqrt(N)) + 1) if N % d == 0)
        b = N // a
        i, j = np.divmod(k, b)                      # row i of a, column j of b
        jitter = rng.random((M, N, 2))
        pts = np.stack([(i + jitter[..., 0]) / a, (j + jitter[..., 1]) / b], axis=-1)
    elif strategy == "latin_hypercube":
        p1 = np.argsort(rng.random((M, N)), axis=1)
        p2 = np.argsort(rng.random((M, N)), axis=1)
        jitter = rng.random((M, N, 2))
        pts = np.stack([(p1 + jitter[..., 0]) / N, (p2 + jitter[..., 1]) / N], axis=-1)
    elif strategy == "halton":
        base = np.stack([_radical_inverse(k + 1, 2), _radical_inverse(k + 1, 3)], axis=-1)
        shift = rng.random((M, 1, 2))
        pts = np.mod(base[None] + shift, 1.0)
    else:  # hammersley with random digit scrambling
        x = np.floor(k / N * 2.0**32).astype(np.uint64).astype(np.uint32)
        y = np.floor(_radical_inverse(k, 2) * 2.0**32).astype(np.uint64).astype(np.uint32)
        s = rng.integers(0, 2**32, size=(M, 1, 2), dtype=np.uint64).astype(np.uint32)
        pts = np.stack([_bits_to_unit(x[None] ^ s[..., 0]), _bits_to_unit(y[None] ^ s[..., 1])], axis=-1)
    return np.minimum(pts, np.nextafter(1.0, 0.0))


def pattern_indices(indices, patterns: int, seed: int = 0) -> np.ndarray:
    """Pattern used by query point ``indices`` (a hash, so chunking cannot change it).

    ``seed`` as for :class:`Sampling` (0 .. 2**32 - 1).
    """
    check_seed(seed)
    _check_patterns(patterns)
    a = np.asarray(indices)
    if a.dtype.kind not in "iu" and a.size:             # (an empty list is float64: no index at all)
        raise TypeError(f"indices must be integers, got dtype {a.dtype}")
    if a.dtype.kind == "i" and a.size and a.min() < 0:
        raise ValueError("indices must be >= 0 and below 2**63")
    i = a.astype(np.uint64)
    z = i + np.uint64((int(seed) * 0x9E3779B97F4A7C15 + 0x632BE59BD9B4E019) & 0xFFFFFFFFFFFFFFFF)
    with np.errstate(over="ignore"):
        z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
        z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
        z = z ^ (z >> np.uint64(31))
    return (z % np.uint64(patterns)).astype(np.int32)


def hemisphere_frame(normals) -> tuple[np.ndarray, np.ndarray]:
    """Tangent ``t`` and bitangent ``b`` of unit normals (float64, NumPy).

    The branch-free frame of Duff et al. (2017): with ``s = sign(n_z)``
    (+1 for ``n_z = 0``), ``a = -1/(s + n_z)``, ``c = n_x n_y a``:
    ``t = (1 + s n_x^2 a, s c, -s n_x)``, ``b = (c, s + n_y^2 a, -n_y)``.
    ``(t, n, b)`` is orthonormal; the kernels build the same frame in float32.
    """
    n = np.asarray(normals, dtype=np.float64)
    s = np.where(n[..., 2] >= 0, 1.0, -1.0)
    a = -1.0 / (s + n[..., 2])
    c = n[..., 0] * n[..., 1] * a
    t = np.stack([1.0 + s * n[..., 0] ** 2 * a, s * c, -s * n[..., 0]], axis=-1)
    b = np.stack([c, s + n[..., 1] ** 2 * a, -n[..., 1]], axis=-1)
    return t, b


def _check_normals(normals):
    """(N, 3) finite normals, normalised as the AO entry points do (:func:`pyshadow._validate.unit_normals`:
    any non-zero length, however small or large, is scaled to 1; zero rows are refused)."""
    return unit_normals(normals, None)


def local_directions(points) -> np.ndarray:
    """Cosine-weighted local directions ``(x, y, z)`` (y along the normal) of 2-D points.

    ``(sqrt(xi1) cos 2 pi xi2, sqrt(1 - xi1), sqrt(xi1) sin 2 pi xi2)``, float64.
    """
    xi = np.asarray(points)
    if xi.dtype.kind not in "iuf":      # complex lost its imaginary part (a ComplexWarning), "0.5" was read
        raise TypeError(f"points: expected real numbers (got dtype {xi.dtype})")
    xi = xi.astype(np.float64, copy=False)
    if xi.shape[-1:] != (2,) or not ((xi >= 0.0) & (xi <= 1.0)).all():      # else NaN directions
        raise ValueError(f"points: expected 2-D sample points in [0, 1]^2, shape (..., 2) (got shape {xi.shape}"
                         f"{'' if xi.shape[-1:] != (2,) else ', values outside [0, 1] or NaN'})")
    r = np.sqrt(xi[..., 0])
    ang = 2.0 * np.pi * xi[..., 1]
    return np.stack([r * np.cos(ang), np.sqrt(1.0 - xi[..., 0]), r * np.sin(ang)], axis=-1)


def direction_table(samples: int, strategy: str = "hammersley", patterns: int = 256,
                    seed: int = 0) -> np.ndarray:
    """Local directions of every pattern, (patterns, samples, 3) float32, as the kernels read them.

    The array is read-only. Every AO call reads its sampling's table, so
    tables of at most ``_TABLE_CACHE_ENTRIES`` directions (samples times
    patterns) are kept, the last eight asked.
    """
    check_sampling(samples, strategy, patterns)
    check_seed(seed)
    key = (int(samples), str(strategy), int(patterns), int(seed))
    if key[0] * key[2] <= _TABLE_CACHE_ENTRIES:
        return _kept_direction_table(*key)
    return _direction_table(*key)


_TABLE_CACHE_ENTRIES = 1 << 16      # directions: 768 KiB a table at most


def _direction_table(samples, strategy, patterns, seed):
    table = local_directions(sample_patterns(samples, strategy, patterns, seed)).astype(np.float32)
    table.setflags(write=False)
    return table


_kept_direction_table = lru_cache(maxsize=8)(_direction_table)


_ORDER = ("samples", "strategy", "patterns", "seed")


def _sampling(where, args, sampling, old):
    """The ``Sampling`` of a call that may use the old positional or keyword sampling arguments."""
    if sampling is not None and not isinstance(sampling, Sampling):
        raise TypeError(f"sampling must be a pyshadow.Sampling, got {sampling!r} (e.g. "
                        f"sampling=pyshadow.Sampling(36, 'hammersley'))")
    return legacy_sampling(where, args, _ORDER, sampling, old, Sampling(), stacklevel=5)[0]


def sample_directions_reference(normals, *args, sampling: Sampling | None = None, indices=None,
                                **old) -> np.ndarray:
    """NumPy (float64) version of :func:`sample_directions`."""
    sampling = _sampling("pyshadow.sampling.sample_directions_reference", args, sampling, old)
    samples, strategy, patterns, seed = sampling.samples, sampling.strategy, sampling.patterns, sampling.seed
    n = _check_normals(normals)
    local = local_directions(sample_patterns(samples, strategy, patterns, seed))
    idx = check_indices(indices, len(n))
    loc = local[pattern_indices(idx, patterns, seed)]       # (N, S, 3)
    # the kernels take the frame's branch on the float32 n_z: -7e-46 < n_z < 0 is -0.0 there, s = +1
    # (here s = -1 gave another frame: directions up to 1.97 apart)
    m = n.copy()
    m[m[:, 2].astype(np.float32) == 0, 2] = 0.0
    t, b = hemisphere_frame(m)
    return loc[..., 0:1] * t[:, None] + loc[..., 1:2] * n[:, None] + loc[..., 2:3] * b[:, None]


def sample_directions(normals, *args, sampling: Sampling | None = None, indices=None, **old) -> np.ndarray:
    """The exact directions the AO kernels trace for each normal.

    Parameters
    ----------
    normals : array_like, shape (N, 3)
        Surface normals (world frame; finite and non-zero, normalised here
        whatever their length, as ``Scene.ambient_occlusion`` does).
        Query point ``i`` uses pattern ``pattern_indices(i, sampling.patterns,
        sampling.seed)``.
    sampling : Sampling, optional
        Directions per point, strategy, number of patterns ``M`` and seed;
        default ``Sampling()`` (36 Hammersley directions, 256 patterns). The
        old positional or keyword ``samples, strategy, patterns, seed`` still
        work, with a DeprecationWarning; anything else (a strategy's name, a
        sample count) is a TypeError.
    indices : array_like of int, shape (N,), optional
        Pattern index of each point (as ``Scene.ambient_occlusion``'s
        ``indices``, e.g. pixel numbers); default ``arange(N)``.

    Returns
    -------
    ndarray, shape (N, sampling.samples, 3), float32
        Unit directions in the upper hemisphere of each normal, computed by
        the same OpenCL function the AO kernel calls, so a ray tracer given
        these directions traces exactly the rays pyshadow tests.

    Raises
    ------
    TypeError
        ``sampling`` is not a :class:`Sampling`; ``normals`` not numeric.
    ValueError
        ``normals`` not of shape (N, 3), not finite or zero; ``indices`` of
        the wrong shape or negative (not integers: TypeError).
    """
    sampling = _sampling("pyshadow.sample_directions", args, sampling, old)
    samples, strategy, patterns, seed = sampling.samples, sampling.strategy, sampling.patterns, sampling.seed
    n = _check_normals(normals)
    N, S = len(n), int(samples)
    out = np.empty((N, S, 3), np.float32)
    if N == 0:
        return out
    import pyopencl as cl

    table = direction_table(S, strategy, patterns, seed)
    idx = check_indices(indices, N)
    pidx = pattern_indices(idx, patterns, seed)
    k = _cl.kernel("sampling.cl", "sample_directions", {"SAMPLES": S})
    buf = _cl.empty(out.nbytes)
    k(_cl.queue(), (N,), None, _cl.to_device(n, np.float32), _cl.to_device(pidx, np.int32),
      _cl.to_device(table), np.int32(N), buf)
    cl.enqueue_copy(_cl.queue(), out, buf)
    return out


def ao_from_samples(directions, visible, normals, return_bent_normals: bool = False):
    """AO (and bent normals) from per-sample visibility, as the AO kernels define them.

    Parameters
    ----------
    directions : ndarray, shape (N, S, 3)
        The cosine-weighted sample directions of each point.
    visible : ndarray, shape (N, S), bool or float
        Which of them reach the sky; or per-sample weights in [0, 1]
        (distance-weighted AO: AO their mean, the bent normal their weighted sum).
    normals : ndarray, shape (N, 3)
        Unit normals: the bent normal where no direction reaches the sky
        (finite and non-zero with ``return_bent_normals=True``).
    return_bent_normals : bool, optional

    Returns
    -------
    ao : ndarray, shape (N,), float32
        The fraction of visible samples.
    bent : ndarray, shape (N, 3), float32
        The normalised sum of the visible directions (only with
        ``return_bent_normals=True``).

    Raises
    ------
    ValueError
        Shapes that do not agree, no sample, weights outside [0, 1] or NaN;
        with ``return_bent_normals``, directions or normals not finite, or a
        zero normal.
    TypeError
        Arrays that do not hold real numbers (``visible``: or bools).
    """
    directions, visible, normals = np.asarray(directions), np.asarray(visible), np.asarray(normals)
    d, v, n = directions.shape, visible.shape, normals.shape
    if len(d) != 3 or d[2] != 3 or v != d[:2] or n != (d[0], 3):
        raise ValueError(f"directions (N, S, 3), visible (N, S) and normals (N, 3) must agree, got {d}, {v} and {n}")
    if d[1] == 0:
        raise ValueError("directions hold no sample (S = 0): AO is the mean over at least one")
    for name, a, kinds in (("directions", directions, "iuf"), ("visible", visible, "biuf"),
                           ("normals", normals, "iuf")):
        if a.dtype.kind not in kinds:
            raise TypeError(f"{name} must hold {'bools or ' if name == 'visible' else ''}real numbers, got {a.dtype}")
    if visible.dtype.kind != "b" and not ((visible >= 0) & (visible <= 1)).all():
        raise ValueError("visible: weights must lie in [0, 1] (NaN is none)")
    ao = visible.mean(axis=1).astype(np.float32)
    if not return_bent_normals:
        return ao
    if not (np.isfinite(directions).all() and np.isfinite(normals).all()):
        raise ValueError("directions and normals must be finite (the bent normals sum them)")
    zero = int((~normals.any(axis=1)).sum())
    if zero:        # else the bent normal of a point no direction reaches was (0, 0, 0), silently
        raise ValueError(f"normals: {zero} rows are zero vectors (the bent normal where no direction is open)")
    b = (directions * visible[..., None]).sum(axis=1)
    length = np.linalg.norm(b, axis=1, keepdims=True)
    b = np.where(length > 0, b / np.maximum(length, np.finfo(length.dtype).tiny), normals)
    return ao, b.astype(np.float32)


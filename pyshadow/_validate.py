"""Validation shared by every entry point: arrays of points, directions, normals, transforms, indices.

Each checker raises ``ValueError`` or ``TypeError`` with the argument's name
and what is wrong; none copies a valid array it does not have to.
"""
from __future__ import annotations

import numbers
from concurrent.futures import ThreadPoolExecutor

import numpy as np

__all__ = ["rows3", "squared_lengths", "check_values", "checked_bound", "check_both", "kernel_rows", "check_rows",
           "nonzero", "check_transform", "check_transforms", "check_indices", "check_int", "FLOAT32_MAX",
           "check_float32_points", "check_float32_instances"]


def rows3(a, name, n=None, dtype=np.float64):
    """Validate an (N, 3) numeric array of finite values; return it as ``dtype``."""
    a = np.asarray(check_rows(a, name, n), dtype=dtype)
    check_values(a, name)
    return a


def check_values(a, name, nonzero=False):
    """Raise ValueError for rows of an (N, 3) array that are not finite (or,
    with ``nonzero``, are zero vectors).

    Cheap for valid input (query batches hold millions of rows): the sum of
    all entries is finite unless an entry is not (or finite entries overflow
    it: then the rows are checked exactly), and a zero row is three zero
    entries in a row of the flat array, found among the (usually few) zero
    entries. No BLAS call: its worker threads would keep spinning on the cores
    the kernel is about to use.
    """
    if len(a) == 0:
        return
    if not np.issubdtype(a.dtype, np.integer):
        with np.errstate(all="ignore"):
            total = np.add.reduce(a, axis=None)
        if not np.isfinite(total):
            bad = int((~np.isfinite(a).all(axis=1)).sum())
            if bad:
                raise ValueError(f"{name}: {bad} rows are not finite")
    if nonzero:
        z = np.flatnonzero(a.reshape(-1) == 0)
        if len(z) >= 3:
            head = z[:-2]
            zero = int(((z[2:] - head == 2) & (head % 3 == 0)).sum())
            if zero:
                raise ValueError(f"{name}: {zero} rows are zero vectors")


#: Rows a chunk of the batch checks reads at a time: 768 KiB of float64 rows, which a core's cache holds
#: while the chunk is read a second time (each check then reads the batch from memory once)
CHECK_ROWS = 1 << 15


def _row_chunks(a):
    return (a[s:s + CHECK_ROWS] for s in range(0, len(a), CHECK_ROWS))


def checked_bound(a, name) -> float:
    """check_values of an (N, 3) array, returning its largest |coordinate|
    (``pyshadow.scene_arrays.points_bound``'s value; 0.0 for no rows).

    The chunks' maxima and minima: a NaN or an infinity makes them
    non-finite, and then the rows are counted as check_values counts them.
    """
    if len(a) == 0:
        return 0.0
    ext = np.array([(c.max(), c.min()) for c in _row_chunks(a)])
    hi, lo = ext[:, 0].max(), ext[:, 1].min()
    if not (np.isfinite(hi) and np.isfinite(lo)):
        check_values(a, name)
    return max(abs(float(hi)), abs(float(lo)))


def _check_chunks(a, name, nonzero):
    """check_values chunk by chunk (the same rows refused; a refusal's counts are those of the whole array)."""
    try:
        for c in _row_chunks(a):
            check_values(c, name, nonzero)
    except ValueError:
        check_values(a, name, nonzero)
        raise


_checker = None


def check_both(p, p_name, w, w_name) -> float:
    """check_values of points and of (non-zero) directions, side by side on
    two threads for large batches (NumPy releases the GIL); the first error in
    argument order is raised. Returns the points' largest |coordinate|
    (:func:`checked_bound`), which the points' check reads on the way."""
    global _checker
    if len(p) < 100_000:
        bound = checked_bound(p, p_name)
        check_values(w, w_name, nonzero=True)
        return bound
    if _checker is None:
        _checker = ThreadPoolExecutor(1, thread_name_prefix="pyshadow-check")
    future = _checker.submit(checked_bound, p, p_name)
    try:
        _check_chunks(w, w_name, True)
    except ValueError:
        future.result()                 # points first, as in the sequential order
        raise
    return future.result()


def kernel_rows(a, name, n=None):
    """An (N, 3) array as the visibility kernel reads it: C-contiguous float32
    or float64 (other dtypes are converted to float64; no copy otherwise)."""
    a = check_rows(a, name, n)
    if a.dtype not in (np.float32, np.float64):
        a = a.astype(np.float64)
    return np.ascontiguousarray(a)


def check_rows(a, name, n=None):
    """Shape and dtype checks of an (N, 3) array, no copy (values are checked later)."""
    a = np.asarray(a)
    if a.ndim != 2 or a.shape[1] != 3:
        raise ValueError(f"{name} must have shape (N, 3), got {a.shape}")
    if n is not None and len(a) != n:
        raise ValueError(f"{name} has {len(a)} rows but points has {n} (shapes must match)")
    if not (np.issubdtype(a.dtype, np.floating) or np.issubdtype(a.dtype, np.integer)):
        raise TypeError(f"{name} must be numeric, got {a.dtype}")
    return a


def nonzero(a, name):
    check_values(a, name, nonzero=True)
    return a


def uniform_scale(A):
    """The signed cube root of ``det(A)`` of 3x3 matrices ``A`` (shape (..., 3, 3)): a rigid transform's
    uniform scale, at any scale (beyond the range where ``det(A)`` over- or underflows float64, from
    ``A / max|A|``; within it ``cbrt(det(A))`` itself)."""
    A = np.asarray(A, np.float64)
    with np.errstate(over="ignore", under="ignore"):
        d = np.linalg.det(A)
    s = np.cbrt(d)
    odd = ~((np.abs(d) > 1e-290) & (np.abs(d) < 1e290))
    if np.any(odd):
        m = np.abs(A).max(axis=(-2, -1))
        m = np.where(m > 0, m, 1.0)
        scaled = np.cbrt(np.linalg.det(A / m[..., None, None])) * m
        s = np.where(odd, scaled, s)
    return s


def point3(x, label: str) -> np.ndarray:
    """``x`` as 3 finite float64 numbers, a new (3,) array (any shape holding 3 values); ValueError
    "``label`` must be 3 finite numbers" otherwise (bools, strings and complex numbers are no
    coordinates: ``(True, False, True)`` was read as ``(1, 0, 1)``)."""
    try:
        a = np.asarray(x)
        a = a.astype(np.float64).reshape(-1) if a.dtype.kind in "iuf" else None
    except (TypeError, ValueError):     # ragged
        a = None
    if a is None or a.shape != (3,) or not np.isfinite(a).all():
        raise ValueError(f"{label} must be 3 finite numbers, got {x!r}")
    return a


#: CSM lookups: ``"nearest"`` (backend ``"csm"``) and ``"vote"`` (``"csm-vote"``).
LOOKUPS = ("nearest", "vote")


def check_lookup(lookup) -> str:
    """``lookup`` unchanged; ValueError unless it is the string 'nearest' or 'vote' (an array's ``in``
    tested its elements, or raised NumPy's "truth value ... ambiguous")."""
    if not isinstance(lookup, str) or lookup not in LOOKUPS:
        raise ValueError(f"lookup must be 'nearest' or 'vote', got {lookup!r}")
    return lookup


def float32_exact(a) -> np.ndarray:
    """Elementwise: does float32 hold the value of ``a`` exactly (so it may be a float32 number, carrying
    float32's rounding)? Beyond float32's range: False."""
    a = np.asarray(a, np.float64)
    with np.errstate(over="ignore"):
        return a.astype(np.float32).astype(np.float64) == a


def real_scalar(value) -> bool:
    """``value`` is one real number (Python, NumPy or a 0-d array; not a bool, a complex or a string)."""
    return (not isinstance(value, (bool, np.bool_)) and np.ndim(value) == 0
            and np.asarray(value).dtype.kind in "iuf")


def flag(value, name: str) -> bool:
    """``value`` as a bool: True or False (Python or NumPy); TypeError naming ``name`` for anything else
    (the string "no" or "False" would be true, an array's truth is ambiguous, None or 0 may mean a default)."""
    if not isinstance(value, (bool, np.bool_)):
        raise TypeError(f"{name}: expected True or False (got {value!r})")
    return bool(value)


#: A rigid transform's 3x3 part, its uniform scale removed, may deviate from a rotation by RIGID_TOL
#: (max |Q^T Q - I|): one written out with 5 or more decimals deviates by up to about 3e-5 (6 decimals,
#: the common "%f", by up to 3e-6, which 1e-6 refused one time in ten). Beyond RIGID_EXACT it is
#: replaced by the nearest rotation (the polar factor of Q), so that an instance's inverse, the
#: transpose, stays exact; at or below it a transform is kept as given.
RIGID_EXACT, RIGID_TOL = 1e-6, 1e-4


def check_transform(T, *, rigid: bool = False, name: str = "transform") -> np.ndarray:
    """Validate a 4x4 affine transform; return it as float64.

    With ``rigid=True`` only rotation, translation and uniform positive scale
    are accepted (the transforms a CSM instance may have), within
    :data:`RIGID_TOL`; a 3x3 part off a scaled rotation by more than
    :data:`RIGID_EXACT` comes back as the nearest scaled rotation (the same
    scale and translation).
    """
    T = np.asarray(T)
    if T.dtype.kind not in "iuf":
        raise TypeError(f"{name} must hold real numbers, got dtype {T.dtype}")
    T = T.astype(np.float64)
    if T.shape != (4, 4):
        raise ValueError(f"{name} must be a 4x4 matrix, got shape {T.shape}")
    if not np.isfinite(T).all():
        raise ValueError(f"{name} has non-finite entries")
    if not np.abs(T[3] - [0.0, 0.0, 0.0, 1.0]).max() <= 1e-12:     # (allclose let w = 1.000009 pass)
        raise ValueError(f"{name} must be affine (last row 0 0 0 1), got {T[3].tolist()}")
    A = T[:3, :3]
    m = np.abs(A).max()
    # singular or not, scale-free: det(A) itself overflows beyond scales of 5e102 and underflows
    # below 1e-100, where a uniform scale is still a rigid body's; entries all below float64's normal
    # range count as singular (the reciprocal of such a scale overflows)
    if not (m >= np.finfo(np.float64).tiny and abs(np.linalg.det(A / m)) > 1e-300):
        raise ValueError(f"{name} is singular")
    if rigid:
        s = float(uniform_scale(A))
        if not s > 0:
            raise ValueError(f"{name} mirrors (negative determinant); only rotations are rigid")
        Q = A / s
        err = np.abs(Q.T @ Q - np.eye(3)).max()
        if err > RIGID_TOL:
            raise ValueError(
                f"{name} is not rigid: after removing the uniform scale {s:.6g} the 3x3 part "
                f"deviates from a rotation by {err:.3g} (shear or non-uniform scale; {RIGID_TOL:g} is allowed)"
            )
        if err > RIGID_EXACT:           # rounded digits: the nearest rotation, U V^T of Q's SVD
            U, _, Vt = np.linalg.svd(Q)
            T[:3, :3] = s * (U @ Vt)
    return T


def check_transforms(T, *, rigid: bool = False, name: str = "transforms", label=None) -> np.ndarray:
    """:func:`check_transform` of every matrix of a stack ``T`` (..., 4, 4) at once, as float64.

    Each matrix gets the same checks and comes back the same, bit for bit, as
    through :func:`check_transform`: those clearly within its rules are read in
    one pass over the stack; any other (a failing one, or one near a threshold
    or off a rotation by more than :data:`RIGID_EXACT`) goes through
    :func:`check_transform` itself, which raises its error named
    ``label(index)`` (default ``f"{name}[index]"``, the matrix's index tuple).
    """
    T = np.asarray(T)
    if T.dtype.kind not in "iuf":
        raise TypeError(f"{name} must hold real numbers, got dtype {T.dtype}")
    T = T.astype(np.float64, order="C")         # (C order: the flat view below writes into T itself)
    if T.ndim < 2 or T.shape[-2:] != (4, 4):
        raise ValueError(f"{name} must have shape (..., 4, 4), got {T.shape}")
    label = label or (lambda k: f"{name}[{', '.join(map(str, k))}]")
    flat = T.reshape(-1, 4, 4)
    with np.errstate(all="ignore"):
        A = flat[:, :3, :3]
        m = np.abs(A).max(axis=(1, 2))
        ok = np.isfinite(flat).all(axis=(1, 2)) & (np.abs(flat[:, 3] - [0.0, 0.0, 0.0, 1.0]).max(axis=1) <= 1e-12)
        ok &= m >= 1e-300
        d = np.linalg.det(A / np.where(ok, m, 1.0)[:, None, None])
        ok &= (d > 1e-280) if rigid else (np.abs(d) > 1e-280)     # clear of the singular test, and not mirrored
        if rigid and ok.any():
            Q = A / uniform_scale(A)[:, None, None]
            err = np.abs(np.matmul(Q.transpose(0, 2, 1), Q) - np.eye(3)).max(axis=(1, 2))
            ok &= err <= 0.5 * RIGID_EXACT                          # kept as given, as check_transform keeps it
    for k in np.flatnonzero(~ok):
        flat[k] = check_transform(flat[k], rigid=rigid, name=label(np.unravel_index(k, T.shape[:-2])))
    return T


def check_indices(indices, n: int, name: str = "indices") -> np.ndarray:
    """Sample-pattern indices of ``n`` points as int64 (default ``arange(n)``): integers >= 0, shape (n,)
    (a float or a negative index was truncated or wrapped into another point's pattern)."""
    if indices is None:
        return np.arange(n)
    a = np.asarray(indices)
    if a.dtype.kind not in "iu":
        raise TypeError(f"{name} must be integers, got dtype {a.dtype}")
    idx = a.astype(np.int64)
    if idx.shape != (n,):
        raise ValueError(f"{name} must have shape ({n},), got {idx.shape}")
    if n and idx.min() < 0:
        raise ValueError(f"{name} must be >= 0 and below 2**63")
    return idx


def check_int(value, name: str, lo: int, hi: int | None = None, why: str = "") -> int:
    """``value`` as a Python int: an integer (Python or NumPy, not a bool) in ``lo .. hi``
    (``hi`` None: no upper bound).

    A float (even ``2.0``), a string or a bool raises TypeError, a value out
    of range ValueError; ``why``, if given, is added to the latter's message
    in parentheses (the reason for the range).
    """
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Integral):
        raise TypeError(f"{name} must be an int, got {value!r}")
    v = int(value)
    if v < lo or (hi is not None and v > hi):
        bound = f">= {lo}" if hi is None else f"in {lo}..{hi}"
        raise ValueError(f"{name} must be {bound}{f' ({why})' if why else ''}, got {v}")
    return v


def squared_lengths(a: np.ndarray) -> np.ndarray:
    """``(x x + y y) + z z`` of each 3-vector along the last axis of ``a`` (shape ``a.shape[:-1]``).

    The sum ``np.linalg.norm(a, axis=-1) ** 2`` takes, in its order, so that
    ``np.sqrt`` of it equals that norm bit for bit; taken by components, not
    by NumPy's slower reduction over an axis of three. Overflow and
    underflow give inf and 0 without a warning (the callers handle them).
    """
    x, y, z = (a[..., k] for k in range(3))
    with np.errstate(over="ignore", under="ignore"):
        return (x * x + y * y) + z * z


def unit_normals(normals, n: int, name: str = "normals", dtype=np.float64) -> np.ndarray:
    """(n, 3) finite, non-zero normals, normalised to unit length (as ``dtype``).

    Each row is divided by its length ``sqrt((x x + y y) + z z)``
    (:func:`squared_lengths`: the value ``np.linalg.norm(m, axis=1)``
    gives), in float64 whatever ``dtype``, which gets the rounded quotients
    (the values of the float64 result cast to it). A row whose squared
    length underflows (to zero or to a subnormal, which keeps fewer digits:
    components below about 1e-154) or overflows (above 1e154) is first
    scaled by its largest component, so that it still comes out a unit
    vector; a row of zeros is refused.
    """
    m = rows3(normals, name, n)
    ss = squared_lengths(m)
    odd = np.flatnonzero(~(ss >= np.finfo(np.float64).tiny) | (ss == np.inf))     # subnormal squares lose digits
    if len(odd):
        big = np.abs(m[odd]).max(axis=1)
        if not big.all():
            raise ValueError(f"{name}: {int((big == 0).sum())} rows are zero vectors")
        m = m.copy()
        m[odd] /= big[:, None]
        ss[odd] = (m[odd] * m[odd]).sum(axis=1)
    r = np.sqrt(ss)
    out = np.empty(m.shape, dtype)
    for k in range(3):                  # by columns (faster than dividing by r[:, None])
        np.divide(m[:, k], r, out=out[:, k])
    return out


#: The largest float32: the kernels read points relative to the scene's anchor, and the instance table
#: (1 / world radius, anchor-relative centres), in float32.
FLOAT32_MAX = float(np.finfo(np.float32).max)


def check_float32_points(p, anchor) -> float:
    """The largest |coordinate| of points ``p`` (N, 3) relative to ``anchor``; ValueError naming the rows
    that lie beyond float32's range from it (the kernels would read infinities)."""
    rel = np.abs(np.asarray(p, np.float64) - anchor).max(axis=1)
    bad = ~(rel <= FLOAT32_MAX)
    if bad.any():
        i = int(np.argmax(bad))
        raise ValueError(f"points: {int(bad.sum())} rows lie beyond float32's range from the scene's anchor "
                         f"{np.asarray(anchor).tolist()} (row {i}: {np.asarray(p[i], np.float64).tolist()}, "
                         f"|p - anchor| up to {float(rel[i]):.3g}; the kernels need at most {FLOAT32_MAX:.3g})")
    return float(rel.max()) if len(rel) else 0.0


def check_float32_instances(name, value, ids, radii, centres):
    """ValueError naming the first instance (of ``ids``) whose field ``name`` of the kernels' instance
    table, ``value`` (n, ...) float64, float32 cannot hold (world ``radii``, anchor-relative ``centres``)."""
    bad = ~(np.abs(value.reshape(len(value), -1)) <= FLOAT32_MAX).all(axis=1)
    if bad.any():
        k = int(np.argmax(bad))
        raise ValueError(f"instance {int(ids[k])}: its placement lies beyond float32's range ({name}: world radius "
                         f"{float(radii[k]):.3g}, centre {np.asarray(centres[k]).tolist()} from the scene's "
                         f"anchor): the kernels need 1 / radius and the anchor-relative centre within "
                         f"{FLOAT32_MAX:.3g}")

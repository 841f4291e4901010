"""The checks of a CSM's arrays the search kernels rely on, for a ``.csm`` file and for a CSM in memory.

:func:`check_arrays` validates the segment lists (``offsets``, ``iend``, ``depth``) against the
resolution, the map count and the depth precision: what :func:`pyshadow.csm.fileformat.load` checks
in a file and :meth:`CoherentShadowMap.save` in the arrays it is about to write (so that it never
replaces a file with one that load refuses). :func:`check_csm` does it for a CSM in memory, as
:meth:`CoherentShadowMap.search_arrays` does before every upload to the device: a CSM built with the
constructor from other arrays, or whose arrays were changed, would otherwise have the kernels read
outside their tables. Vectorized, O(S).
"""
from __future__ import annotations

import numpy as np

from .core import _LAYOUTS, CSMFormatError

__all__ = ["check_arrays", "check_csm", "checked_search_arrays"]

_MAX_RESOLUTION = 4096


def _integers(where, name, a):
    if not isinstance(a, np.ndarray) or a.ndim != 1 or a.dtype.kind not in "iu":
        raise CSMFormatError(f"{where}: {name} must be a 1-D array of integers, got "
                             f"{_described(a)}")


def _described(a):
    return f"{a.dtype} shape {a.shape}" if isinstance(a, np.ndarray) else type(a).__name__


def check_arrays(where, offsets, iend, depth, resolution, maps, depth_bits) -> None:
    """CSMFormatError, naming ``where`` and the first rule broken, unless the arrays are segment lists
    the kernels can search.

    Parameters
    ----------
    where : str
        What the arrays belong to (a file's path), for the message.
    offsets : ndarray, shape (R*R + 1,), integer
        ``offsets[0] == 0``, ``offsets[-1] == S``, every list at least one segment long.
    iend : ndarray, shape (S,), integer
        Values ``0 .. D-1``, strictly rising within a list, each list ending at ``D - 1``.
    depth : ndarray, shape (S,)
        16-bit: integers ``0 .. 65535``; 32-bit: float32, finite in ``[0, 2]`` or ``+inf`` (a miss).
    resolution, maps, depth_bits : int
        ``R`` (1 .. 4096), ``D`` (>= 1) and 16 or 32.
    """
    R, D, bits = resolution, maps, depth_bits
    if not (isinstance(R, (int, np.integer)) and 1 <= R <= _MAX_RESOLUTION):
        raise CSMFormatError(f"{where}: resolution {R!r} outside 1..{_MAX_RESOLUTION}")
    if not (isinstance(D, (int, np.integer)) and D >= 1):
        raise CSMFormatError(f"{where}: {D!r} maps (at least one is needed)")
    if bits not in (16, 32):
        raise CSMFormatError(f"{where}: depth_bits {bits!r} is not 16 or 32")
    _integers(where, "offsets", offsets)
    _integers(where, "iend", iend)
    if len(offsets) != R * R + 1:
        raise CSMFormatError(f"{where}: {len(offsets)} offsets for resolution {R} ({R * R + 1} expected: "
                             "one per texel and the end)")
    S = len(iend)
    if not isinstance(depth, np.ndarray) or depth.shape != (S,):
        raise CSMFormatError(f"{where}: depth is {_described(depth)} for {S} segments (iend); one per segment "
                             "is needed")
    off = offsets.astype(np.int64)
    if off[0] != 0 or off[-1] != S:
        raise CSMFormatError(f"{where}: offset table does not span 0..{S}")
    lengths = np.diff(off)
    if (lengths < 1).any():
        t = int(np.argmax(lengths < 1))
        raise CSMFormatError(f"{where}: segment list of texel {t} is empty or offsets decrease")
    if iend.min() < 0 or iend.max() >= D:
        raise CSMFormatError(f"{where}: an i_end is beyond the last map {D - 1}")
    ends = iend[off[1:] - 1]
    if (ends != D - 1).any():
        t = int(np.argmax(ends != D - 1))
        raise CSMFormatError(f"{where}: segment list of texel {t} does not end at map {D - 1}")
    inc = iend[1:] > iend[:-1]          # in the array's own dtype: no widened copy
    inc[off[1:-1] - 1] = True           # list boundaries may go down
    if not inc.all():
        raise CSMFormatError(f"{where}: i_end values of a segment list are not strictly increasing")
    if bits == 16:
        if depth.dtype.kind not in "iu":
            raise CSMFormatError(f"{where}: 16-bit depth must be integers 0..65535, got {depth.dtype}")
        if depth.dtype != np.uint16 and S and (depth.min() < 0 or depth.max() > 65535):
            raise CSMFormatError(f"{where}: 16-bit depth outside 0..65535 (got {depth.min()} .. {depth.max()})")
        return
    if depth.dtype.kind != "f" or depth.dtype.itemsize != 4:
        raise CSMFormatError(f"{where}: 32-bit depth must be float32, got {depth.dtype}")
    bad = ~(np.isposinf(depth) | (np.isfinite(depth) & (depth >= 0) & (depth <= 2)))
    if bad.any():
        raise CSMFormatError(f"{where}: stored depth {depth[np.argmax(bad)]!r} is neither finite "
                             "in [0, 2] nor the miss value +inf")


def check_csm(csm, where: str = "CoherentShadowMap") -> None:
    """:func:`check_arrays` on ``csm``'s arrays, with its resolution, map count and depth precision; and
    its offsets uint32 or uint64 and float depth in native byte order (what the device tables take), its
    view set's layout one the kernels look up (zigzag or hilbert). What
    :meth:`CoherentShadowMap.search_arrays` checks before an upload."""
    _check_storage(csm, where)
    check_arrays(where, csm.offsets, csm.iend, csm.depth, csm.resolution, csm.maps, csm.depth_bits)


def _check_storage(csm, where) -> None:
    """The O(1) part of :func:`check_csm`: the layout, the offsets' dtype, the float depth's byte order."""
    layout = getattr(csm.views, "layout", None)
    if layout not in _LAYOUTS:
        raise CSMFormatError(f"{where}: view layout {layout!r} has no lookup in the kernels (zigzag or hilbert)")
    off, depth = csm.offsets, csm.depth
    if isinstance(off, np.ndarray) and off.dtype.kind in "iu" and off.dtype not in (np.uint32, np.uint64):
        raise CSMFormatError(f"{where}: offsets must be uint32 (uint64 from 2^32 segments), got {off.dtype}")
    if isinstance(depth, np.ndarray) and depth.dtype.kind == "f" and not depth.dtype.isnative:
        # the device tables take the float's bits as they are
        raise CSMFormatError(f"{where}: depth must be in native byte order, got {depth.dtype.str}")


def checked_search_arrays(csm, wide=None, padded=False, segment=True) -> dict:
    """:meth:`CoherentShadowMap.search_arrays`: :func:`check_csm` (CSMFormatError where the constructor was
    given, or an attribute was set to, arrays the kernels would read outside of; the values of a mapped
    file's are checked when copied, :func:`pyshadow.csm.device.search_arrays`, their dtypes and the layout
    here), then the device layout."""
    from .device import search_arrays

    if any(isinstance(a, np.memmap) for a in (csm.offsets, csm.iend, csm.depth)):
        _check_storage(csm, "CoherentShadowMap")     # the values when copied; an array set since, too
    else:
        check_csm(csm)
    return search_arrays(csm, wide, padded, segment)

"""The ``.csm`` file format, version 1: save, load and validation.

Files are versioned, checksummed (SHA-256 of every byte before the digest)
and written atomically; never pickled.

File layout (little-endian, version 1):

========  =====================================================
bytes     content
========  =====================================================
0-7       magic ``b"PYSHCSM\\0"``
8-11      uint32 format version (1)
12-15     uint32 length H of the JSON header
16-       JSON header (UTF-8): resolution, maps, layout and
          layout_params, centre, radius, depth_bits, layer_rule,
          mesh_hash, segments, offsets_dtype, writer; optional
          front_margin_texels (default 0), footprint (default
          false), box (the mesh's box in the normalised frame,
          [[lo x, y, z], [hi x, y, z]]; default none), two_sided
          ("auto", true or false) and both_sided_faces (an integer
          >= 0; both default none), build_seconds;
          zigzag layout_params may hold row_offset (0 or 0.5;
          default 0, the thesis's grid), hilbert's hemispheres
          (true or false; default false)
aligned   arrays at 64-byte boundaries after the header, in order:
          offsets (R*R+1, uint32 or uint64), iend (S, uint16 when
          D <= 65536 else uint32), depth (S, uint16 or float32)
last 32   SHA-256 of every byte before it
========  =====================================================
"""
from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path

import numpy as np

from .._files import atomic_path
from .._validate import FLOAT32_MAX
from .._version import __version__
from .._views_checks import _layout_args
from ..views import BASIS_TOL, MAX_MAPS, ZIGZAG_ROW_OFFSETS, ViewSet
from .core import _LAYOUTS, CSMFormatError, _depth_dtype, _iend_dtype, _offsets_dtype
from .file_checks import check_arrays

__all__ = ["MAGIC", "FORMAT_VERSION", "save", "load", "check_layout_bases", "file_params"]

MAGIC = b"PYSHCSM\x00"
FORMAT_VERSION = 1
ALIGN = 64


def header(csm, reproducible: bool = False) -> dict:
    seconds = csm._build_seconds if np.isfinite(csm._build_seconds) and not reproducible else None
    return {
        "format": "pyshadow-csm",
        "version": FORMAT_VERSION,
        "writer": f"pyshadow {__version__}",
        "resolution": csm.resolution,
        "maps": csm.maps,
        "layout": csm.views.layout,
        "layout_params": file_params(csm.views),
        "centre": [float(x) for x in csm.centre],
        "radius": csm.radius,
        "depth_bits": csm.depth_bits,
        "layer_rule": csm.layer_rule,
        "front_margin_texels": csm.front_margin_texels,
        "footprint": csm.footprint,
        "box": None if csm.box is None else csm.box.tolist(),
        "two_sided": _plain(csm.two_sided),
        "both_sided_faces": _plain(csm.both_sided_faces),
        "mesh_hash": csm.mesh_hash,
        "segments": csm.segments,
        "offsets_dtype": _file_offsets_dtype(csm).str,
        "build_seconds": seconds,
    }


def _plain(x):
    """A NumPy scalar (``np.int64(3)``, ``np.True_``) as the Python value JSON writes; anything else as is."""
    return x.item() if isinstance(x, np.generic) else x


def _file_offsets_dtype(csm) -> np.dtype:
    """The offsets' dtype in a file, the one :func:`load` reads for the CSM's segment count (the
    offsets of a CSM in memory may be given in another integer dtype)."""
    return _offsets_dtype(csm.segments).newbyteorder("<")


def file_params(views) -> dict:
    """The layout parameters a file holds for ``views``, as :func:`load` reads them: ``theta``, ``phi``
    (and ``row_offset`` where given) of a zigzag set, ``level`` (and ``hemispheres``, only when true) of a
    hilbert set, as JSON numbers.

    A ViewSet may be given its layout's parameters as NumPy numbers, ``hemispheres`` False or 1, or with
    other keys beside them (:class:`pyshadow.ViewSet`); written as given, the NumPy numbers failed in
    ``json`` and load refused the rest.
    """
    args = _layout_args(views.layout, views.params)
    if views.layout == "zigzag":
        return {"theta": int(args[0]), "phi": int(args[1]),
                **({"row_offset": float(args[2])} if "row_offset" in views.params else {})}
    return {"level": int(args[0]), **({"hemispheres": True} if args[1] else {})}


def array_layout(start: int, resolution: int, maps: int, segments: int, depth_bits: int,
                  offsets_dtype) -> list:
    """(name, dtype, count, byte offset) of each array, 64-byte aligned from ``start``."""
    specs = [
        ("offsets", np.dtype(offsets_dtype), resolution * resolution + 1),
        ("iend", _iend_dtype(maps), segments),
        ("depth", _depth_dtype(depth_bits), segments),
    ]
    out, pos = [], start
    for name, dt, n in specs:
        pos = -(-pos // ALIGN) * ALIGN
        out.append((name, dt.newbyteorder("<"), n, pos))
        pos += dt.itemsize * n
    return out, pos


def check_layout_bases(views) -> None:
    """ValueError naming the first map whose basis is not the one its layout's parameters give.

    A file stores a view set as its layout and parameters, and :func:`load` rebuilds the bases from
    them (:meth:`ViewSet.from_params`): the maps of a ViewSet given other bases on the same grid (other
    ``u, v`` about each direction, to :data:`pyshadow.views.BASIS_TOL`) would come back turned, and
    every lookup would read the wrong texels.
    """
    want = ViewSet.from_params(views.layout, views.params).bases
    err = np.abs(np.asarray(views.bases, np.float64) - want).max(axis=(1, 2))
    if not (err <= BASIS_TOL).all():
        k = int(np.argmax(~(err <= BASIS_TOL)))
        raise ValueError(f"the view set's bases are not those of its {views.layout} layout (params "
                         f"{dict(views.params)!r}; map {k} off by {float(err[k]):.3g}, "
                         f"{int((~(err <= BASIS_TOL)).sum())} of {len(err)} maps): a .csm file stores only the "
                         "layout, whose bases load would give back; build with ViewSet.from_params(layout, "
                         "params) to save the CSM")


def save(csm, path, reproducible: bool = False) -> Path:
    """:meth:`CoherentShadowMap.save` (which documents the layout); ValueError where the view set's
    bases are not its layout's (:func:`check_layout_bases`), CSMFormatError where a header value (the
    centre, radius, box, layer rule, margin, two-sided record, build time: :func:`_header_values`) or its
    arrays, as the file's dtypes hold them, break a rule :func:`load` checks
    (:func:`.file_checks.check_arrays`), before anything is written."""
    path = Path(path)
    check_layout_bases(csm.views)
    text = json.dumps(header(csm, reproducible), sort_keys=True)
    _header_values("CoherentShadowMap.save", json.loads(text))     # what load would refuse is not written
    head = text.encode()
    start = 16 + len(head)
    layout, end = array_layout(start, csm.resolution, csm.maps, csm.segments, csm.depth_bits,
                               _file_offsets_dtype(csm))
    arrays = {name: np.ascontiguousarray(getattr(csm, name), dtype=dt) for name, dt, _, _ in layout}
    # what load would refuse is not written over a file
    check_arrays("CoherentShadowMap.save", arrays["offsets"], arrays["iend"], arrays["depth"], csm.resolution,
                 csm.maps, csm.depth_bits)
    h = hashlib.sha256()
    with atomic_path(path) as tmp, open(tmp, "wb") as f:
        def put(b):
            h.update(b)
            f.write(b)

        put(MAGIC + np.uint32(FORMAT_VERSION).tobytes() + np.uint32(len(head)).tobytes() + head)
        pos = start
        for name, dt, n, off in layout:
            put(b"\x00" * (off - pos))
            data = arrays[name]
            put(memoryview(data).cast("B"))
            pos = off + data.nbytes
        f.write(h.digest())
        f.flush()
        os.fsync(f.fileno())
    return path


def load(cls, path, mmap: bool = False):
    """:meth:`CoherentShadowMap.load` (which documents it) for the class ``cls``.

    The bytes checksummed are the bytes parsed: read once into memory, or
    mapped once (``mmap``), never read again from the path.
    """
    path = Path(path)
    if (n := path.stat().st_size) < 16 + 32:
        raise CSMFormatError(f"{path}: {n} bytes is too short for a CSM file")
    raw = np.memmap(path, dtype=np.uint8, mode="r") if mmap else np.frombuffer(path.read_bytes(), np.uint8)
    size = len(raw)
    pre = raw[:16].tobytes()
    if pre[:8] != MAGIC:
        raise CSMFormatError(f"{path}: not a pyshadow CSM file (magic {pre[:8]!r})")
    version = int(np.frombuffer(pre[8:12], "<u4")[0])
    if version != FORMAT_VERSION:
        raise CSMFormatError(f"{path}: format version {version} is not supported "
                             f"(this pyshadow reads version {FORMAT_VERSION})")
    hlen = int(np.frombuffer(pre[12:16], "<u4")[0])
    if 16 + hlen + 32 > size:
        raise CSMFormatError(f"{path}: header length {hlen} runs past the end of the file")
    # checksum over everything but the trailing digest
    if hashlib.sha256(memoryview(raw[:size - 32])).digest() != raw[size - 32:].tobytes():
        raise CSMFormatError(f"{path}: checksum mismatch (corrupted or truncated file)")
    try:
        head = json.loads(raw[16:16 + hlen].tobytes().decode("utf-8"), object_pairs_hook=_unique_keys)
    except _DuplicateKey as exc:
        raise CSMFormatError(f"{path}: the header holds the key {exc.args[0]!r} more than once") from None
    except (ValueError, RecursionError) as exc:     # not UTF-8, not JSON, an integer beyond Python's digits
        raise CSMFormatError(f"{path}: unreadable header ({type(exc).__name__}: {exc})") from None
    if not isinstance(head, dict):
        raise CSMFormatError(f"{path}: the header is not a JSON object")
    return _from_header(cls, path, head, 16 + hlen, raw)


class _DuplicateKey(Exception):
    """A key given twice in one JSON object of a header (which of the two a reader takes differs)."""


def _unique_keys(pairs) -> dict:
    out = dict(pairs)
    if len(out) != len(pairs):
        seen = set()
        raise _DuplicateKey(next(k for k, _ in pairs if k in seen or seen.add(k)))
    return out


def _number(x, lo=-np.inf, hi=np.inf) -> bool:
    """Whether a header value is a number (not a bool) within float32's range and [lo, hi]."""
    if isinstance(x, bool) or not isinstance(x, (int, float)):
        return False
    try:
        v = float(x)
    except OverflowError:               # an integer beyond float64
        return False
    return abs(v) <= FLOAT32_MAX and lo <= v <= hi


def _integer(x) -> bool:
    """Whether a header value is an integer (JSON's ``true`` is a bool, which ViewSet refuses)."""
    return isinstance(x, int) and not isinstance(x, bool)


def _header_values(path, head) -> dict:
    """The values of a header ``head`` (a dict as JSON gives it), checked as :func:`load` checks a file's:
    CSMFormatError naming ``path`` and the field. Sizes only against each other (the file's length and
    arrays are :func:`_from_header`'s)."""
    def need(key, kind):
        if not isinstance(head, dict) or key not in head:
            raise CSMFormatError(f"{path}: header lacks {key!r}")
        val = head[key]
        if kind is int and (isinstance(val, bool) or not isinstance(val, int)):
            raise CSMFormatError(f"{path}: header {key!r} must be an integer, got {val!r}")
        if kind is not int and not isinstance(val, kind):
            raise CSMFormatError(f"{path}: header {key!r} has the wrong type")
        return val

    # the version an integer: JSON's true (True == 1 in Python) and 1.0 are not version 1
    if head.get("format") != "pyshadow-csm" or not _integer(head.get("version")) \
            or head.get("version") != FORMAT_VERSION:
        raise CSMFormatError(f"{path}: header is not a pyshadow-csm version {FORMAT_VERSION}, got format "
                             f"{head.get('format')!r} version {head.get('version')!r}")
    R = need("resolution", int)
    D = need("maps", int)
    S = need("segments", int)
    bits = need("depth_bits", int)
    rule = need("layer_rule", int)
    layout = need("layout", str)
    params = need("layout_params", dict)
    centre = need("centre", list)
    radius = need("radius", (int, float))
    mh = need("mesh_hash", str)
    odt = need("offsets_dtype", str)
    if not 1 <= R <= 4096:
        raise CSMFormatError(f"{path}: resolution {R} outside 1..4096")
    if bits not in (16, 32):
        raise CSMFormatError(f"{path}: depth_bits {bits} is not 16 or 32")
    if rule not in (2, 3):
        raise CSMFormatError(f"{path}: layer_rule {rule} is not 2 or 3")
    margin = head.get("front_margin_texels", 0.0)       # absent in files from before the margin
    if not _number(margin, 0.0):
        raise CSMFormatError(f"{path}: front_margin_texels must be a finite number >= 0, got {margin!r}")
    footprint = head.get("footprint", False)             # absent in files from before the option
    if not isinstance(footprint, bool):
        raise CSMFormatError(f"{path}: footprint must be true or false, got {footprint!r}")
    box = head.get("box")                                 # absent in files from before boxes
    if box is not None:
        try:
            box = np.array(box, dtype=np.float64)
            ok = box.shape == (2, 3) and bool(np.isfinite(box).all()) and bool((box[0] <= box[1]).all()) \
                and bool((np.abs(box) <= 1.0 + 1e-6).all())
        except (TypeError, ValueError, OverflowError):
            ok = False
        if not ok:
            raise CSMFormatError(f"{path}: box must be [[lo x, y, z], [hi x, y, z]] with lo <= hi inside "
                                 f"[-1, 1] (the normalised frame), got {head.get('box')!r}")
    two_sided, n_both = head.get("two_sided"), head.get("both_sided_faces")     # absent before the record
    if not (two_sided is None or isinstance(two_sided, bool) or two_sided == "auto") or (
            two_sided is None) != (n_both is None) or not (
            n_both is None or (isinstance(n_both, int) and not isinstance(n_both, bool) and n_both >= 0)):
        raise CSMFormatError(f"{path}: two_sided must be \"auto\", true or false with both_sided_faces an "
                             f"integer >= 0 (or neither), got {two_sided!r} and {n_both!r}")
    if layout not in _LAYOUTS:
        raise CSMFormatError(f"{path}: unknown view layout {layout!r}")
    if odt != _offsets_dtype(S).newbyteorder("<").str:      # what save writes for S segments
        raise CSMFormatError(f"{path}: offsets dtype {odt!r} for {S} segments (pyshadow writes "
                             f"{_offsets_dtype(S).newbyteorder('<').str!r})")
    if len(centre) != 3 or not all(_number(x) for x in centre):
        raise CSMFormatError(f"{path}: centre must be 3 finite numbers within float32's range")
    if not (_number(radius) and radius > 0 and 1.0 / radius <= FLOAT32_MAX):    # the kernels take 1 / radius
        raise CSMFormatError(f"{path}: radius must be positive and finite, it and its reciprocal within float32's "
                             f"range (at least {1.0 / FLOAT32_MAX:.3g}), got {radius}")
    seconds = head.get("build_seconds")
    if not (seconds is None or _number(seconds, 0.0)):
        raise CSMFormatError(f"{path}: build_seconds must be a number >= 0 or null, got {seconds!r}")
    try:
        if layout == "zigzag":
            # row_offset: absent in files of the thesis's grid (0)
            off = params.get("row_offset", 0.0)
            if isinstance(off, bool) or not isinstance(off, (int, float)) or off not in ZIGZAG_ROW_OFFSETS:
                raise CSMFormatError(f"{path}: zigzag row_offset must be 0 or 0.5, got {off!r}")
            ok = set(params) - {"row_offset"} == {"theta", "phi"} and all(
                _integer(params[k]) and 1 <= params[k] <= 1 << 16 for k in ("theta", "phi"))
        else:
            # hemispheres false: as save wrote a ViewSet given {"level": k, "hemispheres": False} before file_params
            ok = (set(params) in ({"level"}, {"level", "hemispheres"})
                  and _integer(params["level"]) and 0 <= params["level"] <= 10
                  and isinstance(params.get("hemispheres", True), bool))
        if not ok:
            raise ValueError
    except (ValueError, KeyError, TypeError):
        raise CSMFormatError(f"{path}: invalid {layout} parameters {params!r}") from None
    # the layout's map count from its parameters, and the sizes against the
    # file's, before anything as large as the header claims is built
    layout_maps = ViewSet.maps_for(layout, params)
    if layout_maps != D:
        raise CSMFormatError(f"{path}: {D} maps in the header but the {layout} layout has {layout_maps}")
    if D > MAX_MAPS:
        raise CSMFormatError(f"{path}: {D} maps, beyond the {MAX_MAPS} of the largest view set")
    if S < R * R:
        raise CSMFormatError(f"{path}: {S} segments for {R * R} texels (every texel needs one)")
    if S > D * R * R or S > 2**40:      # a run of maps per segment: fewer segments than maps is common
        raise CSMFormatError(f"{path}: {S} segments for {D} maps of {R * R} texels (at most one per map "
                             "and texel)")
    return {"R": R, "D": D, "S": S, "bits": bits, "rule": rule, "layout": layout, "params": params,
            "centre": centre, "radius": radius, "mesh_hash": mh, "offsets_dtype": odt, "margin": margin,
            "footprint": footprint, "box": box, "two_sided": two_sided, "both_sided_faces": n_both,
            "seconds": seconds}


def _from_header(cls, path, head, start, raw):
    v = _header_values(path, head)
    R, D, S, bits, layout, params, odt, seconds = (v[k] for k in ("R", "D", "S", "bits", "layout", "params",
                                                                    "offsets_dtype", "seconds"))
    arrays, end = array_layout(start, R, D, S, bits, odt)
    if end + 32 != (size := len(raw)):
        raise CSMFormatError(f"{path}: size {size} bytes does not match the header ({end + 32} expected from "
                             f"resolution {R}, maps {D}, segments {S}, depth_bits {bits}): a truncated or "
                             "padded array, or one of these fields wrong")
    views = ViewSet.from_params(layout, params)
    data = {name: raw[off:off + dt.itemsize * n].view(dt) for name, dt, n, off in arrays}
    _validate_arrays(path, data, R, D, S, bits)
    return cls(views=views, resolution=R, depth_bits=bits, layer_rule=v["rule"],
               centre=np.array(v["centre"], dtype=np.float64), radius=float(v["radius"]), mesh_hash=v["mesh_hash"],
               offsets=data["offsets"], iend=data["iend"], depth=data["depth"],
               build_seconds=float("nan") if seconds is None else seconds, front_margin_texels=v["margin"],
               footprint=v["footprint"], box=v["box"], two_sided=v["two_sided"], both_sided_faces=v["both_sided_faces"])


def _validate_arrays(path, data, R, D, S, bits):
    """:func:`.file_checks.check_arrays` on a file's ``data`` (``offsets``, ``iend``, ``depth``) of ``S`` segments."""
    if len(data["depth"]) != S:
        raise CSMFormatError(f"{path}: {len(data['depth'])} depths for {S} segments")
    check_arrays(path, data["offsets"], data["iend"], data["depth"], R, D, bits)

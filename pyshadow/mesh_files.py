"""Reading mesh files for :func:`pyshadow.load_mesh`: trimesh's readers, with OBJ text they misread made plain.

trimesh's OBJ reader resolves a negative (relative) index against the *whole* file's vertices instead of those
read so far (OBJ's rule): an object whose faces say ``f -4 -3 -2 -1`` before the next object's ``v`` lines was
given that object's vertices. It reads no vertex from a ``v`` line indented or separated from its numbers by a
tab, nor from a first line after UTF-8's byte order mark, fails on a comment at the end of a data line
(``f 1 2 3 # lid``), and takes an index 0 (a file written counting from 0) for the last vertex: such a file is
refused; :func:`obj_text` rewrites the others with absolute indices, single spaces and no comments on data
lines before trimesh reads them (a comment only where trimesh fails on the file as it is); any other file is
read as it is, byte for byte. trimesh splits every polygon into a fan from its first corner, which covers
ground outside a concave polygon (an L-shaped floor, a dart-shaped quad): :func:`obj_polygons` splits each
concave face of 4 or more corners into triangles that tile it (ear clipping; convex faces keep the fan).

trimesh's binary PLY reader takes every face to have as many corners as the first one, so a binary PLY of
triangles and quads (Blender writes its n-gons so) failed ("PLY is unexpected length!"). Where it fails on a
binary PLY, :func:`ply_ascii` turns the file into the same PLY in ASCII, which trimesh reads with faces of any
size (every number written so it reads back to the same bits), also where the sizes add up and trimesh misread
it. PLY and OFF polygons were fanned as OBJ's, PLY face colours not split with their polygons (IndexError),
an OFF of pentagons beside triangles failed, and an OFF comment after data shifted the lines after it:
:func:`ply_polygons` and :func:`off_text` rewrite such files (concave quads too: an OFF's, and a PLY's also where
trimesh reads it as it is, triangles and quads without colours, whose concave quads it fanned over ground outside
them). A binary STL whose facet count is not its
length's (0, as some CAD exporters write) "held no geometry" (read now); an ASCII STL cut short is refused.
glTF files are read by :mod:`pyshadow.gltf_files`. An empty file is refused as such.
"""
from __future__ import annotations

import io
import itertools
import re
import struct
import warnings
from pathlib import Path

import numpy as np
import trimesh

from .gltf_files import _gltf_head, _gltf_json, check_gltf, read_gltf

__all__ = ["read_mesh_file", "obj_text", "obj_polygons", "ply_ascii", "ply_polygons", "off_text", "check_gltf"]
_GLTF_HELPERS = (_gltf_head, _gltf_json)        # moved to gltf_files, still importable from here

# an element line holding a negative index, or a data line indented or with a tab after its keyword
# (a false alarm only costs the rewrite, which changes nothing then); searched in "\n" + text: a literal
# first character is found fast where "^" of multi-line mode is tried at every byte
_UNUSUAL = re.compile(rb"\n(?:[fpl][ \t][^\n-]*-|[ \t]+(?:v|vt|vn|f|l|p)[ \t]|(?:v|vt|vn|f|l|p)\t)")
_POLYGON = re.compile(rb"\nf(?:[ \t]++[^ \t\r\n#]++){5}[^\n]*")        # a face of 5 or more corners
# a face of exactly 4 corners with positive indices (its vertex numbers captured)
_QUAD = re.compile(rb"\nf" + rb"[ \t]++(\d++)[^ \t\r\n#]*+" * 4 + rb"[ \t\r]*+(?:#[^\n]*)?(?=\n|\Z)")
_VERTEX = re.compile(rb"\nv[ \t]+([^ \t\r\n#]+)[ \t]+([^ \t\r\n#]+)[ \t]+([^ \t\r\n#]+)")
_COUNTED = {b"v": 0, b"vt": 1, b"vn": 2}
_ELEMENTS = (b"f", b"l", b"p")
_STL_SOLID = re.compile(rb"\n[ \t]*(end)?solid", re.IGNORECASE)     # an ASCII STL's solid begins or ends
_ZERO = re.compile(rb"\n[fpl][ \t][^\n#0]*+(?:0[^\n#0]*+)*?(?<![^ \t/])0+(?![^ \t/\r\n#])")    # an index 0
_BOM = b"\xef\xbb\xbf"                   # UTF-8's byte order mark, which some Windows programs write first


def obj_text(data: bytes, label: str = "OBJ", *, force: bool = False) -> bytes | None:
    """OBJ text with absolute indices and plain data lines, or None where ``data`` needs no change.

    Parameters
    ----------
    data : bytes
        An OBJ file's contents.
    label : str
        Names the file in errors.
    force : bool
        Rewrite whatever the text holds (trailing comments of data lines are only looked for then).

    Returns
    -------
    bytes or None
        ``data`` with every negative index ``-k`` of an ``f``, ``l`` or ``p`` line replaced by the absolute
        index it means (the ``k``-th last ``v``, ``vt`` or ``vn`` before that line), continued lines joined,
        and the lines of vertices and elements unindented, with single spaces and no comment; None where no
        line has a negative index, an indent or a tab after its keyword and ``force`` is False, or where the
        rewrite changes nothing (the file is read as it is).

    Raises
    ------
    ValueError
        A negative index reaches before the first vertex (the line is named).
    """
    if not (force or _UNUSUAL.search(b"\n" + data)):
        return None
    joined = data.replace(b"\\\r\n", b" ").replace(b"\\\n", b" ")
    counts = [0, 0, 0]
    out = []
    for number, line in enumerate(joined.splitlines(), 1):
        words = line.split(b"#", 1)[0].split()
        key = words[0] if words else b""
        if key in _COUNTED:
            counts[_COUNTED[key]] += 1
        elif key in _ELEMENTS:
            words = [key] + [_absolute(w, counts, label, number) for w in words[1:]]
        else:
            out.append(line.lstrip())
            continue
        out.append(b" ".join(words))
    text = b"\n".join(out) + b"\n"
    return None if text == data else text


def obj_polygons(text: bytes) -> bytes | None:
    """OBJ text with each concave face of 4 or more corners split into triangles that tile it, or None.

    Parameters
    ----------
    text : bytes
        OBJ text with absolute indices (:func:`obj_text`'s, or a file's that it leaves as it is).

    Returns
    -------
    bytes or None
        ``text`` with every such ``f`` line whose fan from its first corner (trimesh's split) covers ground
        outside it replaced by ``f`` lines of the triangles of an ear clipping, each corner with its own ``vt``
        and ``vn``; None where no face needs it (the text is read as it is). Convex faces, faces crossing
        themselves and faces whose corners are not known (an index that is not a number) keep the fan.
    """
    body = b"\n" + text
    quads = _QUAD.findall(body)                     # (C speed: files of quads are large)
    if not quads and not _POLYGON.search(body):
        return None
    faces = [(m.start() + 1, m.end(), m.group()[1:].split(b"#", 1)[0].split()[1:]) for m in _POLYGON.finditer(body)]
    try:
        index = [[int(c.split(b"/", 1)[0]) - 1 for c in corners] for _, _, corners in faces]
        words = _VERTEX.findall(body)               # x, y, z of each v line
        if len(words) != body.count(b"\nv ") + body.count(b"\nv\t") or index and (
                min(min(face) for face in index) < 0 or max(max(face) for face in index) >= len(words)):
            return None                             # a v line of fewer numbers, an index of no vertex
        xyz = np.fromiter(map(float, itertools.chain.from_iterable(words)), np.float64, 3 * len(words))
        # digits only (an index beyond int64 reads as its largest value: no vertex)
        quad = np.fromstring(b" ".join(itertools.chain.from_iterable(quads)), np.int64, sep=" ").reshape(-1, 4) - 1
    except ValueError:                              # an index or a coordinate that is no number
        return None
    xyz = xyz.reshape(-1, 3)
    concave = [faces[k] + (index[k],) for k in _concave(index, xyz)]
    if len(quad) and quad.min() >= 0 and quad.max() < len(xyz):       # else: an index of no vertex, left as it is
        flips = set(_fan_flips(xyz[quad]).tolist())
        if flips:
            concave += [(m.start() + 1, m.end(), m.group()[1:].split(b"#", 1)[0].split()[1:], quad[k])
                        for k, m in enumerate(_QUAD.finditer(body)) if k in flips]
    pieces, done = [], 0
    for start, end, corners, face in sorted(concave, key=lambda c: c[0]):
        tiles = _ears(_plane(xyz[face]))
        if tiles is not None:
            pieces += [body[done:start], b"\n".join(b"f " + b" ".join(corners[j] for j in tri) for tri in tiles)]
            done = end
    return None if not pieces else b"".join(pieces + [body[done:]])[1:]


def _plane(p: np.ndarray) -> np.ndarray:
    """The corners ``p`` (..., n, 3) of faces in 2D, counter-clockwise: the coordinates across the largest
    component of the Newell normal (corner 0 moved to the origin), the second negated where it is negative."""
    p = p - p[..., :1, :]
    normal = np.cross(p, np.roll(p, -1, axis=-2)).sum(axis=-2)
    axis = np.argmax(np.abs(normal), axis=-1)
    u = np.take_along_axis(p, ((axis + 1) % 3)[..., None, None], axis=-1)[..., 0]
    v = np.take_along_axis(p, ((axis + 2) % 3)[..., None, None], axis=-1)[..., 0]
    sign = np.where(np.take_along_axis(normal, axis[..., None], axis=-1) < 0, -1.0, 1.0)
    return np.stack([u, sign * v], axis=-1)


def _concave(index: list, xyz: np.ndarray) -> list:
    """Numbers of the faces (corner lists ``index`` into ``xyz``) whose fan from corner 0 does not tile them:
    a fan triangle turns against the face (faces of each corner count at once)."""
    out = []
    for n in sorted({len(face) for face in index}):
        which = [k for k, face in enumerate(index) if len(face) == n]
        out += [which[k] for k in _fan_flips(xyz[np.array([index[k] for k in which])])]
    return sorted(out)


def _fan_flips(p: np.ndarray) -> np.ndarray:
    """Numbers of the faces of corners ``p`` (F, n, 3) that a fan from corner 0 does not tile (:func:`_concave`)."""
    if p.shape[1] == 4:
        return _quad_flips(p)
    with np.errstate(invalid="ignore", over="ignore"):
        q = _plane(p)
        fan = q[:, 1:-1, 0] * q[:, 2:, 1] - q[:, 1:-1, 1] * q[:, 2:, 0]
        bad = fan.min(axis=1) < -1e-12 * np.abs(fan).sum(axis=1)
    return np.flatnonzero(bad & np.isfinite(fan).all(axis=1))


def _quad_flips(p: np.ndarray) -> np.ndarray:
    """:func:`_fan_flips` of quads (F, 4, 3) without :func:`_plane`'s arrays (files of quads are large): the fan's
    normals ``n_1, n_2`` (their sum the Newell normal) along its largest component."""
    e1, e2, e3 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0], p[:, 3] - p[:, 0]
    with np.errstate(invalid="ignore", over="ignore"):
        n1, n2 = np.cross(e1, e2), np.cross(e2, e3)
        s = n1 + n2
        ax = np.argmax(np.abs(s), axis=1)[:, None]
        sign = np.where(np.take_along_axis(s, ax, axis=1) < 0, -1.0, 1.0)
        f1, f2 = np.take_along_axis(n1, ax, axis=1) * sign, np.take_along_axis(n2, ax, axis=1) * sign
        bad = np.minimum(f1, f2) < -1e-12 * (np.abs(f1) + np.abs(f2))
    return np.flatnonzero(bad & np.isfinite(f1) & np.isfinite(f2))


def _ears(q: np.ndarray):
    """Ear clipping of the counter-clockwise polygon ``q`` (n, 2): n - 2 triangles (corner numbers), or None
    where no ear is found (a polygon crossing itself)."""
    q = q.tolist()

    def cross(a, b, c):
        return (q[b][0] - q[a][0]) * (q[c][1] - q[a][1]) - (q[b][1] - q[a][1]) * (q[c][0] - q[a][0])

    left, tiles = list(range(len(q))), []
    while len(left) > 3:
        for k in range(len(left)):
            a, b, c = left[k - 1], left[k], left[(k + 1) % len(left)]
            if cross(a, b, c) > 0.0 and not any(
                    cross(a, b, j) >= 0.0 and cross(b, c, j) >= 0.0 and cross(c, a, j) >= 0.0
                    for j in left if j not in (a, b, c)):
                tiles.append((a, b, c))
                del left[k]
                break
        else:
            return None
    return tiles + [tuple(left)]


def _absolute(word: bytes, counts, label: str, number: int) -> bytes:
    """One corner ``v/vt/vn`` of an element with its negative indices made absolute (1-based)."""
    if b"-" not in word:
        return word
    parts = word.split(b"/")
    for k, part in enumerate(parts[:3]):
        if part.startswith(b"-"):
            try:
                index = counts[k] + 1 + int(part)
            except ValueError:
                continue                        # not a number: left for trimesh to judge
            if index < 1:
                raise ValueError(f"{label}: line {number}: index {part.decode()} reaches before the first of "
                                 f"the {counts[k]} {('v', 'vt', 'vn')[k]} lines read so far")
            parts[k] = str(index).encode()
    return b"/".join(parts)


#: PLY scalar types -> struct codes (numpy's too)
_PLY_TYPES = {"char": "b", "int8": "b", "uchar": "B", "uint8": "B", "short": "h", "int16": "h", "ushort": "H",
              "uint16": "H", "int": "i", "int32": "i", "uint": "I", "uint32": "I", "float": "f", "float32": "f",
              "double": "d", "float64": "d"}
_PLY_COLOURS = ("red", "green", "blue", "alpha")        # an element has colours where 3 are its properties
_PLY_TEXT = {"b": "%d", "B": "%d", "h": "%d", "H": "%d", "i": "%d", "I": "%d", "f": "%.9g", "d": "%.17g"}


def _ply_header(data: bytes):
    """A PLY file's format, where its data start and its elements [(name, count, [(property, item code,
    list count code or None)])]; None where ``data`` is no PLY with a header it can read."""
    end = data.find(b"end_header")
    if not data.startswith(b"ply") or end < 0:
        return None
    start = data.find(b"\n", end) + 1
    words = [line.split() for line in data[:start].decode("ascii", "replace").splitlines()]
    form = next((w[1] for w in words if w[:1] == ["format"] and len(w) > 1), "")
    elements = []
    try:
        for w in words:
            if w[:1] == ["element"]:
                elements.append((w[1], int(w[2]), []))
            elif w[:1] == ["property"]:
                elements[-1][2].append((w[-1], _PLY_TYPES[w[3]], _PLY_TYPES[w[2]]) if w[1] == "list"
                                       else (w[2], _PLY_TYPES[w[1]], None))
    except (IndexError, KeyError, ValueError):
        return None
    return form, start, elements


def ply_ascii(data: bytes) -> bytes | None:
    """A binary PLY file's contents as the same PLY in ASCII, or None where ``data`` is no binary PLY.

    Parameters
    ----------
    data : bytes
        A PLY file's contents.

    Returns
    -------
    bytes or None
        The header with ``format ascii 1.0``, then one line per element: integers as they are, float32 with 9
        and float64 with 17 significant digits (they read back to the same bits). Lists may differ in length
        from element to element. None where the format is not binary or the data ends before the header's
        elements do.
    """
    head = _ply_header(data)
    if head is None or head[0] not in ("binary_little_endian", "binary_big_endian"):
        return None
    form, start, elements = head
    out, pos, order = [], start, "<" if form == "binary_little_endian" else ">"
    try:
        for _, count, props in elements:
            pos = _ply_element(data, pos, order, count, [(code, n) for _, code, n in props], out)
    except (ValueError, struct.error):
        return None
    return re.sub(rb"\nformat[ \t]+binary_\w+", b"\nformat ascii", data[:start], count=1) + "".join(out).encode("ascii")


def _ply_element(data: bytes, pos: int, order: str, count: int, props, out: list) -> int:
    """Append one element's rows as text to ``out``; return the position after them."""
    if all(n is None for _, n in props):                # fixed rows: at once
        dtype = np.dtype([(f"p{k}", order + code) for k, (code, _) in enumerate(props)])
        rows = np.frombuffer(data, dtype, count, pos)
        if count and props:
            text = io.StringIO()
            np.savetxt(text, rows, fmt=" ".join(_PLY_TEXT[code] for code, _ in props))
            out.append(text.getvalue())
        return pos + count * dtype.itemsize
    for _ in range(count):                          # lists of any length: row by row
        row = []
        for code, n_code in props:
            n = 1
            if n_code is not None:
                (n,) = struct.unpack_from(order + n_code, data, pos)
                pos += struct.calcsize(n_code)
                row.append(str(n))
            values = struct.unpack_from(f"{order}{n}{code}", data, pos)
            pos += n * struct.calcsize(code)
            row.extend(_PLY_TEXT[code] % v for v in values)
        out.append(" ".join(row) + "\n")
    return pos


def _tiled(index: list, xyz: np.ndarray) -> dict:
    """The ear clippings {face number: triangles (corner numbers)} of the faces (corner lists ``index`` into
    ``xyz`` (V, 3)) of 4 or more corners that a fan from corner 0 does not tile (as :func:`obj_polygons`)."""
    big = [k for k, face in enumerate(index) if len(face) >= 4]
    if not big or min(min(index[k]) for k in big) < 0 or max(max(index[k]) for k in big) >= len(xyz):
        return {}
    tiles = {big[k]: _ears(_plane(xyz[index[big[k]]])) for k in _concave([index[k] for k in big], xyz)}
    return {k: t for k, t in tiles.items() if t is not None}


def ply_polygons(text: bytes, split: bool = False) -> bytes | None:
    """An ASCII PLY with its faces split into triangles where trimesh's split would be wrong, or None.

    Parameters
    ----------
    text : bytes
        An ASCII PLY file's contents (:func:`ply_ascii`'s for a binary one).
    split : bool
        Split every face of 4 or more corners, as where faces have colours.

    Returns
    -------
    bytes or None
        ``text`` with each concave face of 4 or more corners replaced by rows of an ear clipping (as
        :func:`obj_polygons`), and, where faces have colours or ``split``, each of 4 or more corners by rows of
        a fan (where convex), those of under 3 dropped; each row keeps its face's properties (of a per-corner
        list such as ``texcoord``, its corners'). None where no face needs it.
    """
    head = _ply_header(text)
    if head is None or head[0] != "ascii":
        return None
    _, start, elements = head
    lines, rows, at = text[start:].splitlines(), {}, 0
    for name, count, props in elements:
        rows[name], at = (at, count, props), at + count
    if "vertex" not in rows or "face" not in rows:
        return None
    (v0, nv, vprops), (f0, nf, fprops) = rows["vertex"], rows["face"]
    names = [name for name, _, _ in vprops]
    lists = [k for k, (name, _, n) in enumerate(fprops) if n is not None]
    key = next((k for k in lists if fprops[k][0] in ("vertex_indices", "vertex_index")), lists[0] if lists else None)
    if key is None or any(n is not None for _, _, n in vprops) or not {"x", "y", "z"} <= set(names):
        return None
    try:
        xyz = np.array(b" ".join(lines[v0:v0 + nv]).split(), np.float64).reshape(nv, -1)[
            :, [names.index(c) for c in "xyz"]]
        spans, index = [], []                   # each face's words per property; its corners
        for line in lines[f0:f0 + nf]:
            words, span, at = line.split(), [], 0
            for _, _, n in fprops:
                size = 1 if n is None else int(words[at]) + 1
                span.append(words[at:at + size])
                at += size
            spans.append(span)
            index.append([int(w) for w in span[key][1:]])
    except (IndexError, ValueError):
        return None
    tiles = _tiled(index, xyz)
    split = (split or sum(c in [p[0] for p in fprops] for c in _PLY_COLOURS) > 2) and any(len(f) != 3 for f in index)
    if not (tiles or split):
        return None
    out = []
    for k, span in enumerate(spans):
        n = len(index[k])
        if not (k in tiles or split and n != 3):
            out.append(b" ".join(itertools.chain.from_iterable(span)))
            continue
        for tri in tiles.get(k) or [(0, j, j + 1) for j in range(1, n - 1)]:
            row = []
            for p, words in enumerate(span):
                m = (len(words) - 1) // n if p in lists and n and (len(words) - 1) % n == 0 else 0
                row += [str(3 * m).encode()] + [w for c in tri for w in words[1 + m * c:1 + m * c + m]] if m else words
            out.append(b" ".join(row))
    header = re.sub(rb"(\nelement[ \t]+face[ \t]+)\d+", lambda h: h.group(1) + str(len(out)).encode(), text[:start],
                    count=1)
    return b"\n".join([header[:-1]] + lines[:f0] + out + lines[f0 + nf:]) + b"\n"


_OFF_POLYGON = re.compile(rb"\n[ \t]*(?:[5-9]|[1-9][0-9]+)(?:[ \t]+[0-9]+){5}")        # a line that may be one
_OFF_QUAD = re.compile(rb"\n[ \t]*4(?:[ \t]+[0-9]+){4}")                               # a line that may be a quad
_OFF_COUNTS = re.compile(rb"\A[ \t\r\n]*C?OFF[ \t\r\n]+([0-9]+)[ \t]+([0-9]+)[ \t]+[0-9]+[ \t\r]*\n")   # header, counts


def off_text(data: bytes) -> bytes | None:
    """OFF text without comments and with its faces of 5 or more corners and concave quads split, or None.

    Parameters
    ----------
    data : bytes
        An OFF file's contents.

    Returns
    -------
    bytes or None
        ``data`` without comments (``#`` to its line's end), each face of 5 or more corners and each quad that
        a fan from corner 0 would not tile replaced by lines of triangles with its colour: an ear clipping where
        a fan from corner 0 would not tile it (as :func:`obj_polygons`), else that fan (trimesh's). None where
        there is no comment and no such face, or the file does not read as OFF.
    """
    if b"#" not in data and not _OFF_POLYGON.search(b"\n" + data) and (
            not _OFF_QUAD.search(b"\n" + data) or _off_quads_tile(data)):
        return None
    text = "\n".join(line.split("#", 1)[0] for line in data.decode("utf-8", "replace").splitlines())
    key = re.search("COFF|OFF", text)
    if key is None:
        return None
    lines = [line.strip() for line in text[key.end():].splitlines() if line.strip()]
    try:
        counts = lines[0].split()
        nv, nf = int(counts[0]), int(counts[1])
        xyz = np.array([line.split()[:3] for line in lines[1:nv + 1]], np.float64).reshape(nv, 3)
        faces = [line.split() for line in lines[nv + 1:nv + nf + 1]]
        index = [[int(w) for w in face[1:int(face[0]) + 1]] for face in faces]
    except (IndexError, ValueError):
        return None
    most = max(map(len, index), default=0)
    tiles, out = _tiled(index, xyz) if most >= 4 else {}, []
    if b"#" not in data and most < 5 and not tiles:
        return None
    for k, face in enumerate(faces):
        n, tail = len(index[k]), face[len(index[k]) + 1:]
        out += [" ".join(["3"] + [face[1 + c] for c in tri] + tail) for tri in tiles.get(k) or [
            (0, j, j + 1) for j in range(1, n - 1)]] if n >= 5 or k in tiles else [" ".join(face)]
    counts[1] = str(len(out))
    body = [text[:key.end()], " ".join(counts)] + lines[1:nv + 1] + out + lines[nv + nf + 1:]
    return "\n".join(body).encode() + b"\n"


def _off_quads_tile(data: bytes) -> bool:
    """Does every quad of an OFF of quads (and nothing else: no colours, no blank lines) tile itself as trimesh
    fans it? Read by NumPy (files of quads are large); False where it is not such a file (:func:`off_text`
    reads it)."""
    head = _OFF_COUNTS.search(data)
    if head is None:
        return False
    nv, nf = int(head.group(1)), int(head.group(2))
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")         # numpy's "no data" warning: the shapes tell
            xyz = np.loadtxt(io.BytesIO(data[head.end():]), np.float64, max_rows=nv, ndmin=2)
            faces = np.loadtxt(io.BytesIO(data[head.end():]), np.int64, skiprows=nv, max_rows=nf, ndmin=2)
    except (ValueError, IndexError, OverflowError):
        return False
    if xyz.shape != (nv, 3) or faces.shape != (nf, 5) or not (faces[:, 0] == 4).all():
        return False
    quads = faces[:, 1:]
    return bool(quads.min(initial=0) >= 0 and quads.max(initial=-1) < nv and not len(_quad_flips(xyz[quads])))


def _stl_ended(data: bytes, label: str) -> None:
    """ValueError where an ASCII STL (as trimesh tells it from a binary one) has a ``solid`` without ``endsolid``
    (trimesh read no facet of it: a file cut short "held no geometry", or lost its last solid)."""
    if len(data) >= 84 and 84 + 50 * struct.unpack_from("<I", data, 80)[0] == len(data) or b"\0" in data:
        return
    ends = [bool(m.group(1)) for m in _STL_SOLID.finditer(b"\n" + data)]
    if len(ends) > 2 * sum(ends):
        raise ValueError(f"{label}: an ASCII STL with {len(ends) - sum(ends)} 'solid' but {sum(ends)} 'endsolid' "
                         "lines (cut short?)")


def _stl_binary(data: bytes, label: str) -> bytes | None:
    """A binary STL with the count of the 50-byte facets after its 84 bytes (the header's where they are no
    whole number: bytes after them left out), or None (ASCII, no facets); ValueError where it is cut short."""
    if len(data) <= 84 or b"\0" not in data and data.lstrip()[:5].lower() == b"solid":
        return None
    count, size = struct.unpack_from("<I", data, 80)[0], len(data) - 84
    count = size // 50 if size % 50 == 0 else count
    if not 0 < 50 * count <= size:
        raise ValueError(f"{label}: a binary STL whose header counts {count} facets ({50 * count} bytes) but "
                         f"which holds {size} bytes of facets (cut short?)")
    return data[:80] + struct.pack("<I", count) + data[84:84 + 50 * count]


def _ply_suspect(mesh) -> str:
    """Why trimesh's read of a PLY may be wrong: "misread" (binary lists not all as long as the first, as trimesh
    takes them), "split" (faces of 5+ corners, of 4 with colours, or a concave quad: :func:`ply_polygons`), or ""."""
    face = ((getattr(mesh, "metadata", None) or {}).get("_ply_raw") or {}).get("face") or {}
    data, props = face.get("data"), face.get("properties") or {}
    lists = [name for name, dtype in props.items() if "," in dtype]
    name = next((k for k in lists if k in ("vertex_indices", "vertex_index")), lists[0] if lists else None)
    try:
        column = data[name]
        if isinstance(data, np.ndarray) and data.dtype.names:
            if (column["f0"] != column["f1"].shape[1]).any():
                return "misread"
            column = column["f1"]
        most = column.shape[1] if column.ndim == 2 else max(map(len, column), default=0)
        # a concave quad (a dart) trimesh fans from corner 0 over ground outside it (area 3 for 1)
        quads = column if column.ndim == 2 else np.array([f for f in column if len(f) == 4], np.int64)
        concave = most == 4 and np.shape(quads)[1:] == (4,) and 0 <= quads.min() and quads.max() < len(mesh.vertices) \
            and len(_quad_flips(np.asarray(mesh.vertices, np.float64)[quads]))
    except (KeyError, TypeError, ValueError, IndexError, AttributeError):
        return ""
    return "split" if most >= 5 or most >= 4 and sum(c in props for c in _PLY_COLOURS) > 2 or concave else ""


def _read_ply(path: Path | None, data: bytes | None = None):
    """What trimesh reads from the PLY file ``path`` (or its contents ``data``: ``path`` None), where needed from
    :func:`ply_ascii`'s, ply_polygons' text (an ASCII PLY trimesh fails on with every polygon split: it failed on
    ``texcoord`` lists of triangles and quads)."""
    try:
        mesh = trimesh.load(str(path) if data is None else io.BytesIO(data), file_type="ply", process=False)
        why, error = _ply_suspect(mesh), None
        if not why:
            return mesh
    except Exception as exc:                    # faces of several sizes in a binary PLY: read as ASCII
        mesh, why, error = None, "misread", exc
    data = path.read_bytes() if data is None else data
    text = ply_ascii(data)
    if text is None and mesh is None and (text := ply_polygons(data, split=True)) is None:
        raise error
    fixed = ply_polygons(text or data)
    if fixed is None and (text is None or why != "misread"):
        return mesh
    return trimesh.load(io.BytesIO(fixed or text), file_type="ply", process=False,
                        resolver=None if path is None else trimesh.resolvers.FilePathResolver(str(path)))


def read_mesh_file(path: Path, label: str):
    """What trimesh reads from the file ``path`` (no processing); OBJ text made plain first (:func:`obj_text`),
    a binary PLY trimesh cannot read read as ASCII (:func:`ply_ascii`).

    Raises ValueError naming ``label`` where the format is unknown or the file cannot be parsed.
    """
    try:
        if path.stat().st_size == 0:            # (was "could not be read" for a reason of the parser's)
            raise ValueError(f"{label}: the file is empty (0 bytes: an empty mesh)")
        if path.suffix.lower() == ".ply":
            return _read_ply(path)
        if path.suffix.lower() == ".off":
            fixed = off_text(path.read_bytes())
            if fixed is not None:
                return trimesh.load(io.BytesIO(fixed), file_type="off", process=False)
        if path.suffix.lower() == ".stl":
            mesh, data = trimesh.load(str(path), process=False), path.read_bytes()
            _stl_ended(data, label)
            fixed = _stl_binary(data, label) if isinstance(mesh, trimesh.Scene) and not mesh.geometry else None
            return mesh if fixed is None else trimesh.load(io.BytesIO(fixed), file_type="stl", process=False)
        if path.suffix.lower() in (".glb", ".gltf"):
            return read_gltf(path, label)
        if path.suffix.lower() != ".obj":
            return trimesh.load(str(path), process=False)
        data = path.read_bytes()
        bom = data.startswith(_BOM)         # trimesh read no vertex from a first line "\ufeffv 1 2 3"
        data = data[len(_BOM):] if bom else data
        zero = _ZERO.search(b"\n" + data)     # (trimesh took 0 for -1, the last vertex: a box's area read 5.83)
        if zero:
            at, line = zero.start(), data[zero.start():].split(b"\n", 1)[0].strip().decode("utf-8", "replace")
            raise ValueError(f"{label}: line {data.count(bytes([10]), 0, at) + 1} ({line[:60]!r}) has index 0, "
                             "which OBJ has not: it counts from 1 (was the file written counting from 0?)")
        fixed = obj_text(data, label)
        fixed = obj_polygons(data if fixed is None else fixed) or fixed or (data if bom else None)
        if fixed is None:
            try:
                return trimesh.load(str(path), process=False)
            except Exception:                   # a comment after a face, say: read once more without them
                fixed = obj_text(data, label, force=True)
                if fixed is None:
                    raise
                fixed = obj_polygons(fixed) or fixed
        return trimesh.load(io.BytesIO(fixed), file_type="obj", process=False,
                            resolver=trimesh.resolvers.FilePathResolver(str(path)))
    except (NotImplementedError, KeyError) as exc:
        if path.suffix.lower() in (".obj", ".ply", ".stl", ".off", ".glb", ".gltf"):   # (a glTF without POSITION)
            raise ValueError(f"{label}: could not be read as a mesh (no {exc} where the file needs one)") from exc
        raise ValueError(f"{label}: unknown or unsupported mesh format {path.suffix!r} ({exc})") from exc
    except ValueError as exc:
        if str(exc).startswith(label):
            raise
        raise ValueError(f"{label}: could not be read as a mesh ({exc})") from exc
    except Exception as exc:  # parsers raise anything on garbage input
        raise ValueError(f"{label}: could not be read as a mesh ({exc})") from exc

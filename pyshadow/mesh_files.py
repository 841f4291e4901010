"""Reading mesh files for :func:`pyshadow.load_mesh`: trimesh's readers, with OBJ text they misread made plain.

trimesh's OBJ reader resolves a negative (relative) index against the *whole*
file's vertices instead of those read so far (OBJ's rule), so an object whose
faces say ``f -4 -3 -2 -1`` before the next object's ``v`` lines was given
that object's vertices: a two-object file lost its first object without a
word. It also reads no vertex from a ``v`` line indented or separated from its
numbers by a tab (the file "held no geometry"), and fails on a comment at the
end of a data line (``f 1 2 3 # lid``). :func:`obj_text` rewrites such text
with absolute indices, single spaces and no comments on data lines before
trimesh reads it (a comment only where trimesh fails on the file as it is);
any other file is read as it is, byte for byte. trimesh also splits every
polygon into a fan from its first corner, which covers ground outside a
concave polygon (an L-shaped floor): :func:`obj_polygons` splits each
concave face of 5 or more corners into triangles that tile it (ear clipping;
convex faces and quads keep trimesh's fan).

trimesh's binary PLY reader takes every face to have as many corners as the
first one, so a binary PLY of triangles and quads (Blender writes its
n-gons so) failed ("PLY is unexpected length!"). Where it fails on a binary
PLY, :func:`ply_ascii` turns the file into the same PLY in ASCII, which
trimesh reads with faces of any size (every number written so it reads back
to the same bits).

trimesh reads a glTF whose geometry it cannot decode wrongly or fails on it
unclearly: a Draco-compressed mesh without DracoPy was read as zeros ("every
face is degenerate"), normalised integer positions (``KHR_mesh_quantization``)
as the integers (32767 times too large for int16), sparse positions without
their sparse values, a triangle-fan primitive was left out, and a
meshopt-compressed file failed with "list index out of range".
:func:`check_gltf` refuses such a file first, saying why.
"""
from __future__ import annotations

import importlib.util
import io
import itertools
import json
import re
import struct
from pathlib import Path

import numpy as np
import trimesh

__all__ = ["read_mesh_file", "obj_text", "obj_polygons", "ply_ascii", "check_gltf"]

# an element line holding a negative index, or a data line indented or with a tab after its keyword
# (a false alarm only costs the rewrite, which changes nothing then); searched in "\n" + text: a literal
# first character is found fast where "^" of multi-line mode is tried at every byte
_UNUSUAL = re.compile(rb"\n(?:[fpl][ \t][^\n-]*-|[ \t]+(?:v|vt|vn|f|l|p)[ \t]|(?:v|vt|vn|f|l|p)\t)")
_POLYGON = re.compile(rb"\nf(?:[ \t]++[^ \t\r\n#]++){5}[^\n]*")        # a face of 5 or more corners
_VERTEX = re.compile(rb"\nv[ \t]+([^ \t\r\n#]+)[ \t]+([^ \t\r\n#]+)[ \t]+([^ \t\r\n#]+)")
_COUNTED = {b"v": 0, b"vt": 1, b"vn": 2}
_ELEMENTS = (b"f", b"l", b"p")


def obj_text(data: bytes, label: str = "OBJ", *, force: bool = False) -> bytes | None:
    """OBJ text with absolute indices and plain data lines, or None where ``data`` needs no change.

    Parameters
    ----------
    data : bytes
        An OBJ file's contents.
    label : str
        Names the file in errors.
    force : bool
        Rewrite whatever the text holds (trailing comments of data lines are
        only looked for then).

    Returns
    -------
    bytes or None
        ``data`` with every negative index ``-k`` of an ``f``, ``l`` or ``p``
        line replaced by the absolute index it means (the ``k``-th last
        ``v``, ``vt`` or ``vn`` before that line), continued lines joined, and
        the lines of vertices and elements unindented, with single spaces and
        no comment;
        None where no line has a negative index, an indent or a tab after its
        keyword and ``force`` is False, or where the rewrite changes nothing
        (the file is read as it is).

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
    """OBJ text with each concave face of 5 or more corners split into triangles that tile it, or None.

    Parameters
    ----------
    text : bytes
        OBJ text with absolute indices (:func:`obj_text`'s, or a file's that
        it leaves as it is).

    Returns
    -------
    bytes or None
        ``text`` with every such ``f`` line whose fan from its first corner
        (trimesh's split) covers ground outside it replaced by ``f`` lines of
        the triangles of an ear clipping, each corner with its own ``vt``
        and ``vn``; None where no face needs it (the text is read as it is).
        Convex faces, quads, faces crossing themselves and faces whose
        corners are not known (an index that is not a number) keep the fan.
    """
    body = b"\n" + text
    if not _POLYGON.search(body):
        return None
    faces = [(m.start() + 1, m.end(), m.group()[1:].split(b"#", 1)[0].split()[1:]) for m in _POLYGON.finditer(body)]
    try:
        index = [[int(c.split(b"/", 1)[0]) - 1 for c in corners] for _, _, corners in faces]
        words = _VERTEX.findall(body)               # x, y, z of each v line (C speed: files are large)
        if len(words) != body.count(b"\nv ") + body.count(b"\nv\t") or \
                min(min(face) for face in index) < 0 or max(max(face) for face in index) >= len(words):
            return None                             # a v line of fewer numbers, an index of no vertex
        xyz = np.fromiter(map(float, itertools.chain.from_iterable(words)), np.float64, 3 * len(words))
    except ValueError:                              # an index or a coordinate that is no number
        return None
    xyz = xyz.reshape(-1, 3)
    concave = _concave(index, xyz)
    pieces, done = [], 0
    for k in concave:
        start, end, corners = faces[k]
        tiles = _ears(_plane(xyz[index[k]]))
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
        with np.errstate(invalid="ignore", over="ignore"):
            q = _plane(xyz[np.array([index[k] for k in which])])
            fan = q[:, 1:-1, 0] * q[:, 2:, 1] - q[:, 1:-1, 1] * q[:, 2:, 0]
            bad = fan.min(axis=1) < -1e-12 * np.abs(fan).sum(axis=1)
        out += [which[k] for k in np.flatnonzero(bad & np.isfinite(fan).all(axis=1))]
    return sorted(out)


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
_PLY_TEXT = {"b": "%d", "B": "%d", "h": "%d", "H": "%d", "i": "%d", "I": "%d", "f": "%.9g", "d": "%.17g"}


def ply_ascii(data: bytes) -> bytes | None:
    """A binary PLY file's contents as the same PLY in ASCII, or None where ``data`` is no binary PLY.

    Parameters
    ----------
    data : bytes
        A PLY file's contents.

    Returns
    -------
    bytes or None
        The header with ``format ascii 1.0``, then one line per element:
        integers as they are, float32 with 9 and float64 with 17 significant
        digits (they read back to the same bits). Lists may differ in length
        from element to element. None where the format is not binary or the
        data ends before the header's elements do.
    """
    end = data.find(b"end_header")
    if not data.startswith(b"ply") or end < 0:
        return None
    start = data.find(b"\n", end) + 1
    head = data[:start].decode("ascii", "replace").splitlines()
    words = [line.split() for line in head]
    form = next((w[1] for w in words if w[:1] == ["format"] and len(w) > 1), "")
    if form not in ("binary_little_endian", "binary_big_endian"):
        return None
    order = "<" if form == "binary_little_endian" else ">"
    elements = []                               # (count, [(item code, list count code or None)])
    try:
        for w in words:
            if w[:1] == ["element"]:
                elements.append((int(w[2]), []))
            elif w[:1] == ["property"]:
                elements[-1][1].append((_PLY_TYPES[w[3]], _PLY_TYPES[w[2]]) if w[1] == "list"
                                       else (_PLY_TYPES[w[1]], None))
        out = ["\n".join("format ascii 1.0" if w[:1] == ["format"] else line
                         for w, line in zip(words, head)) + "\n"]
        pos = start
        for count, props in elements:
            pos = _ply_element(data, pos, order, count, props, out)
    except (IndexError, KeyError, ValueError, struct.error):
        return None
    return "".join(out).encode("ascii")


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


def _gltf_json(data: bytes):
    """The JSON of a GLB's first chunk or of a ``.gltf`` file, or None where there is none to read."""
    try:
        if data[:4] == b"glTF":
            length, kind = struct.unpack_from("<II", data, 12)
            return json.loads(data[20:20 + length]) if kind == 0x4E4F534A else None
        return json.loads(data)
    except (ValueError, struct.error):
        return None


def _gltf_head(path: Path) -> bytes:
    """A GLB's header and JSON chunk (not its binary chunk), or a ``.gltf`` file's text."""
    with open(path, "rb") as fh:
        head = fh.read(20)
        if head[:4] != b"glTF" or len(head) < 20:
            return head + fh.read()
        return head + fh.read(struct.unpack_from("<I", head, 12)[0])


def check_gltf(data: bytes, label: str = "glTF") -> None:
    """Raise ValueError where a glTF's geometry is stored in a way trimesh reads wrongly.

    Parameters
    ----------
    data : bytes
        A ``.glb`` file's contents (its first chunk suffices) or a ``.gltf``
        file's text; anything else passes.
    label : str
        Names the file in the message.

    Raises
    ------
    ValueError
        A primitive is compressed with ``KHR_draco_mesh_compression`` and
        DracoPy is not installed (trimesh would read zeros); the file requires
        ``EXT_meshopt_compression`` or ``KHR_meshopt_compression`` (trimesh
        fails on them); a ``POSITION`` accessor is ``normalized`` integers
        (trimesh would not scale them); a primitive's positions or indices
        are a sparse accessor (trimesh ignores the sparse values); or a
        primitive is a triangle fan (mode 6, which trimesh leaves out).
    """
    tree = _gltf_json(data)
    if not isinstance(tree, dict):
        return
    prims = [p for m in tree.get("meshes") or [] if isinstance(m, dict)
             for p in m.get("primitives") or [] if isinstance(p, dict)]
    used = set(tree.get("extensionsRequired") or []) | {e for p in prims for e in p.get("extensions") or {}}
    if "KHR_draco_mesh_compression" in used and importlib.util.find_spec("DracoPy") is None:
        raise ValueError(f"{label}: its meshes are Draco-compressed (KHR_draco_mesh_compression), which trimesh "
                         "decodes only with DracoPy (pip install DracoPy); or export the file without Draco")
    meshopt = used & {"EXT_meshopt_compression", "KHR_meshopt_compression"}
    if meshopt:
        raise ValueError(f"{label}: it requires {sorted(meshopt)[0]}, which trimesh cannot decode; "
                         "export the file without meshopt compression (gltfpack: leave out -c/-cc)")
    accessors = tree.get("accessors") or []
    for p in prims:
        if p.get("mode") == 6:
            raise ValueError(f"{label}: a primitive is a triangle fan (mode 6), which trimesh leaves out; "
                             "export triangles")
        for k in ((p.get("attributes") or {}).get("POSITION"), p.get("indices")):
            acc = accessors[k] if isinstance(k, int) and 0 <= k < len(accessors) else None
            if isinstance(acc, dict) and acc.get("sparse"):
                raise ValueError(f"{label}: accessor {k} of a primitive's positions or indices is sparse, "
                                 "which trimesh reads without its sparse values; export dense accessors")
        k = (p.get("attributes") or {}).get("POSITION")
        if isinstance(k, int) and 0 <= k < len(accessors) and (accessors[k] or {}).get("normalized"):
            raise ValueError(f"{label}: its positions are normalized integers (accessor {k}, "
                             "KHR_mesh_quantization), which trimesh reads unscaled; export float positions "
                             "(gltfpack: -noq)")


def read_mesh_file(path: Path, label: str):
    """What trimesh reads from the file ``path`` (no processing); OBJ text made plain first (:func:`obj_text`),
    a binary PLY trimesh cannot read read as ASCII (:func:`ply_ascii`).

    Raises ValueError naming ``label`` where the format is unknown or the file cannot be parsed.
    """
    try:
        if path.suffix.lower() == ".ply":
            try:
                return trimesh.load(str(path), process=False)
            except Exception:                   # faces of several sizes in a binary PLY: read as ASCII
                text = ply_ascii(path.read_bytes())
                if text is None:
                    raise
            return trimesh.load(io.BytesIO(text), file_type="ply", process=False,
                                resolver=trimesh.resolvers.FilePathResolver(str(path)))
        if path.suffix.lower() in (".glb", ".gltf"):
            check_gltf(_gltf_head(path), label)
        if path.suffix.lower() != ".obj":
            return trimesh.load(str(path), process=False)
        data = path.read_bytes()
        fixed = obj_text(data, label)
        fixed = obj_polygons(data if fixed is None else fixed) or fixed
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
        raise ValueError(f"{label}: unknown or unsupported mesh format {path.suffix!r} ({exc})") from exc
    except ValueError as exc:
        if str(exc).startswith(label):
            raise
        raise ValueError(f"{label}: could not be read as a mesh ({exc})") from exc
    except Exception as exc:  # parsers raise anything on garbage input
        raise ValueError(f"{label}: could not be read as a mesh ({exc})") from exc

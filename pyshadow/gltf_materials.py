"""What a glTF file says about a primitive's colours that trimesh's reader does not keep (:mod:`pyshadow.materials`).

trimesh's glTF reader (a) turns the ``COLOR_0`` of a primitive without a
material into 8-bit colours, wrapping normalized unsigned shorts modulo 256
(0.61 became 0.25) and rounding floats; (b) reads UVs from ``TEXCOORD_0``
whatever set the base colour texture names (``texCoord``), and normalized
integer UVs (``KHR_mesh_quantization``) as their integers; (c) drops
``KHR_texture_transform`` and (d) the texture's sampler (wrap modes and
magnification filter). Where a file uses any of these, :func:`primitive_details`
reads them from the file the mesh came from (``mesh.source.file_path``),
for the primitive whose positions and faces are exactly the mesh's (a mesh
changed since, or one that is several primitives merged, is left as trimesh
read it).

trimesh's PLY reader likewise wraps 16-bit (``ushort``) colours modulo 256
(40000 became 64): :func:`ply_colours` reads them from the PLY elements
trimesh keeps in ``mesh.metadata["_ply_raw"]``.

Sampler: a tuple ``(wrap_s, wrap_t, nearest)`` of glTF's wrap codes
(:data:`REPEAT`, :data:`CLAMP_TO_EDGE`, :data:`MIRRORED_REPEAT`) and whether
the magnification filter is ``NEAREST`` (9728); :data:`DEFAULT_SAMPLER` is
glTF's default (repeat, linear). Minification filters are not used (a
surface point's colour is one sample, without mipmaps).
"""
from __future__ import annotations

import base64
import json
import os
import struct
from functools import lru_cache

import numpy as np

__all__ = ["REPEAT", "CLAMP_TO_EDGE", "MIRRORED_REPEAT", "DEFAULT_SAMPLER", "primitive_details", "sample",
           "ply_colours"]

REPEAT, CLAMP_TO_EDGE, MIRRORED_REPEAT = 10497, 33071, 33648
DEFAULT_SAMPLER = (REPEAT, REPEAT, False)
_NEAREST = 9728
_DTYPES = {5120: "<i1", 5121: "<u1", 5122: "<i2", 5123: "<u2", 5125: "<u4", 5126: "<f4"}
_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}


def sample(image, uv, sampler) -> np.ndarray:
    """Texels of an image at texture coordinates under a glTF sampler.

    Parameters
    ----------
    image : ndarray, shape (h, w, 3), float
        Linear RGB, row 0 at the top (``v = 1``).
    uv : ndarray, shape (N, 2), float64
        Texture coordinates, v up (``1 - v`` of glTF's); any values.
    sampler : tuple
        ``(wrap_s, wrap_t, nearest)`` (module docstring).

    Returns
    -------
    ndarray, shape (N, 3), float64
        Bilinear (or with ``nearest`` the nearest texel) over texel centres,
        each tap's index wrapped per axis as OpenGL wraps it: repeat
        (modulo), clamp to the edge texel, mirrored repeat (period of twice
        the size).
    """
    h, w = image.shape[:2]
    wrap_s, wrap_t, nearest = sampler
    x = _reduced(uv[:, 0], wrap_s) * w - 0.5
    y = (1.0 - _reduced(uv[:, 1], wrap_t)) * h - 0.5     # v is 1 - glTF's v: the same wrap of glTF's
    tap = (lambda i, j: image[_wrap(i, h, wrap_t), _wrap(j, w, wrap_s)].astype(np.float64))
    if nearest:
        return tap(np.floor(y + 0.5).astype(np.int64), np.floor(x + 0.5).astype(np.int64))
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    i0, j0 = y0.astype(np.int64), x0.astype(np.int64)
    return ((1 - fy) * ((1 - fx) * tap(i0, j0) + fx * tap(i0, j0 + 1))
            + fy * ((1 - fx) * tap(i0 + 1, j0) + fx * tap(i0 + 1, j0 + 1)))


def ply_colours(mesh, element: str, colours) -> np.ndarray:
    """A PLY's 16-bit colours where trimesh read them as ``colours`` (module docstring), else ``colours``.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        As trimesh's PLY reader returned it (``metadata["_ply_raw"]``).
    element : {"vertex", "face"}
        Whose colours.
    colours : ndarray, shape (n, 4), uint8
        trimesh's (``visual.vertex_colors`` or ``visual.face_colors``).

    Returns
    -------
    ndarray, shape (n, 3 or 4)
        The element's ``red``, ``green``, ``blue`` (``alpha``) as stored
        (uint16) where they are 16-bit and trimesh's ``colours`` are exactly
        them modulo 256 (the mesh as read); ``colours`` otherwise.
    """
    from trimesh.visual.color import to_rgba

    try:
        el = mesh.metadata["_ply_raw"][element]
        raw = np.column_stack([el["data"][k] for k in ("red", "green", "blue", "alpha") if k in el["properties"]])
    except (AttributeError, KeyError, TypeError, ValueError, IndexError):    # no PLY, or not as trimesh keeps it
        return colours
    if raw.dtype != np.uint16 or raw.shape[1] < 3 or not np.array_equal(to_rgba(raw.copy()), colours):
        return colours
    return raw


def _reduced(u, mode):
    """``u`` moved by whole periods of its wrap (1 for repeat, 2 for mirror; clamped to [0, 1] for clamp),
    which leaves the sample as it is and keeps the texel index small (exact in float64)."""
    if mode == CLAMP_TO_EDGE:
        return np.clip(u, 0.0, 1.0)
    return np.mod(u, 2.0 if mode == MIRRORED_REPEAT else 1.0)


def _wrap(i, n, mode):
    """Texel indices ``i`` wrapped into [0, n) by a glTF wrap mode (OpenGL's rule)."""
    if mode == CLAMP_TO_EDGE:
        return np.clip(i, 0, n - 1)
    if mode == MIRRORED_REPEAT:
        m = np.mod(i, 2 * n) - n
        return (n - 1) - np.where(m >= 0, m, -(1 + m))
    return np.mod(i, n)


def primitive_details(mesh) -> dict | None:
    """What the glTF file of ``mesh`` says beyond trimesh's reading of it (module docstring), or None.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        A mesh of trimesh's glTF reader, as read (``mesh.source.file_path``
        names its file).

    Returns
    -------
    dict or None
        None unless that file is a ``.glb``/``.gltf`` that uses a feature of
        the module docstring and exactly one kind of triangle primitive in it
        has the mesh's vertices and faces and a material trimesh could have
        read as the mesh's (name, 8-bit base colour factor, texture or
        none). Otherwise ``"colour_0"``: (V, 3 or 4) ``COLOR_0`` as stored
        (uint8, uint16 or float32) or None; ``"material"``: whether the
        primitive has one; ``"uv"``: (V, 2) float64, v up (``1 - v`` of
        glTF's), of the base colour texture's ``texCoord`` set (normalized
        integers over their maximum) with ``KHR_texture_transform``
        applied, or None where trimesh's (float ``TEXCOORD_0`` as it is)
        are those; ``"sampler"``: of the base colour texture.
    """
    path = _file_path(mesh)
    if path is None:
        return None
    try:
        stat = os.stat(path)
        doc = _document(path, stat.st_mtime_ns, stat.st_size)
        if doc is None:
            return None
        found = [_details(doc, p) for p in _find(doc, np.asarray(mesh.vertices), np.asarray(mesh.faces),
                                                  getattr(getattr(mesh, "visual", None), "material", None))]
    # a file that cannot be read here (or not as trimesh read it): trimesh's reading stays
    except (OSError, ValueError, KeyError, IndexError, TypeError, AttributeError, struct.error):
        return None
    if not found or any(not _same(found[0], d) for d in found[1:]):     # none, or several that differ
        return None
    return found[0]


def _same(a, b) -> bool:
    """Are two :func:`primitive_details` equal?"""
    return all(np.array_equal(a[k], b[k]) if isinstance(a[k], np.ndarray) else a[k] == b[k] for k in a)


def _file_path(mesh):
    """The path of the glTF file trimesh read ``mesh`` from, or None."""
    try:
        path = getattr(getattr(mesh, "source", None), "file_path", None)
    except Exception:       # an object whose source cannot be read names no file
        return None
    if not isinstance(path, str) or not path.lower().endswith((".glb", ".gltf")) or not os.path.isfile(path):
        return None
    return path


def _texture_info(tree, material):
    """(textureInfo dict of the base colour texture or {}, its KHR_texture_transform dict or {})."""
    mats = tree.get("materials") or []
    mat = mats[material] if isinstance(material, int) and 0 <= material < len(mats) else {}
    info = (mat.get("pbrMetallicRoughness") or {}).get("baseColorTexture") or {}
    return info, (info.get("extensions") or {}).get("KHR_texture_transform") or {}


def _sampler(tree, info) -> tuple:
    """The sampler tuple of a textureInfo."""
    textures = tree.get("textures") or []
    k = info.get("index")
    tex = textures[k] if isinstance(k, int) and 0 <= k < len(textures) else {}
    samplers = tree.get("samplers") or []
    s = tex.get("sampler")
    s = samplers[s] if isinstance(s, int) and 0 <= s < len(samplers) else {}
    modes = (REPEAT, CLAMP_TO_EDGE, MIRRORED_REPEAT)
    wrap = [m if m in modes else REPEAT for m in (s.get("wrapS", REPEAT), s.get("wrapT", REPEAT))]
    return wrap[0], wrap[1], s.get("magFilter") == _NEAREST


def _needed(tree) -> bool:
    """Does the glTF ``tree`` use anything trimesh's reader loses (module docstring)?"""
    accessors = tree.get("accessors") or []
    for m in tree.get("meshes") or []:
        for p in m.get("primitives") or []:
            k = (p.get("attributes") or {}).get("COLOR_0")
            if "material" not in p and isinstance(k, int) and accessors[k].get("componentType") != 5121:
                return True
            info, transform = _texture_info(tree, p.get("material"))
            quantised = any(accessors[k].get("componentType") != 5126 for a, k in (p.get("attributes") or {}).items()
                            if a.startswith("TEXCOORD_"))
            if info and (info.get("texCoord", 0) != 0 or transform or quantised
                         or _sampler(tree, info) != DEFAULT_SAMPLER):
                return True
    return False


@lru_cache(maxsize=1)
def _document(path, mtime_ns, size):
    """(JSON tree, buffers) of a glTF file that :func:`_needed`, else None; cached by path, time and size
    (the last file only: its buffers are as large as the file). Only the JSON is read of other files."""
    from .gltf_files import GltfResolver, _gltf_head

    head = _gltf_head(path)
    glb = head[:4] == b"glTF"
    tree = json.loads(head[20:] if glb else head)
    if not isinstance(tree, dict) or not _needed(tree):
        return None
    if glb:
        with open(path, "rb") as fh:
            fh.seek(len(head))
            chunk = fh.read(8)              # none: a GLB whose buffers are all files (or data:)
            n, kind = struct.unpack("<II", chunk) if len(chunk) == 8 else (0, 0)
            glb = fh.read(n) if kind == 0x004E4942 else None
    buffers = []
    for b in tree.get("buffers") or []:
        uri = b.get("uri")
        if uri is None:
            buffers.append(glb)
        elif uri.startswith("data:"):
            buffers.append(base64.b64decode(uri.split(",", 1)[1]))
        else:                                   # the file trimesh read (a percent-decoded name)
            buffers.append(GltfResolver(str(path)).get(uri))
    return tree, buffers


def _accessor(doc, k, normalise=False) -> np.ndarray:
    """Accessor ``k`` of a document as stored, (count, width); normalized integers over their maximum with
    ``normalise`` (as float64). Sparse accessors raise ValueError (not read here)."""
    tree, buffers = doc
    acc = tree["accessors"][k]
    if acc.get("sparse") or "bufferView" not in acc:
        raise ValueError("sparse or bufferless accessor")
    view = tree["bufferViews"][acc["bufferView"]]
    dtype = np.dtype(_DTYPES[acc["componentType"]])
    count, width = acc["count"], _WIDTH[acc["type"]]
    start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
    stride = view.get("byteStride") or width * dtype.itemsize
    raw = np.frombuffer(buffers[view["buffer"]], np.uint8)
    rows = np.lib.stride_tricks.as_strided(raw[start:], (count, width * dtype.itemsize), (stride, 1)) \
        if count else np.zeros((0, width * dtype.itemsize), np.uint8)
    if count and start + (count - 1) * stride + width * dtype.itemsize > len(raw):
        raise ValueError("accessor beyond its buffer")
    out = np.ascontiguousarray(rows).view(dtype).reshape(count, width)
    if normalise and acc.get("normalized") and dtype.kind in "iu":
        return np.maximum(out / float(np.iinfo(dtype).max), -1.0)
    return out


def _find(doc, vertices, faces, material) -> list:
    """The triangle primitives (dicts) whose positions and faces are exactly ``vertices`` and ``faces`` and whose
    material is one trimesh could have read as ``material`` (:func:`_like`)."""
    import trimesh

    tree = doc[0]
    found = []
    for m in tree.get("meshes") or []:
        for p in m.get("primitives") or []:
            mode = p.get("mode", 4)
            k = (p.get("attributes") or {}).get("POSITION")
            if mode not in (4, 5) or not isinstance(k, int) or tree["accessors"][k].get("count") != len(vertices):
                continue
            if "indices" in p:
                flat = _accessor(doc, p["indices"]).reshape(-1).astype(np.int64)
            else:
                flat = np.arange(len(vertices), dtype=np.int64)
            tri = trimesh.util.triangle_strips_to_faces([flat]) if mode == 5 else flat.reshape(-1, 3)
            if np.array_equal(tri, faces) and np.array_equal(_accessor(doc, k), vertices) and _like(
                    tree, p.get("material"), material):
                found.append(p)
    return found


def _like(tree, index, material) -> bool:
    """Could trimesh have read the glTF material ``index`` (None: none) as ``material`` (None: none)? Its name,
    its base colour factor in 8 bits (``material``'s may be the float one :func:`pyshadow.gltf_files.read_gltf`
    restores) and whether it has a base colour texture agree."""
    from trimesh.visual.color import to_rgba

    if index is None or material is None:
        return index is None and material is None
    mat = (tree.get("materials") or [])[index]
    pbr = mat.get("pbrMetallicRoughness") or {}
    factor = pbr.get("baseColorFactor")
    mine = getattr(material, "baseColorFactor", None)
    return (("name" not in mat or getattr(material, "name", None) == mat["name"])
            and (factor is None) == (mine is None)
            and (factor is None or np.array_equal(to_rgba(np.array(factor, np.float64)), to_rgba(np.array(mine))))
            and ("baseColorTexture" in pbr) == (getattr(material, "baseColorTexture", None) is not None))


def _details(doc, prim) -> dict:
    """:func:`primitive_details` of a found primitive."""
    tree = doc[0]
    attrs = prim.get("attributes") or {}
    colour = _accessor(doc, attrs["COLOR_0"]) if "COLOR_0" in attrs else None
    if colour is not None and colour.dtype.kind == "i":     # not a glTF colour type: as trimesh read it
        colour = None
    info, transform = _texture_info(tree, prim.get("material"))
    uv = None
    channel = transform.get("texCoord", info.get("texCoord", 0))
    k = attrs.get(f"TEXCOORD_{channel}")
    if info and isinstance(k, int) and (channel != 0 or transform or tree["accessors"][k]["componentType"] != 5126):
        uv = _accessor(doc, k, normalise=True).astype(np.float64)
        if transform:
            sx, sy = transform.get("scale", (1.0, 1.0))
            ox, oy = transform.get("offset", (0.0, 0.0))
            c, s = np.cos(transform.get("rotation", 0.0)), np.sin(transform.get("rotation", 0.0))
            u, v = uv[:, 0] * sx, uv[:, 1] * sy
            uv = np.column_stack([c * u + s * v + ox, -s * u + c * v + oy])
        uv = np.column_stack([uv[:, 0], 1.0 - uv[:, 1]])
    return {"colour_0": colour, "material": "material" in prim, "uv": uv,
            "sampler": _sampler(tree, info) if info else DEFAULT_SAMPLER}

"""Reading glTF files for :func:`pyshadow.mesh_files.read_mesh_file`: what trimesh reads wrongly refused, and
the files a ``.gltf`` names found by their decoded names.

trimesh reads a glTF whose geometry it cannot decode wrongly or fails on it
unclearly: a Draco-compressed mesh without DracoPy was read as zeros ("every
face is degenerate"), normalised integer positions (``KHR_mesh_quantization``)
as the integers (32767 times too large for int16), sparse positions without
their sparse values, a triangle-fan primitive was left out, and a
meshopt-compressed file failed with "list index out of range".
:func:`check_gltf` refuses such a file first, saying why.

A glTF names its buffer and image files by URI, percent-encoded as RFC 3986
asks (Blender writes the buffer ``my chair.bin`` as ``my%20chair.bin``,
``café.png`` as ``caf%C3%A9.png``). trimesh looks the URI up as a file name as
it is written: a model whose buffer name was encoded failed ("could not be
read as a mesh (my%20chair.bin)"), one whose image name was encoded lost its
texture without a word (it read white), as did one whose image file is
missing. :class:`GltfResolver` looks for the decoded name first, then for the
name as written (some exporters write names raw), each as trimesh's resolver
does (a name that leaves the file's folder, ``..`` or absolute, is not read
there; trimesh tries its last part in the folder); :func:`check_gltf_files`
names a buffer or image file that is not found before trimesh reads.

A buffer holding fewer bytes than its ``byteLength`` (a ``.bin`` or GLB cut short) failed with an empty
message, an accessor past its buffer view with "cannot reshape array": :func:`check_gltf_buffers` names them.

trimesh also keeps a material's ``baseColorFactor`` in 8 bits (0.001 read as
0); :func:`read_gltf` gives each material back the file's float factor.
"""
from __future__ import annotations

import importlib.util
import json
import os
import struct
import warnings
from pathlib import Path
from urllib.parse import unquote

import numpy as np
import trimesh

__all__ = ["check_gltf", "check_gltf_files", "check_gltf_buffers", "read_gltf", "GltfResolver", "gltf_file_uris"]

#: bytes of each accessor componentType; components of each accessor type (matrices left out: their columns
#: may be padded)
_COMPONENT_BYTES = {5120: 1, 5121: 1, 5122: 2, 5123: 2, 5125: 4, 5126: 4}
_COMPONENTS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}


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


class GltfResolver(trimesh.resolvers.FilePathResolver):
    """trimesh's resolver of the files beside a glTF, which also reads percent-encoded names.

    Parameters
    ----------
    source : str
        The glTF file's path (its folder is the root files are read from).
    """

    def find(self, name: str) -> Path | None:
        """The file that the URI ``name`` means, or None where there is none.

        Parameters
        ----------
        name : str
            A buffer's or image's ``uri`` as the file writes it.

        Returns
        -------
        pathlib.Path or None
            The first existing file among the decoded name (``%20`` a space,
            UTF-8 escapes their characters), then the name as written, each
            tried as trimesh's resolver does: as it is, without a leading
            ``/``, and its last part; only files in the root or below it
            (absolute, symbolic links followed).
        """
        found = self.match(name)
        return None if found is None else found[1]

    def match(self, name: str):
        """(the name tried that was found, relative to the root where it is absolute, and :meth:`find`'s
        file), or None."""
        for text in dict.fromkeys((unquote(name), name)):
            for candidate in (text.strip(), text.strip().lstrip("/"), os.path.split(text)[-1]):
                try:
                    path = self.absolute(candidate)
                    if path.is_file():
                        if os.path.isabs(candidate):
                            candidate = os.path.relpath(os.path.join(self.parent, candidate), self.parent)
                        return candidate, path
                except (ValueError, OSError):   # outside the root; a name the system refuses
                    continue
        return None

    def get(self, name: str) -> bytes:
        """The bytes of the file the URI ``name`` means (:meth:`find`); trimesh's error where there is none."""
        path = self.find(name)
        if path is None:
            return super().get(name)
        return path.read_bytes()


def gltf_file_uris(tree, every: bool = False) -> list:
    """[(what, number, uri)] of the files a glTF's JSON ``tree`` reads: each buffer's ``uri`` and each image's
    that trimesh reads (not ``data:``; with ``every`` False, not an image in a buffer view or KTX2, which
    trimesh leaves out)."""
    out = []
    if not isinstance(tree, dict):
        return out
    for key, what in (("buffers", "buffer"), ("images", "image")):
        items = tree.get(key)
        for k, item in enumerate(items if isinstance(items, list) else []):
            uri = item.get("uri") if isinstance(item, dict) else None
            left_out = what == "image" and ("bufferView" in item or item.get("mimeType") == "image/ktx2")
            if not isinstance(uri, str) or uri.startswith("data:") or "base64," in uri or left_out and not every:
                continue
            out.append((what, k, uri))
    return out


def check_gltf_files(path: Path, data: bytes, label: str = "glTF") -> None:
    """Raise ValueError where a buffer file a glTF names is not found; warn where an image file is not.

    Parameters
    ----------
    path : pathlib.Path
        The glTF file (files are looked for in its folder).
    data : bytes
        Its JSON (:func:`_gltf_head`: a GLB's first chunk or a ``.gltf`` file).
    label : str
        Names the file in the message.

    Raises
    ------
    ValueError
        Naming the buffer, its ``uri`` and the decoded file name: no file
        has that name (decoded or as written) in the folder, or it lies
        outside the folder (``..``, an absolute path), where trimesh reads
        no file (a missing buffer failed unclearly).

    Warns
    -----
    UserWarning
        The same of an image: the mesh is read without it (its geometry,
        AO and shadows need none; a missing image was left out without a
        word: the mesh read white).
    """
    entries = gltf_file_uris(_gltf_json(data))
    if not entries:
        return
    resolver = GltfResolver(str(path))
    for what, k, uri in entries:
        if resolver.find(uri) is not None:
            continue
        name = unquote(uri)
        named = f"{name!r}" + (f" (uri {uri!r})" if name != uri else "")
        where = f"is not in {resolver.parent}"
        try:
            resolver.absolute(name)
        except ValueError as exc:               # trimesh's "escapes resolver root", or a NUL in the name
            if "escapes" in str(exc):
                where = f"lies outside {resolver.parent}, where glTF files are not read from: put it in that folder"
        message = f"{label}: its {what} {k} names the file {named}, which {where}"
        if what != "buffer":
            warnings.warn(f"{message}; read without it", UserWarning, stacklevel=4)
            continue
        raise ValueError(message)


def _buffer_bytes(path: Path, head: bytes, k: int, buf: dict, label: str):
    """(bytes buffer ``k`` holds, where they are) or None where that is not known (a file not found:
    :func:`check_gltf_files`)."""
    uri = buf.get("uri")
    if uri is None:
        if head[:4] != b"glTF" or k != 0:
            raise ValueError(f"{label}: its buffer {k} has no uri (only a GLB's first buffer may have none: "
                             "its binary chunk)")
        size = path.stat().st_size
        with open(path, "rb") as fh:
            fh.seek(len(head))
            chunk = fh.read(8)
        if len(chunk) < 8 or struct.unpack_from("<I", chunk, 4)[0] != 0x004E4942:
            return 0, "the GLB, which has no binary chunk,"
        return min(struct.unpack_from("<I", chunk)[0], size - len(head) - 8), "the GLB's binary chunk"
    if not isinstance(uri, str):
        return None
    if uri.startswith("data:"):                 # its length, not decoded (no other than base64: not known)
        text = uri.partition(";base64,")[2].strip()
        return (len(text) * 3 // 4 - text[-2:].count("="), "its data: URI") if text.isascii() and \
            text.replace("+", "").replace("/", "").rstrip("=").isalnum() else None
    found = GltfResolver(str(path)).find(uri)
    return None if found is None else (found.stat().st_size, f"the file {found.name!r}")


def check_gltf_buffers(path: Path, head: bytes, label: str = "glTF") -> None:
    """Raise ValueError where a glTF's data lie beyond the bytes its buffers hold (a buffer file or GLB cut short).

    Parameters
    ----------
    path : pathlib.Path
        The glTF file (its buffer files are looked for in its folder).
    head : bytes
        Its JSON (:func:`_gltf_head`).
    label : str
        Names the file in the message.

    Raises
    ------
    ValueError
        No glTF JSON can be read; a buffer holds fewer bytes than its
        ``byteLength`` (a ``.bin`` file, a GLB's binary chunk or a
        ``data:`` URI: trimesh failed with an empty message or "cannot
        reshape array"); a buffer other than a GLB's first has no ``uri``;
        a buffer view reaches past its buffer or an accessor past its
        buffer view. The message names the buffer, view or accessor.
    """
    tree = _gltf_json(head)
    if not isinstance(tree, dict):
        raise ValueError(f"{label}: no glTF JSON could be read from it (not a glTF file, or damaged)")

    def items(key):
        got = tree.get(key)
        return [x if isinstance(x, dict) else {} for x in got] if isinstance(got, list) else []

    buffers, views = items("buffers"), items("bufferViews")
    for k, buf in enumerate(buffers):
        declared, held = _count(buf, "byteLength"), _buffer_bytes(path, head, k, buf, label)
        if held is not None and declared is not None and held[0] < declared:
            raise ValueError(f"{label}: its buffer {k} has {declared} bytes (byteLength) but {held[1]} holds "
                             f"{held[0]} (cut short?)")
    for k, view in enumerate(views):
        b, offset, length = view.get("buffer"), _count(view, "byteOffset"), _count(view, "byteLength")
        size = _count(buffers[b], "byteLength") if isinstance(b, int) and 0 <= b < len(buffers) else None
        if None not in (size, offset, length) and offset + length > size:
            raise ValueError(f"{label}: its bufferView {k} reaches byte {offset + length} of buffer {b}, which has "
                             f"{size}")
    for k, acc in enumerate(items("accessors")):
        v, count, offset = acc.get("bufferView"), _count(acc, "count"), _count(acc, "byteOffset")
        n, size = _COMPONENTS.get(acc.get("type")), _COMPONENT_BYTES.get(acc.get("componentType"))
        if not (isinstance(v, int) and 0 <= v < len(views) and count and offset is not None and n and size):
            continue
        stride, length = _count(views[v], "byteStride") or n * size, _count(views[v], "byteLength")
        end = offset + (count - 1) * stride + n * size
        if length is not None and end > length:
            raise ValueError(f"{label}: its accessor {k} ({count} x {acc.get('type')}) reaches byte {end} of "
                             f"bufferView {v}, which has {length}")


def _count(item: dict, key: str):
    """``item[key]`` where it is a whole number of 0 or more (0 where it is absent), else None."""
    value = item.get(key, 0)
    return value if isinstance(value, int) and not isinstance(value, bool) and value >= 0 else None


def read_gltf(path: Path, label: str):
    """What trimesh reads from the ``.gltf`` or ``.glb`` file ``path`` (no processing), its files found by
    their decoded names (:class:`GltfResolver`) and its materials' float ``baseColorFactor`` kept (float64
    RGBA where trimesh has uint8: :func:`_float_factors`); ValueError naming ``label`` where
    :func:`check_gltf` or :func:`check_gltf_files` refuses it."""
    head = _gltf_head(path)
    check_gltf(head, label)
    check_gltf_files(path, head, label)
    check_gltf_buffers(path, head, label)
    loaded = trimesh.load(str(path), process=False, resolver=GltfResolver(str(path)))
    _float_factors(loaded, _gltf_json(head))
    return loaded


def _float_factors(loaded, tree) -> None:
    """Give each material of trimesh's reading the float ``baseColorFactor`` of the glTF material it was read from.

    trimesh keeps the factor as 8-bit RGBA (``0.001`` read as 0, ``0.0015`` as 0, ``0.3`` as 0.298); glTF's
    is a float multiplier. A material gets the file's RGBA (float64, in [0, 1]) where the glTF materials of
    its name (any, for unnamed ones) whose factor reads as its 8 bits all have the same factor (a texture
    that was not found changes nothing); otherwise it keeps trimesh's.
    """
    from trimesh.visual.color import to_rgba

    mats = tree.get("materials") if isinstance(tree, dict) else None
    if not isinstance(mats, list) or not mats:
        return
    geoms = loaded.geometry.values() if isinstance(loaded, trimesh.Scene) else [loaded]
    found = {}
    for geom in geoms:
        material = getattr(getattr(geom, "visual", None), "material", None)
        for m in getattr(material, "materials", None) or [material]:
            if isinstance(m, trimesh.visual.material.PBRMaterial) and m.baseColorFactor is not None:
                found[id(m)] = m
    factors = []
    for mat in mats:
        try:
            f = to_rgba(np.array(mat["pbrMetallicRoughness"]["baseColorFactor"], np.float64), dtype=np.float64)
            factors.append((mat.get("name"), f, to_rgba(f.copy())) if f.shape == (4,) else None)
        except (TypeError, ValueError, KeyError, AttributeError, IndexError):     # none, or none a glTF has
            factors.append(None)
    for m in found.values():
        mine = to_rgba(np.array(m.baseColorFactor))
        same = {tuple(f) for c in factors if c is not None for name, f, bits in [c]
                if (name is None or name == m.name) and np.array_equal(bits, mine)}
        if len(same) == 1:
            m._data["baseColorFactor"] = np.array(same.pop(), np.float64)    # its setter would round it

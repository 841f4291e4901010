"""Surface colours of meshes: vertex colours and textures kept by :func:`pyshadow.load_mesh` (issue 19).

:func:`pyshadow.load_mesh` merges coincident vertices and so loses the
per-vertex visual attributes of the file (a UV seam or a colour edge splits
a vertex). It keeps them apart from the geometry instead, per *face
corner*, in a :class:`MeshVisual` stored as ``mesh.metadata["pyshadow_visual"]``
(:data:`VISUAL_KEY`; absent when the file has neither colours nor UVs).
Vertices, faces and :func:`pyshadow.mesh.mesh_hash` are exactly those of a load
without it, so CSMs and caches do not change. A scene (several meshes, as
a GLB or a multi-material OBJ loads) gets one visual per mesh, joined per
face corner in the order its meshes are concatenated (:func:`join_visuals`):
each part keeps its own colours, material colour and texture. The visual
records the faces it was attached to (:attr:`MeshVisual.faces`), so
:func:`visual_of` follows trimesh where it re-orders their corners
(``invert()``, a mirroring transform, ``trimesh.repair.fix_winding``;
:mod:`pyshadow.visual_corners`).

Colour convention: linear RGB in [0, 1]; alpha (glTF's ``alphaMode``, ``alphaCutoff``: a MASK cutout is
no hole), glTF's emissive colour and metallic/roughness are not used (the base colour is the diffuse
albedo, even of a metal: glTF's default ``metallicFactor`` is 1). Texture images
and an OBJ material's ``Kd`` are sRGB-encoded and decoded with
:func:`pyshadow.io.srgb_to_linear`, and so are the vertex and face colours
of every format but glTF (PLY, OBJ, ...: display-encoded, as their
viewers show them; trimesh reads no colours from OFF files). glTF is linear where its specification says so: the
``COLOR_0`` vertex colours ("an additional linear multiplier to base
color", glTF 2.0 section 3.9.2) and ``baseColorFactor`` are used as they
are; its base colour texture is sRGB like any image. A mesh counts as glTF
(:func:`is_gltf`) when :func:`pyshadow.load_mesh` read it from a path
ending in ``.glb`` or ``.gltf`` (any case), or when the trimesh object
itself comes from trimesh's glTF reader: that reader puts the key
``"from_gltf_primitive"`` in every mesh's ``metadata`` (kept by
``Scene.to_geometry``, ``force="mesh"`` and ``copy``), and a mesh of a
loaded scene also has ``source.file_type`` ``'glb'``/``'gltf'``. Any other
mesh object (built in code, or read from another format) has sRGB colours;
one whose colours are linear can pass ``gltf=True`` to :func:`mesh_visual`.
Integer data is 8-bit (over 255) except 16 bit (over 65535: a 16-bit
greyscale PNG, glTF's unsigned short ``COLOR_0``); float data (glTF's float
``COLOR_0``) is in [0, 1] already; a grey per vertex ((V,), (V, 1), with alpha (V, 2)) is grey RGB.
A mesh with UVs but no texture (a PLY) has the colours trimesh keeps on it (``vertex_attributes``,
``face_attributes``). Colours that are not finite are refused like such UVs (below).

The colour of a surface point (:func:`point_colours`) is the product of
what its mesh has, as glTF defines a base colour: the barycentric
interpolation of its face's corner colours, times the texture's bilinear
sample at the interpolated UV (repeat wrap; ``v = 0`` is the image's
bottom row; a glTF file's sampler, UV set and ``KHR_texture_transform``,
and its ``COLOR_0`` at full precision, as :mod:`pyshadow.gltf_materials`
reads them), times the material's base colour factor. UVs that are not
finite (an OBJ's ``vt nan nan``) are kept by :func:`pyshadow.load_mesh`
(the geometry, shadows and AO do not need them) and refused with a
ValueError naming the source where the texture is applied. A lit render
multiplies it by the instance's albedo (:class:`pyshadow.lighting.Lighting`'s
``albedo``/``albedos``); a mesh without a :class:`MeshVisual` contributes 1,
and so do the faces of a part without colours in a joined scene.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from functools import lru_cache

import numpy as np

from .gltf_materials import DEFAULT_SAMPLER, ply_colours, primitive_details, sample
from .visual_corners import aligned_visual, barycentrics

__all__ = ["MeshVisual", "VISUAL_KEY", "GLTF_SUFFIXES", "is_gltf", "mesh_visual", "join_visuals", "visual_of",
           "point_colours", "surface_colours", "barycentrics"]

#: Key of :attr:`trimesh.Trimesh.metadata` under which :func:`pyshadow.load_mesh` keeps a :class:`MeshVisual`.
VISUAL_KEY = "pyshadow_visual"

#: File suffixes (lower case) whose meshes :func:`pyshadow.load_mesh` reads as glTF (linear ``COLOR_0``).
GLTF_SUFFIXES = (".glb", ".gltf")


@dataclass(eq=False)
class MeshVisual:
    """Visual attributes of a mesh, per face corner (aligned with ``mesh.faces``).

    Attributes
    ----------
    colours : ndarray, shape (T, 3, 3), float32, or None
        Linear RGB in [0, 1] of each corner of each face (vertex colours, or
        face colours repeated on the three corners).
    uv : ndarray, shape (T, 3, 2), float32, or None
        Texture coordinates of each corner.
    texture : ndarray, shape (h, w, 3), float32, or None
        The base-colour image, linear RGB, row 0 at the top (``v = 1``).
    factor : ndarray, shape (3,), float32
        Base colour factor (glTF ``baseColorFactor``), linear RGB; for an
        untextured :class:`trimesh.visual.material.SimpleMaterial` (OBJ/MTL)
        its ``diffuse`` (``Kd``) when set; ones otherwise.
    source : str
        What the attributes were read from (the path :func:`pyshadow.load_mesh`
        was given, or ``<Trimesh>``), named in errors.
    textures : tuple of ndarray
        Several images (each as ``texture``), when the faces of a joined
        scene (:func:`join_visuals`) use different textures; ``texture`` is
        None then. Empty otherwise.
    texture_index : ndarray, shape (T,), int32, or None
        With ``textures``: the image each face samples, -1 for none (colour 1).
    sampler : tuple
        How ``texture`` is sampled: glTF's ``(wrapS, wrapT, nearest)``
        (:data:`pyshadow.gltf_materials.DEFAULT_SAMPLER`: repeat, bilinear).
    samplers : tuple of tuple
        With ``textures``: the sampler of each image.
    faces : ndarray, shape (T, 3), int64, or None
        The mesh's faces (vertex ids) the rows are aligned with, recorded
        where :mod:`pyshadow` attaches it to a mesh (:meth:`attached_to`);
        :func:`visual_of` re-orders the corners of the faces whose corners
        trimesh re-ordered since (:func:`pyshadow.visual_corners.aligned_visual`).
        None: not recorded (only the number of faces is checked).
    """

    colours: np.ndarray | None
    uv: np.ndarray | None
    texture: np.ndarray | None
    factor: np.ndarray
    source: str = "mesh"
    textures: tuple = ()
    texture_index: np.ndarray | None = None
    sampler: tuple = DEFAULT_SAMPLER
    samplers: tuple = ()
    faces: np.ndarray | None = None
    # which of colours, uv and texture hold only finite values: found once per visual (a copy made by
    # take or with_fans finds its own), not on every point_colours call
    _finite: dict = field(default_factory=dict, init=False, repr=False)
    # [faces, aligned visual or None: itself] of the last faces visual_of aligned it to (visual_corners)
    _aligned: list = field(default_factory=list, init=False, repr=False)

    def take(self, faces) -> "MeshVisual":
        """The attributes of the faces ``faces`` (index or boolean mask), in that order."""
        pick = (lambda a: None if a is None else np.ascontiguousarray(a[faces]))
        return replace(self, colours=pick(self.colours), uv=pick(self.uv), texture_index=pick(self.texture_index),
                       faces=pick(self.faces))

    def attached_to(self, faces) -> "MeshVisual":
        """This visual with ``faces`` (T, 3) recorded as the faces of the mesh it is kept on (:attr:`faces`)."""
        return replace(self, faces=np.array(faces, dtype=np.int64).reshape(-1, 3))

    def reversed(self) -> "MeshVisual":
        """The attributes of the faces with their corners in reverse order (trimesh's ``fliplr`` of faces
        that a mirroring transform reverses)."""
        rev = (lambda a: None if a is None else np.ascontiguousarray(a[:, ::-1]))
        return replace(self, colours=rev(self.colours), uv=rev(self.uv), faces=rev(self.faces))

    def with_fans(self, faces: np.ndarray, loops) -> "MeshVisual":
        """Extended by the fan faces :func:`pyshadow.mesh.close_holes` appends, in its order (no :attr:`faces`).

        The fan face ``(b, a, centre)`` of the boundary edge ``(a, b)`` of face
        ``f`` takes ``f``'s corner attributes at ``a`` and ``b`` (and ``f``'s
        texture); the centre takes the mean of the loop's.
        """
        where = {}
        for k in range(3):
            for f, (a, b) in enumerate(zip(faces[:, k].tolist(), faces[:, (k + 1) % 3].tolist())):
                where[(a, b)] = (f, k, (k + 1) % 3)
        parts = {"colours": [], "uv": [], "texture_index": []}
        for loop in loops:
            if len(loop) < 3:
                continue
            hit = [where[e] for e in loop]
            if self.texture_index is not None:
                parts["texture_index"].append(self.texture_index[[f for f, _, _ in hit]])
            for name in ("colours", "uv"):
                arr = getattr(self, name)
                if arr is None:
                    continue
                at_a = np.stack([arr[f, ka] for f, ka, _ in hit])
                at_b = np.stack([arr[f, kb] for f, _, kb in hit])
                centre = np.broadcast_to(at_a.mean(axis=0), at_a.shape)
                parts[name].append(np.stack([at_b, at_a, centre], axis=1).astype(np.float32))
        grow = (lambda a, extra: a if a is None or not extra else np.concatenate([a, *extra]))
        return replace(self, colours=grow(self.colours, parts["colours"]), uv=grow(self.uv, parts["uv"]),
                       texture_index=grow(self.texture_index, parts["texture_index"]), faces=None)


def _linear(rgb, srgb: bool = True) -> np.ndarray:
    """Colours (..., >= 3) -> linear float32 (..., 3); non-finite values -> NaN (module docstring).

    uint16 is over 65535, float as it is (clipped to [0, 1]), any other type over 255; then decoded
    with :func:`pyshadow.io.srgb_to_linear` unless ``srgb`` is False (glTF's linear ``COLOR_0``).
    """
    a = np.asarray(rgb)[..., :3]
    if a.dtype in (np.uint8, np.uint16):    # a table of every code: float64 copies of a 4096^2 image took 2.4 GB
        return _code_table(a.dtype.itemsize, bool(srgb))[a]
    return _decode(a, srgb)


@lru_cache(maxsize=None)
def _code_table(itemsize: int, srgb: bool) -> np.ndarray:
    """:func:`_linear` of every 8-bit (``itemsize`` 1) or 16-bit code, (256,) or (65536,) float32, read-only."""
    table = _decode(np.arange(1 << (8 * itemsize), dtype=np.uint8 if itemsize == 1 else np.uint16), srgb)
    table.setflags(write=False)
    return table


def _decode(a, srgb) -> np.ndarray:
    """:func:`_linear` of the array ``a`` (..., 3), elementwise in float64."""
    from .io import srgb_to_linear

    scale = 1.0 if a.dtype.kind == "f" else 65535.0 if a.dtype == np.uint16 else 255.0
    a = a.astype(np.float64)
    ok = np.isfinite(a)
    unit = np.where(ok, a, 0.0) / scale
    return np.where(ok, srgb_to_linear(unit) if srgb else np.clip(unit, 0.0, 1.0), np.nan).astype(np.float32)


def _rgb_rows(col, source) -> np.ndarray:
    """Vertex (face) colours (n,) or (n, 1) (grey), (n, 2) (grey, alpha), (n, 3) or (n, 4) as (n, 3 or 4)."""
    a = np.asarray(col)[:, None] if np.ndim(col) == 1 else np.asarray(col)
    if a.ndim != 2 or not 1 <= a.shape[1] <= 4:
        raise ValueError(f"{source}: vertex or face colours must have shape (n,) or (n, 1) (grey), (n, 2) (grey, "
                         f"alpha), (n, 3) (RGB) or (n, 4) (RGBA), got {np.shape(col)}")
    return np.repeat(a[:, :1], 3, axis=1) if a.shape[1] < 3 else a


def _image(image) -> np.ndarray:
    """A PIL image's encoded colours, (h, w, 3): 16-bit greyscale (modes ``I;16*``, ``I``: a 16-bit PNG)
    as uint16 and float greyscale (``F``) as float, which ``convert("RGB")`` would clip to 0/255."""
    if image.mode.startswith("I;16") or image.mode == "I":
        grey = np.clip(np.asarray(image), 0, 65535).astype(np.uint16)
    elif image.mode == "F":
        grey = np.asarray(image, dtype=np.float32)
    else:
        return np.asarray(image.convert("RGB"))
    return np.repeat(grey[..., None], 3, axis=-1)


def _diffuse(material) -> np.ndarray:
    """Linear factor (3,) float32 of an untextured SimpleMaterial's sRGB ``diffuse`` (OBJ ``Kd``); ones when unset
    (trimesh's default grey, unless an MTL file gave it: ``kd`` in its kwargs) or for other materials."""
    from trimesh.visual.color import DEFAULT_COLOR

    d = getattr(material, "diffuse", None)
    if d is None or ("kd" not in (getattr(material, "kwargs", None) or {})
                     and np.array_equal(np.asarray(d), DEFAULT_COLOR)):
        return np.ones(3, np.float32)
    return _linear(np.asarray(d))


def _texture(material, sample: bool = True, images: dict | None = None):
    """(image (h, w, 3) float32 linear or None, factor (3,) float32) of a trimesh material.

    ``sample=False``: the factor only (no UVs to apply an image with); the image still decides
    whether a SimpleMaterial's ``diffuse`` counts (only without any image: trimesh writes its
    placeholder image with its default grey as ``map_Kd`` and ``Kd``). ``images``: decoded images by
    the id of their PIL image (shared by the parts of a scene: each is decoded once, and equal
    parts get the same array).
    """
    image = getattr(material, "baseColorTexture", None)
    if image is None:
        image = getattr(material, "image", None)
    untextured = image is None
    if image is not None and _placeholder(image):
        image = None
    base = getattr(material, "baseColorFactor", None)
    if base is not None:
        base = np.asarray(base)
        # trimesh keeps glTF's factor as uint8 RGBA (sRGB-free: glTF factors are linear)
        factor = (base[:3].astype(np.float64) / (255.0 if base.dtype == np.uint8 else 1.0)).astype(np.float32)
    elif untextured:
        factor = _diffuse(material)
    else:
        factor = np.ones(3, np.float32)
    if image is None or not sample:
        return None, factor
    if images is None:
        return _linear(_image(image)), factor
    if id(image) not in images:
        images[id(image)] = (image, _linear(_image(image)))     # the image kept alive: its id stays its own
    return images[id(image)][1], factor


def _placeholder(image) -> bool:
    """Is ``image`` the uniform image trimesh invents for UVs without a material (``empty_material``)?"""
    from trimesh.visual.material import color_image

    blank = np.asarray(color_image())
    got = np.asarray(image)
    return got.shape == blank.shape and bool(np.array_equal(got, blank))


def is_gltf(mesh) -> bool:
    """Does ``mesh`` come from trimesh's glTF reader (module docstring)? Its ``COLOR_0`` is linear then.

    True when its ``metadata`` has the key ``"from_gltf_primitive"`` (which that reader sets on every
    mesh) or its ``source.file_type`` is ``'glb'`` or ``'gltf'``.
    """
    if "from_gltf_primitive" in (getattr(mesh, "metadata", None) or {}):
        return True
    try:
        kind = getattr(getattr(mesh, "source", None), "file_type", None)
    except Exception:       # an object whose source cannot be read is no glTF
        return False
    return isinstance(kind, str) and kind.lower() in ("glb", "gltf")


def mesh_visual(mesh, source: str = "mesh", gltf: bool | None = None) -> MeshVisual | None:
    """The :class:`MeshVisual` of a trimesh as loaded (before merging), or None if it has none.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        Its ``visual``: :class:`trimesh.visual.ColorVisuals` with vertex or
        face colours, or :class:`trimesh.visual.TextureVisuals` with UVs
        (and a material image or glTF ``COLOR_0`` colours) or a material
        colour (glTF ``baseColorFactor``, OBJ ``Kd``; with or without UVs;
        per face for the primitives of a glTF mesh merged into one, a
        :class:`trimesh.visual.material.MultiMaterial`). The uniform image
        trimesh makes up for UVs without a material file is not a texture
        (ignored).
    source : str, optional
        What it was read from (:attr:`MeshVisual.source`).
    gltf : bool or None, optional
        Whether its vertex and face colours are linear (glTF ``COLOR_0``)
        rather than sRGB-encoded; None: :func:`is_gltf` of ``mesh``.
    """
    return _mesh_visual(mesh, source, gltf, None)


def _mesh_visual(mesh, source, gltf, images) -> MeshVisual | None:
    """:func:`mesh_visual`, with the decoded images of :func:`_texture` shared through ``images``."""
    import trimesh

    visual = getattr(mesh, "visual", None)
    faces = np.asarray(mesh.faces, dtype=np.int64)
    if visual is None or len(faces) == 0:
        return None
    srgb = not (is_gltf(mesh) if gltf is None else bool(gltf))
    colours = uv = texture = None
    factor = np.ones(3, np.float32)
    more = None if srgb else primitive_details(mesh)        # what trimesh's glTF reader lost
    if isinstance(visual, trimesh.visual.ColorVisuals):
        if visual.kind == "vertex":
            raw = ply_colours(mesh, "vertex", visual.vertex_colors)     # trimesh wraps 16-bit ones
            if more is not None and more["colour_0"] is not None and not more["material"] and np.array_equal(
                    trimesh.visual.color.to_rgba(more["colour_0"].copy()), raw):   # trimesh's 8 bits of it
                raw = more["colour_0"]
            colours = _linear(raw, srgb)[faces]
        elif visual.kind == "face":
            colours = np.repeat(_linear(ply_colours(mesh, "face", visual.face_colors), srgb)[:, None, :], 3, axis=1)
    elif isinstance(visual, trimesh.visual.TextureVisuals):
        uv_of = visual.uv if more is None or more["uv"] is None else more["uv"]
        has_uv = uv_of is not None and len(uv_of) == len(mesh.vertices)
        material = visual.material
        per_face = getattr(visual, "face_materials", None)
        if isinstance(material, trimesh.visual.material.MultiMaterial):
            # glTF primitives merged by trimesh (merge_primitives=True): a material colour per face
            if per_face is not None and len(per_face) == len(faces) and len(material.materials):
                table = np.stack([_texture(m, sample=False)[1] for m in material.materials])
                pick = np.clip(np.asarray(per_face, dtype=np.int64), 0, len(table) - 1)
                if not (table == 1).all():
                    colours = np.repeat(table[pick][:, None, :], 3, axis=1)
        else:
            texture, factor = _texture(material, sample=has_uv, images=images)
        if has_uv:
            uv = np.asarray(uv_of, dtype=np.float32)[faces]
        col = visual.vertex_attributes.get("color") if hasattr(visual, "vertex_attributes") else None
        kept = [getattr(mesh, k, None) or {} for k in ("vertex_attributes", "face_attributes")]
        if col is None and texture is None:     # trimesh keeps a PLY's colours on a mesh with UVs (they were lost)
            col = kept[0].get("color")
        fcol = kept[1].get("color") if texture is None else None
        c = None
        if col is not None and len(col) == len(mesh.vertices):
            c = _linear(_rgb_rows(col, source), srgb)[faces]
        elif fcol is not None and len(fcol) == len(faces):
            c = np.repeat(_linear(_rgb_rows(fcol, source), srgb)[:, None, :], 3, axis=1)
        if c is not None:
            colours = c if colours is None else colours * c
    if colours is None and uv is None and bool((factor == 1).all()):
        return None
    return MeshVisual(colours, uv, texture, factor, str(source),
                      sampler=DEFAULT_SAMPLER if more is None or texture is None else more["sampler"])


def join_visuals(parts, source: str = "mesh") -> MeshVisual | None:
    """One :class:`MeshVisual` of meshes concatenated in order, from the visual of each.

    Parameters
    ----------
    parts : sequence of (MeshVisual or None, int)
        Each mesh's visual (None: it has none) and its number of faces.
    source : str, optional
        :attr:`MeshVisual.source` of the result.

    Returns
    -------
    MeshVisual or None
        None when no part has one; the part's own (``source`` replaced) when
        there is one part. Otherwise a part's faces keep their colours, UVs
        and texture; a part without colours has ones (not trimesh's default
        grey); factors that differ between parts are multiplied into the
        corner colours (exact: a factor is constant over its part); textures
        that differ give :attr:`MeshVisual.textures` with a texture index per
        face (the parts without one: -1, colour 1).
    """
    parts = [(v, int(n)) for v, n in parts]
    if all(v is None for v, _ in parts):
        return None
    if len(parts) == 1:
        return replace(parts[0][0], source=str(source))
    one = np.ones(3, np.float32)
    factors = [one if v is None else np.asarray(v.factor, np.float32) for v, _ in parts]
    same = all(np.array_equal(f, factors[0]) for f in factors)
    colours = None
    if not same or any(v is not None and v.colours is not None for v, _ in parts):
        colours = np.concatenate([
            (np.ones((n, 3, 3), np.float32) if v is None or v.colours is None else v.colours)
            * (one if same else f) for (v, n), f in zip(parts, factors)]).astype(np.float32)
    uv = None
    if any(v is not None and v.uv is not None for v, _ in parts):
        uv = np.concatenate([np.zeros((n, 3, 2), np.float32) if v is None or v.uv is None else v.uv
                             for v, n in parts]).astype(np.float32)
    images: list = []
    samplers: list = []

    def slot(image, sampler):              # index of ``image`` in ``images`` (the same array and sampler: one slot)
        for k, known in enumerate(images):
            if known is image and samplers[k] == sampler:
                return k
        images.append(image)
        samplers.append(sampler)
        return len(images) - 1

    index = []
    for v, n in parts:
        if v is None or v.uv is None:
            index.append(np.full(n, -1, np.int32))
        elif v.texture_index is not None:
            remap = np.array([slot(t, s) for t, s in zip(v.textures, v.samplers or [DEFAULT_SAMPLER] * len(v.textures))]
                             + [-1], np.int32)
            index.append(remap[v.texture_index])               # -1 stays -1 (the last entry)
        else:
            index.append(np.full(n, -1 if v.texture is None else slot(v.texture, v.sampler), np.int32))
    index = np.concatenate(index)
    texture, textures, texture_index, sampler = None, (), None, DEFAULT_SAMPLER
    if len(images) == 1 and (index == 0).all():
        texture, sampler = images[0], samplers[0]
    elif images:
        textures, texture_index = tuple(images), index
    return MeshVisual(colours, uv, texture, factors[0] if same else one, str(source), textures, texture_index,
                      sampler, tuple(samplers) if textures else ())


def visual_of(mesh) -> MeshVisual | None:
    """The :class:`MeshVisual` kept on ``mesh`` (``mesh.metadata[VISUAL_KEY]``), or None.

    With :attr:`MeshVisual.faces` recorded, its corner attributes in the corner order of ``mesh.faces`` now
    (after ``mesh.invert()``, a mirroring transform, ``trimesh.repair.fix_winding``: a copy re-ordered by
    :func:`pyshadow.visual_corners.aligned_visual`); a ValueError where faces use other vertices.
    """
    v = getattr(mesh, "metadata", {}).get(VISUAL_KEY)
    if v is None:
        return None
    if not isinstance(v, MeshVisual):
        raise TypeError(f"mesh.metadata[{VISUAL_KEY!r}] must be a pyshadow.materials.MeshVisual, "
                        f"got {type(v).__name__}")
    _check_arrays(v, f"mesh.metadata[{VISUAL_KEY!r}]")
    if any(a is not None and len(a) != len(mesh.faces) for a in (v.colours, v.uv, v.texture_index, v.faces)):
        raise ValueError(f"mesh.metadata[{VISUAL_KEY!r}] holds attributes of another mesh "
                         f"(its arrays do not have one row per face, {len(mesh.faces)})")
    return aligned_visual(v, mesh, f"mesh.metadata[{VISUAL_KEY!r}]")


def _bilinear(image, uv, sampler=DEFAULT_SAMPLER) -> np.ndarray:
    """Bilinear lookup of (h, w, 3) ``image`` at (N, 2) ``uv`` (repeat wrap, v up), (N, 3) float64; another
    glTF sampler by :func:`pyshadow.gltf_materials.sample`."""
    if tuple(sampler) != DEFAULT_SAMPLER:
        return sample(image, uv, tuple(sampler))
    h, w = image.shape[:2]
    x = np.mod(uv[:, 0], 1.0) * w - 0.5
    y = (1.0 - np.mod(uv[:, 1], 1.0)) * h - 0.5
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    i0, j0 = np.mod(y0.astype(np.int64), h), np.mod(x0.astype(np.int64), w)
    i1, j1 = np.mod(i0 + 1, h), np.mod(j0 + 1, w)
    tap = (lambda i, j: image[i, j].astype(np.float64))      # the taps only, not the whole image, in float64
    return ((1 - fy) * ((1 - fx) * tap(i0, j0) + fx * tap(i0, j1))
            + fy * ((1 - fx) * tap(i1, j0) + fx * tap(i1, j1)))


#: what point_colours names when an attribute of a visual is not finite
_WHAT = {"colours": "colours (of face corners)", "uv": "texture coordinates (UVs of face corners)",
         "texture": "texels of its texture"}


def _check_finite(visual: MeshVisual, name: str) -> None:
    """ValueError naming ``visual.source`` if any value of its attribute ``name`` (corner colours, UVs or
    texels) is not finite (NaN or inf in float file data: NaN colours); refused whatever faces are asked,
    so a render fails or not whatever it sees. With :attr:`MeshVisual.textures`: every image, and the
    UVs of the faces that have a texture."""
    ok = visual._finite.get(name)
    if ok is None:
        ok = visual._finite[name] = all(bool(np.isfinite(a).all()) for a in _checked(visual, name))
    if not ok:
        arrays = _checked(visual, name)
        bad = sum(int((~np.isfinite(a).all(axis=-1)).sum()) for a in arrays)
        n = sum(a.shape[0] * a.shape[1] if name == "texture" else a.shape[0] * 3 for a in arrays)
        raise ValueError(f"{visual.source}: {bad} of {n} {_WHAT[name]} are not finite (NaN or inf)"
                         + (": its texture cannot be applied" if name == "uv" else ""))


def _check_arrays(visual: MeshVisual, name: str) -> None:
    """TypeError or ValueError naming ``name`` where an array of ``visual`` is not of its documented form
    (:class:`MeshVisual`): colours (T, 3, 3), UVs (T, 3, 2) and textures (h, w, 3), h, w >= 1, of floats
    (8-bit data read as floats was 255 times too bright), texture indices of integers, a factor of three
    finite numbers >= 0."""
    want = {"colours": (3, 3), "uv": (3, 2)}
    arrays = [(k, getattr(visual, k), want[k]) for k in want]
    arrays += [("texture", t, None) for t in (visual.texture, *visual.textures)]
    for key, a, tail in arrays:
        if a is None:
            continue
        a = np.asarray(a)
        if a.dtype.kind != "f":
            what = "texture coordinates" if key == "uv" else "linear RGB in [0, 1], not 8-bit values"
            raise TypeError(f"{name}: {key} must be floats ({what}), got dtype {a.dtype}")
        if tail is None and not (a.ndim == 3 and a.shape[2] == 3 and a.shape[0] >= 1 and a.shape[1] >= 1):
            raise ValueError(f"{name}: a texture must be an RGB image of shape (h, w, 3), h, w >= 1, "
                             f"got shape {a.shape}")
        if tail is not None and (a.ndim != 3 or a.shape[1:] != tail):
            raise ValueError(f"{name}: {key} must have shape (T, {tail[0]}, {tail[1]}), got {a.shape}")
    if visual.faces is not None and np.asarray(visual.faces).dtype.kind not in "iu":
        raise TypeError(f"{name}: faces must be integer vertex ids, got dtype {np.asarray(visual.faces).dtype}")
    if visual.faces is not None and (np.ndim(visual.faces) != 2 or np.shape(visual.faces)[1] != 3):
        raise ValueError(f"{name}: faces must have shape (T, 3), got {np.shape(visual.faces)}")
    if visual.texture_index is not None and np.asarray(visual.texture_index).dtype.kind not in "iu":
        raise TypeError(f"{name}: texture_index must be integers, got dtype "
                        f"{np.asarray(visual.texture_index).dtype}")
    factor = np.asarray(visual.factor)
    if factor.dtype.kind not in "fiu" or factor.shape != (3,) or not (np.isfinite(factor).all()
                                                                      and (factor >= 0).all()):
        raise ValueError(f"{name}: factor must be three finite numbers >= 0 (linear RGB), got {visual.factor!r}")


def _checked(visual: MeshVisual, name: str) -> list:
    """The arrays :func:`_check_finite` checks for ``name``."""
    if visual.texture_index is not None and name == "texture":
        return list(visual.textures)
    if visual.texture_index is not None and name == "uv":
        return [visual.uv[visual.texture_index >= 0]]
    return [getattr(visual, name)]


def point_colours(visual: MeshVisual | None, faces, bary) -> np.ndarray:
    """Linear RGB surface colour of points on a mesh, (N, 3) float64 (module docstring).

    Parameters
    ----------
    visual : MeshVisual or None
        None: ones. Its colours, and with a texture its UVs and texels,
        must be finite (ValueError naming its source otherwise).
    faces : ndarray, shape (N,), int
        Face index of each point.
    bary : ndarray, shape (N, 3)
        Its barycentric coordinates in that face (:func:`barycentrics`).
    """
    f = np.asarray(faces, dtype=np.int64)
    out = np.ones((len(f), 3))
    if visual is None or len(f) == 0:
        return out
    _check_arrays(visual, visual.source)
    b = np.asarray(bary, dtype=np.float64)
    if visual.colours is not None:
        _check_finite(visual, "colours")
        out *= np.einsum("nk,nkc->nc", b, visual.colours[f].astype(np.float64))
    if visual.uv is not None and (visual.texture is not None or visual.texture_index is not None):
        _check_finite(visual, "uv")
        _check_finite(visual, "texture")
        uv = np.einsum("nk,nkc->nc", b, visual.uv[f].astype(np.float64))
        if visual.texture_index is None:
            out *= _bilinear(visual.texture, uv, visual.sampler)
        else:                                   # a joined scene: each face its part's texture, or none
            which = visual.texture_index[f]
            for k in np.unique(which[which >= 0]):
                sel = which == k
                out[sel] *= _bilinear(visual.textures[k], uv[sel], visual.samplers[k] if visual.samplers
                                      else DEFAULT_SAMPLER)
    return out * np.asarray(visual.factor, np.float64)


def surface_colours(items, item, face, bary) -> np.ndarray:
    """:func:`point_colours` of points on several drawn meshes, (N, 3) float64.

    ``items`` the drawn ``(mesh, transform)`` pairs; ``item``, ``face``
    (N,) int and ``bary`` (N, 3) as :func:`pyshadow.shading_normals.pixel_surface`
    returns them. Points on meshes without a :class:`MeshVisual` get ones.
    """
    from .gbuffer_items import pixels_by_item

    item = np.asarray(item, dtype=np.int64)
    out = np.ones((len(item), 3))
    for i, sel in pixels_by_item(item):
        visual = visual_of(items[i][0])
        if visual is not None:
            out[sel] = point_colours(visual, np.asarray(face)[sel], np.asarray(bary)[sel])
    return out

"""Surface colours of meshes: vertex colours and textures kept by :func:`pyshadow.load_mesh` (issue 19).

:func:`pyshadow.load_mesh` merges coincident vertices and so loses the
per-vertex visual attributes of the file (a UV seam or a colour edge splits
a vertex). It keeps them apart from the geometry instead, per *face
corner*, in a :class:`MeshVisual` stored as ``mesh.metadata["pyshadow_visual"]``
(:data:`VISUAL_KEY`; absent when the file has neither colours nor UVs).
Vertices, faces and :func:`pyshadow.mesh_hash` are exactly those of a load
without it, so CSMs and caches do not change.

Colour convention: linear RGB in [0, 1]. Colours of files (vertex and
face colours, texture images, an OBJ material's ``Kd``) are sRGB-encoded
and decoded with :func:`pyshadow.io.srgb_to_linear`; alpha is ignored.
Integer data is 8-bit (over 255) except 16 bit (over 65535: a 16-bit
greyscale PNG, glTF's unsigned short ``COLOR_0``); float data (glTF's float
``COLOR_0``) is in [0, 1] already. Colours that are not finite are
refused like such UVs (below).

The colour of a surface point (:func:`point_colours`) is the product of
what its mesh has, as glTF defines a base colour: the barycentric
interpolation of its face's corner colours, times the texture's bilinear
sample at the interpolated UV (repeat wrap; ``v = 0`` is the image's
bottom row), times the material's base colour factor. UVs that are not
finite (an OBJ's ``vt nan nan``) are kept by :func:`pyshadow.load_mesh`
(the geometry, shadows and AO do not need them) and refused with a
ValueError naming the source where the texture is applied. A lit render
multiplies it by the instance's albedo (:class:`pyshadow.lighting.Lighting`'s
``albedo``/``albedos``); a mesh without a :class:`MeshVisual` contributes 1.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

__all__ = ["MeshVisual", "VISUAL_KEY", "mesh_visual", "visual_of", "point_colours", "surface_colours", "barycentrics"]

#: Key of :attr:`trimesh.Trimesh.metadata` under which :func:`pyshadow.load_mesh` keeps a :class:`MeshVisual`.
VISUAL_KEY = "pyshadow_visual"


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
    """

    colours: np.ndarray | None
    uv: np.ndarray | None
    texture: np.ndarray | None
    factor: np.ndarray
    source: str = "mesh"
    # which of colours, uv and texture hold only finite values: found once per visual (a copy made by
    # take or with_fans finds its own), not on every point_colours call
    _finite: dict = field(default_factory=dict, init=False, repr=False)

    def take(self, faces) -> "MeshVisual":
        """The attributes of the faces ``faces`` (index or boolean mask), in that order."""
        pick = (lambda a: None if a is None else np.ascontiguousarray(a[faces]))
        return replace(self, colours=pick(self.colours), uv=pick(self.uv))

    def with_fans(self, faces: np.ndarray, loops) -> "MeshVisual":
        """Extended by the fan faces :func:`pyshadow.mesh.close_holes` appends, in its order.

        The fan face ``(b, a, centre)`` of the boundary edge ``(a, b)`` of face
        ``f`` takes ``f``'s corner attributes at ``a`` and ``b``; the centre
        takes the mean of the loop's.
        """
        where = {}
        for k in range(3):
            for f, (a, b) in enumerate(zip(faces[:, k].tolist(), faces[:, (k + 1) % 3].tolist())):
                where[(a, b)] = (f, k, (k + 1) % 3)
        parts = {"colours": [], "uv": []}
        for loop in loops:
            if len(loop) < 3:
                continue
            hit = [where[e] for e in loop]
            for name in parts:
                arr = getattr(self, name)
                if arr is None:
                    continue
                at_a = np.stack([arr[f, ka] for f, ka, _ in hit])
                at_b = np.stack([arr[f, kb] for f, _, kb in hit])
                centre = np.broadcast_to(at_a.mean(axis=0), at_a.shape)
                parts[name].append(np.stack([at_b, at_a, centre], axis=1).astype(np.float32))
        grow = (lambda a, extra: a if a is None or not extra else np.concatenate([a, *extra]))
        return replace(self, colours=grow(self.colours, parts["colours"]), uv=grow(self.uv, parts["uv"]))


def _linear(rgb) -> np.ndarray:
    """sRGB-encoded (..., >= 3) -> linear float32 (..., 3); non-finite values -> NaN (module docstring).

    uint16 is over 65535, float as it is (clipped to [0, 1]), any other type over 255.
    """
    from .io import srgb_to_linear

    a = np.asarray(rgb)[..., :3]
    scale = 1.0 if a.dtype.kind == "f" else 65535.0 if a.dtype == np.uint16 else 255.0
    a = a.astype(np.float64)
    ok = np.isfinite(a)
    return np.where(ok, srgb_to_linear(np.where(ok, a, 0.0) / scale), np.nan).astype(np.float32)


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


def _texture(material, sample: bool = True):
    """(image (h, w, 3) float32 linear or None, factor (3,) float32) of a trimesh material.

    ``sample=False``: the factor only (no UVs to apply an image with); the image still decides
    whether a SimpleMaterial's ``diffuse`` counts (only without any image: trimesh writes its
    placeholder image with its default grey as ``map_Kd`` and ``Kd``).
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
    return _linear(_image(image)), factor


def _placeholder(image) -> bool:
    """Is ``image`` the uniform image trimesh invents for UVs without a material (``empty_material``)?"""
    from trimesh.visual.material import color_image

    blank = np.asarray(color_image())
    got = np.asarray(image)
    return got.shape == blank.shape and bool(np.array_equal(got, blank))


def mesh_visual(mesh, source: str = "mesh") -> MeshVisual | None:
    """The :class:`MeshVisual` of a trimesh as loaded (before merging), or None if it has none.

    Parameters
    ----------
    mesh : trimesh.Trimesh
        Its ``visual``: :class:`trimesh.visual.ColorVisuals` with vertex or
        face colours, or :class:`trimesh.visual.TextureVisuals` with UVs
        (and a material image or glTF ``COLOR_0`` colours) or a material
        colour (glTF ``baseColorFactor``, OBJ ``Kd``; with or without UVs).
        The uniform image trimesh makes up for UVs without a material file
        is not a texture (ignored).
    source : str, optional
        What it was read from (:attr:`MeshVisual.source`).
    """
    import trimesh

    visual = getattr(mesh, "visual", None)
    faces = np.asarray(mesh.faces, dtype=np.int64)
    if visual is None or len(faces) == 0:
        return None
    colours = uv = texture = None
    factor = np.ones(3, np.float32)
    if isinstance(visual, trimesh.visual.ColorVisuals):
        if visual.kind == "vertex":
            colours = _linear(visual.vertex_colors)[faces]
        elif visual.kind == "face":
            colours = np.repeat(_linear(visual.face_colors)[:, None, :], 3, axis=1)
    elif isinstance(visual, trimesh.visual.TextureVisuals):
        has_uv = visual.uv is not None and len(visual.uv) == len(mesh.vertices)
        texture, factor = _texture(visual.material, sample=has_uv)
        if has_uv:
            uv = np.asarray(visual.uv, dtype=np.float32)[faces]
        col = visual.vertex_attributes.get("color") if hasattr(visual, "vertex_attributes") else None
        if col is not None and len(col) == len(mesh.vertices):
            colours = _linear(col)[faces]
    if colours is None and uv is None and bool((factor == 1).all()):
        return None
    return MeshVisual(colours, uv, texture, factor, str(source))


def visual_of(mesh) -> MeshVisual | None:
    """The :class:`MeshVisual` kept on ``mesh`` (``mesh.metadata[VISUAL_KEY]``), or None."""
    v = getattr(mesh, "metadata", {}).get(VISUAL_KEY)
    if v is None:
        return None
    if not isinstance(v, MeshVisual):
        raise TypeError(f"mesh.metadata[{VISUAL_KEY!r}] must be a pyshadow.materials.MeshVisual, "
                        f"got {type(v).__name__}")
    if any(a is not None and len(a) != len(mesh.faces) for a in (v.colours, v.uv)):
        raise ValueError(f"mesh.metadata[{VISUAL_KEY!r}] holds attributes of another mesh "
                         f"(its arrays do not have one row per face, {len(mesh.faces)})")
    return v


def barycentrics(points, triangles) -> np.ndarray:
    """Barycentric coordinates of points in the plane of their triangles, (N, 3) float64.

    Parameters
    ----------
    points : ndarray, shape (N, 3)
        Points on (or near) the triangles, any frame.
    triangles : ndarray, shape (N, 3, 3)
        Corners ``a, b, c`` in the same frame.

    Returns
    -------
    ndarray, shape (N, 3), float64
        Weights of ``a, b, c`` for the point's projection onto the plane,
        clamped to [0, 1] and renormalised to sum 1 (a pixel centre lies in
        its triangle up to the G-buffer's float32 depth).
    """
    p = np.asarray(points, dtype=np.float64)
    t = np.asarray(triangles, dtype=np.float64)
    e1, e2, d = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0], p - t[:, 0]
    d11, d12, d22 = (np.einsum("ij,ij->i", x, y) for x, y in ((e1, e1), (e1, e2), (e2, e2)))
    d1, d2 = np.einsum("ij,ij->i", d, e1), np.einsum("ij,ij->i", d, e2)
    den = d11 * d22 - d12 * d12
    den = np.where(den > 0, den, 1.0)
    v = (d22 * d1 - d12 * d2) / den
    w = (d11 * d2 - d12 * d1) / den
    b = np.maximum(np.column_stack([1.0 - v - w, v, w]), 0.0)
    s = b.sum(axis=1, keepdims=True)
    return np.where(s > 0, b / np.where(s > 0, s, 1.0), 1.0 / 3.0)


def _bilinear(image, uv) -> np.ndarray:
    """Bilinear lookup of (h, w, 3) ``image`` at (N, 2) ``uv`` (repeat wrap, v up), (N, 3) float64."""
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
    so a render fails or not whatever it sees."""
    a = getattr(visual, name)
    ok = visual._finite.get(name)
    if ok is None:
        ok = visual._finite[name] = bool(np.isfinite(a).all())
    if not ok:
        bad = int((~np.isfinite(a).all(axis=-1)).sum())
        n = a.shape[0] * a.shape[1] if name == "texture" else a.shape[0] * 3
        raise ValueError(f"{visual.source}: {bad} of {n} {_WHAT[name]} are not finite (NaN or inf)"
                         + (": its texture cannot be applied" if name == "uv" else ""))


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
    b = np.asarray(bary, dtype=np.float64)
    if visual.colours is not None:
        _check_finite(visual, "colours")
        out *= np.einsum("nk,nkc->nc", b, visual.colours[f].astype(np.float64))
    if visual.uv is not None and visual.texture is not None:
        _check_finite(visual, "uv")
        _check_finite(visual, "texture")
        uv = np.einsum("nk,nkc->nc", b, visual.uv[f].astype(np.float64))
        out *= _bilinear(visual.texture, uv)
    return out * visual.factor.astype(np.float64)


def surface_colours(items, item, face, bary) -> np.ndarray:
    """:func:`point_colours` of points on several drawn meshes, (N, 3) float64.

    ``items`` the drawn ``(mesh, transform)`` pairs; ``item``, ``face``
    (N,) int and ``bary`` (N, 3) as :func:`pyshadow.shading_normals.pixel_surface`
    returns them. Points on meshes without a :class:`MeshVisual` get ones.
    """
    item = np.asarray(item, dtype=np.int64)
    out = np.ones((len(item), 3))
    for i in np.unique(item):
        visual = visual_of(items[i][0])
        if visual is not None:
            sel = np.flatnonzero(item == i)
            out[sel] = point_colours(visual, np.asarray(face)[sel], np.asarray(bary)[sel])
    return out

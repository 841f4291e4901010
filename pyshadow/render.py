"""The render stage: a scene and a camera in, a :class:`Frame` of per-pixel buffers out.

Stage "render" of the pipeline (README.md, the table of stages). The G-buffer is rasterised
(:func:`pyshadow.render_gbuffer`; or any G-buffer of the same form, e.g.
Embree's), the covered pixels become surface points (:func:`surface_points`,
the one place that does so), their AO and bent normals come from a
visibility backend (:mod:`pyshadow.visibility`), and an edge-aware filter
may denoise the AO image (:mod:`pyshadow.filters`).
"""
from __future__ import annotations

import numbers
from collections.abc import Mapping
from dataclasses import dataclass, fields

import numpy as np

from .ao_pass import ao_pass
from .camera import check_camera, points_on_rays
from .materials import visual_of
from .sampling import Sampling
from .scene_arrays import scene_arrays
from .shading_normals import DEFAULT_CREASE_ANGLE, NORMAL_MODES, check_crease_angle

__all__ = ["Frame", "SurfacePoints", "render", "surface_points", "covered_pixels", "draw_items", "ground_quad",
           "DENOISERS"]

#: Names accepted by ``denoise=``: the filters of :mod:`pyshadow.filters`.
DENOISERS = ("bilateral", "separable", "box")
#: Low-res taps per side of the upsampling of ``ao_scale`` > 1 (:func:`pyshadow.filters.upsample`'s ``radius``).
_UPSAMPLE_RADIUS = 2


@dataclass(eq=False)
class Frame(Mapping):
    """Per-pixel buffers of one rendered image; also readable as a mapping (``frame["ao"]``).

    Attributes
    ----------
    ao : ndarray, shape (H, W), float32
        Ambient occlusion in [0, 1], 1 on the background; NaN where not asked (``lighting`` of :func:`render`).
    bent_normal : ndarray, shape (H, W, 3), float32
        World-frame bent normals, 0 on the background. With ``ao_scale`` > 1
        only the AO pass's pixels hold theirs (every ``ao_scale``-th pixel of
        every ``ao_scale``-th row, and covered pixels whose upsampling window
        holds no such pixel on their own surface: :func:`pyshadow.ao_pass.ao_pass`); the other
        covered pixels hold 0. The lighting stage upsamples them like the AO where it needs
        them (the sky term);
        :func:`pyshadow.filters.upsample` of each channel with ``fill=0``
        does the same for a caller.
    depth : ndarray, shape (H, W), float32
        Distance along the eye ray (world units), ``inf`` on the background.
    normal : ndarray, shape (H, W, 3), float32
        World normals facing the camera: the shading normals AO and
        shading used (the G-buffer's face normals with ``normals="flat"``,
        interpolated ones with ``normals="smooth"``), 0 on the background.
    object_id : ndarray, shape (H, W), int32
        Instance id; ``pyshadow.scene.GROUND_ID`` (-2) for the ground, -1
        for the background.
    position : ndarray, shape (H, W, 3), float32
        World positions (NaN on the background).
    geometric_normal : ndarray, shape (H, W, 3), float32, or None
        With ``normals="smooth"``: the G-buffer's face normals (facing the
        camera); None otherwise (then not among the mapping's keys).
    radiance : ndarray, shape (H, W, 3), float32, or None
        Linear radiance, where a lighting stage fills it; None otherwise
        (then not among the mapping's keys). With a
        :class:`~pyshadow.lighting.phong.PhongLighting`: thesis 000's
        display-referred colour instead (:mod:`pyshadow.lighting.phong`).
    """

    ao: np.ndarray
    bent_normal: np.ndarray
    depth: np.ndarray
    normal: np.ndarray
    object_id: np.ndarray
    position: np.ndarray
    geometric_normal: np.ndarray | None = None
    radiance: np.ndarray | None = None

    def _keys(self):
        return [f.name for f in fields(self) if getattr(self, f.name) is not None]

    def __getitem__(self, key):
        if key not in self._keys():
            raise KeyError(key)
        return getattr(self, key)

    def __iter__(self):
        return iter(self._keys())

    def __len__(self) -> int:
        return len(self._keys())

    @property
    def shape(self) -> tuple[int, int]:
        """(H, W)."""
        return self.ao.shape


@dataclass(eq=False)
class SurfacePoints:
    """The covered pixels of a G-buffer as surface points.

    Attributes
    ----------
    gbuffer : dict
        The G-buffer (:func:`pyshadow.render_gbuffer`'s form).
    object_id : ndarray, shape (H, W), int32
        Instance id per pixel (the G-buffer's item index mapped through the
        drawn items), ``GROUND_ID`` (-2) for the ground, -1 background.
    index : ndarray, shape (K,), int64
        Flat pixel index ``r * W + c`` of each point (its sample-pattern index).
    points : ndarray, shape (K, 3), float64
        World positions ``eye + depth * ray direction``; on the plane of the pixel's face in float64
        where the float32 depth could miss it (:func:`pyshadow.gbuffer.on_face_planes`: renders for
        Embree, and from a camera far from the scene, whose ``gbuffer`` then holds float64 depths).
    normals : ndarray, shape (K, 3), float32
        World normals facing the camera.
    surface_ids : ndarray, shape (K,), int32
        Instance id of each point's surface.
    """

    gbuffer: dict
    object_id: np.ndarray
    index: np.ndarray
    points: np.ndarray
    normals: np.ndarray
    surface_ids: np.ndarray


def ground_quad(scene, size: float | None = None):
    """A finite square of the scene's ground plane for drawing, centred under the scene.

    Parameters
    ----------
    scene : pyshadow.Scene
        Must have a ground plane.
    size : float, optional
        Side length (world units); default 8 times the diameter of the
        region the instances occupy (at least 8 times the largest radius).

    Returns
    -------
    trimesh.Trimesh
        Two triangles at ``y = scene.ground``, facing up.
    """
    import trimesh

    if scene.ground is None:
        raise ValueError("the scene has no ground plane")
    anchor = scene.anchor()
    if size is None:                    # the instances' world spheres, stacked once per scene change
        held = scene_arrays(scene)      # (as Instance.world_sphere gives them, bit for bit)
        c, r = held["world_centre"][held["live"]], held["world_radius"][held["live"]]    # (not those removed)
        # the largest norm(c - anchor) + r: every row near the largest (within far more than the rounding
        # of a vectorised norm) taken again with np.linalg.norm itself, so the same float as row by row
        with np.errstate(over="ignore", invalid="ignore"):
            near = np.sqrt(((c - anchor) ** 2).sum(axis=1)) + r
        top = near.max(initial=-np.inf)
        rows = np.flatnonzero(~(near < top - 1e-9 * abs(top))) if np.isfinite(top) else np.arange(len(r))
        reach = max([np.linalg.norm(c[i] - anchor) + r[i] for i in rows] or [1.0])
        size = 16.0 * reach
    if isinstance(size, bool) or not isinstance(size, (int, float, np.integer, np.floating)) or not (
            _finite_float(size) and size > 0):
        raise ValueError(f"ground_size must be a finite number > 0 (world units), got {size!r}")
    h = 0.5 * float(size)
    cx, cz = anchor[0], anchor[2]
    v = np.array([[cx - h, scene.ground, cz - h], [cx + h, scene.ground, cz - h],
                  [cx + h, scene.ground, cz + h], [cx - h, scene.ground, cz + h]])
    if not (v[1, 0] > v[0, 0] and v[2, 2] > v[1, 2]):      # a quad of no area draws no ground
        raise ValueError(f"ground_size {size!r} is too small to draw at the scene's anchor {anchor.tolist()}: "
                         f"the quad's corners coincide in float64")
    return trimesh.Trimesh(v, [[0, 2, 1], [0, 3, 2]], process=False)


def _finite_float(x) -> bool:
    """Whether the real number ``x`` is finite as a float (a Python int beyond float64's range is not)."""
    try:
        return bool(np.isfinite(float(x)))
    except OverflowError:
        return False


def draw_items(scene, ground_size: float | None = None):
    """What a camera sees of ``scene``: ``[(mesh, transform)]`` and the object id of each, (M,) int32.

    Every instance that has a mesh (its instance id), then the ground quad
    (:func:`ground_quad`, id ``GROUND_ID``) if the scene has a ground plane.
    """
    from .scene import GROUND_ID

    items, ids = [], []
    for i, inst in enumerate(scene.instances):
        if inst.mesh is not None:
            items.append((inst.mesh, inst.transform))
            ids.append(i)
    if scene.ground is not None:
        items.append((ground_quad(scene, ground_size), np.eye(4)))
        ids.append(GROUND_ID)
    return items, np.array(ids, dtype=np.int32)


def surface_points(scene, camera, *, ground_size=None, ao_scale: int = 1, gbuffer=None) -> SurfacePoints:
    """The pixels of ``camera`` that see a surface of ``scene``, as world points and normals.

    Parameters
    ----------
    scene : pyshadow.Scene
    camera : pyshadow.Camera
    ground_size : float, optional
        Side of the drawn ground quad (:meth:`pyshadow.Scene.ground_quad`).
    ao_scale : {1, 2, 4}, optional
        Keep only every ``ao_scale``-th pixel in each direction (from
        ``(0, 0)``): the points of a reduced-resolution AO pass.
    gbuffer : dict, optional
        A G-buffer of ``scene.draw_items(ground_size)`` seen by ``camera``;
        default :func:`pyshadow.render_gbuffer` of them.
    """
    from .gbuffer import render_gbuffer
    from .visibility import _check_scene

    _check_scene(scene)
    check_camera(camera)
    ao_scale = _check_ao_scale(ao_scale)
    items, ids = scene.draw_items(ground_size)
    g = render_gbuffer(items, camera) if gbuffer is None else _check_gbuffer(gbuffer, camera, len(items))
    obj = _instance_ids(g, ids)
    return covered_pixels(camera, _on_faces(scene, items, g, camera, obj != -1), obj, ao_scale=ao_scale)


def _on_faces(scene, items, g, camera, covered, exact=False, factor=1.0) -> dict:
    """``g``, or a copy whose float64 depths put the covered pixels on their faces' planes: for a ray tracer
    (``exact``), or once a float32 depth's rounding nears ``factor`` times the ground's tolerance (a far camera;
    :func:`render`'s barycentrics: 100, normals then off by up to ~1e-3 rad), over the image's largest tangent
    (beyond 1: a wide image), a margin from when the kernel's pixel ray rounded by a float32 spacing times it."""
    from .contact import ground_tolerance
    from .gbuffer import on_face_planes

    wide = max(1.0, camera.tan_half * max(1.0, camera.aspect))
    return on_face_planes(items, g, camera, covered, 0.0 if exact else factor * ground_tolerance(scene) / wide)


def _instance_ids(g, ids) -> np.ndarray:
    """(H, W) int32: the G-buffer's item indices mapped through the drawn items' ids ``ids``, -1 background."""
    hit = g["object_id"] >= 0
    return np.where(hit, ids[np.maximum(g["object_id"], 0)] if len(ids) else -1, -1).astype(np.int32)


def _check_gbuffer(g, camera, n_items: int, *, frame: bool = False) -> dict:
    """A G-buffer given to :func:`surface_points` checked (the camera's shape, float buffers, item indices in range,
    a depth > 0 on covered pixels; ``frame``: also positions), its background's depth +inf (a copy if not: 0, NaN)."""
    H, W = camera.height, camera.width
    want = {"object_id": (H, W), "depth": (H, W), "normal": (H, W, 3)}
    if frame:
        want["position"] = (H, W, 3)
    for key, shape in want.items():
        if key not in g:
            raise ValueError(f"gbuffer lacks {key!r} (it needs {', '.join(want)})")
        if np.shape(g[key]) != shape:
            raise ValueError(f"gbuffer[{key!r}] has shape {np.shape(g[key])}; the camera needs {shape}")
        if key != "object_id" and not np.issubdtype(np.asarray(g[key]).dtype, np.floating):
            raise TypeError(f"gbuffer[{key!r}] must be floats, got {np.asarray(g[key]).dtype}")
    oid = np.asarray(g["object_id"])
    if not np.issubdtype(oid.dtype, np.integer):
        raise TypeError(f"gbuffer['object_id'] must be integers, got {oid.dtype}")
    if oid.size and (oid.min() < -1 or oid.max() >= n_items):
        raise ValueError(f"gbuffer['object_id'] holds {int(oid.min())}..{int(oid.max())}; the scene draws "
                         f"{n_items} items (ids 0..{n_items - 1}, -1 for the background)")
    z, back = np.asarray(g["depth"]), oid < 0
    bad = ~(np.isfinite(z) & (z > 0) | back)
    if bad.any():
        raise ValueError(f"gbuffer['depth'] must be finite and > 0 where object_id >= 0 (a surface in front of "
                         f"the camera), got {int(bad.sum())} other value(s), e.g. {float(z[bad][0])!r}")
    return g if (z[back] == np.inf).all() else {**g, "depth": np.where(back, np.inf, z)}


def _check_ao_scale(ao_scale) -> int:
    if isinstance(ao_scale, (bool, np.bool_)) or not isinstance(ao_scale, numbers.Integral) \
            or ao_scale not in (1, 2, 4):
        raise ValueError(f"ao_scale must be 1, 2 or 4, got {ao_scale!r}")
    return int(ao_scale)


def covered_pixels(camera, gbuffer, object_id, *, ao_scale: int = 1) -> SurfacePoints:
    """The pixels whose ``object_id`` is not -1 (background), as :class:`SurfacePoints`.

    Parameters
    ----------
    camera : pyshadow.Camera
    gbuffer : dict or Frame
        Holds ``depth`` (H, W) and ``normal`` (H, W, 3) as seen by ``camera``.
    object_id : ndarray, shape (H, W), int32
        Instance ids (``GROUND_ID`` for the ground), -1 for the background.
    ao_scale : {1, 2, 4}, optional
        As in :func:`surface_points`.
    """
    check_camera(camera)
    ao_scale = _check_ao_scale(ao_scale)
    H, W = camera.height, camera.width
    for name, a, shape in (("object_id", object_id, (H, W)), ("gbuffer['depth']", gbuffer["depth"], (H, W)),
                           ("gbuffer['normal']", gbuffer["normal"], (H, W, 3))):
        if np.shape(a) != shape:        # a transposed image, or another camera's, picked other pixels
            raise ValueError(f"{name} has shape {np.shape(a)}; the camera needs {shape}")
    hit = object_id != -1
    if ao_scale != 1:
        sub = np.zeros((camera.height, camera.width), bool)
        sub[::ao_scale, ::ao_scale] = True
        hit = hit & sub
    return _points_at(camera, gbuffer, object_id, hit)


def _points_at(camera, gbuffer, object_id, keep) -> SurfacePoints:
    """:class:`SurfacePoints` of the pixels where the (H, W) bool ``keep`` is True (covered ones)."""
    H, W = camera.height, camera.width
    sel = np.flatnonzero(keep.reshape(-1))
    every = len(sel) == H * W                   # no background: sel is every pixel, in order

    def pick(a, k, copy=True):                  # a's values at sel, rows of k (np.take: indexing is slower)
        a = np.asarray(a).reshape(H * W, k) if k > 1 else np.asarray(a).reshape(-1)
        return (a.copy() if copy else a) if every else np.take(a, sel, axis=0)

    dirs = pick(camera._rays(), 3, copy=False)
    depth = pick(gbuffer["depth"], 1, copy=False).astype(np.float64)
    return SurfacePoints(gbuffer=gbuffer, object_id=object_id, index=sel,
                         points=points_on_rays(camera.eye, depth, dirs),
                         normals=pick(gbuffer["normal"], 3), surface_ids=pick(object_id, 1))


def _put_pixels(image, index, values) -> None:
    """``image.reshape(H * W, -1)[index] = values`` for an (H, W) or (H, W, k) image and the
    sorted, distinct flat pixel indices ``index`` (:attr:`SurfacePoints.index`).

    One copy where ``index`` is every pixel (a frame without background), whole rows moved as
    bytes otherwise (NumPy's indexing by rows is slower); the values are cast to the image's
    dtype as the assignment casts them.
    """
    if not image.flags.c_contiguous:
        raise ValueError("_put_pixels writes into a C-contiguous image")
    flat = image.reshape(image.shape[0] * image.shape[1], -1)
    vals = np.asarray(values, dtype=image.dtype).reshape(len(index), flat.shape[1])
    if len(index) == len(flat):             # sorted and distinct: every pixel, in order
        flat[...] = vals
        return
    row = np.dtype((np.void, flat.shape[1] * flat.itemsize))
    flat.view(row).reshape(-1)[index] = np.ascontiguousarray(vals).view(row).reshape(-1)


def _check_render_options(denoise, ao_scale, sampling):
    if denoise is not None and not (isinstance(denoise, str) and denoise in DENOISERS):   # an array: no truth value
        raise ValueError(f"denoise must be None, 'bilateral', 'separable' or 'box', got {denoise!r}")
    ao_scale = _check_ao_scale(ao_scale)
    if sampling is None:
        return ao_scale, Sampling()
    if not isinstance(sampling, Sampling):
        raise TypeError(f"sampling must be a pyshadow.Sampling, got {sampling!r}")
    return ao_scale, sampling


def render(scene, camera, *, visibility="csm", sampling=None, denoise=None, ao_scale: int = 1,
           ground_size=None, bias=None, gbuffer=None, lighting=None, normals: str = "flat",
           crease_angle: float = DEFAULT_CREASE_ANGLE) -> Frame:
    """Render AO, bent normals and the G-buffer of ``scene`` from ``camera``.

    Parameters
    ----------
    scene : pyshadow.Scene
    camera : pyshadow.Camera
    visibility : str or VisibilityBackend, optional
        Who answers the AO rays (:mod:`pyshadow.visibility`): ``"csm"``,
        ``"csm-vote"``, ``"numpy"``, ``"embree"`` or a registered name.
    sampling : pyshadow.Sampling, optional
        Default ``Sampling()``; pixel ``(r, c)`` uses pattern index ``r * W + c``.
    denoise : {None, 'bilateral', 'separable', 'box'}, optional
        Edge-aware filtering of the AO image (:mod:`pyshadow.filters`).
    ao_scale : {1, 2, 4}, optional
        Compute AO at 1/ao_scale resolution and upsample it with the
        full-resolution G-buffer (joint bilateral upsampling,
        :func:`pyshadow.filters.upsample`; bent normals: ``Frame``). A covered pixel whose
        upsampling window holds no low-res pixel on its own surface (:func:`pyshadow.ao_pass.ao_pass`:
        a thin object, a face seen edge-on, a tiny image) gets its own AO, not another surface's or ``fill``.
    ground_size : float, optional
        Side of the drawn ground quad (:meth:`pyshadow.Scene.ground_quad`).
    bias : float, optional
        As in :func:`pyshadow.visibility.visible`.
    gbuffer : dict, optional
        A G-buffer to use instead of rasterising one (e.g.
        :func:`pyshadow.embree.gbuffer`): ``object_id``, ``depth``, ``normal``
        and ``position`` of the camera's shape, the depth finite and > 0 on
        every covered pixel (on the background, any depth is taken as +inf).
    lighting : pyshadow.lighting.Lighting, optional
        Fill ``Frame.radiance`` (H, W, 3) float32, linear, 0 on the
        background: the sky term from the frame's (filtered, upsampled) AO
        and its bent normals (mode "bent"), or along the AO directions of
        each covered pixel (modes "transfer" and "sampled", at full
        resolution), the sun term from one ``visible`` query per
        covered pixel on the same ``visibility`` backend (:mod:`pyshadow.lighting.shade`). Every other buffer
        is the same as without it, but where ``visibility`` answers no AO (``ShadowMapVisibility``) and the
        lighting needs none (no sky; ``PhongLighting(ao="off")``) ``Frame.ao`` and ``bent_normal`` are NaN on
        covered pixels (a lighting needing AO is refused there). The albedo of a pixel is its instance's
        (``Lighting(albedo=, albedos=)``) times its mesh's colour (vertex colours, texture: :mod:`pyshadow.materials`).
        A :class:`pyshadow.lighting.phong.PhongLighting` instead fills it
        with thesis 000's display-referred colour ``c`` (eq. 3.2: a point
        light with Phong specular towards ``camera.eye``, the ambient term
        weighted by the frame's AO, or constant, or one shadow sample along
        the normal; the light's shadow on the same ``visibility`` backend),
        not radiance in :class:`~pyshadow.lighting.Lighting`'s units.
    normals : {"flat", "smooth"}, optional
        Shading normals: the G-buffer's face normals ("flat", the default),
        or normals interpolated from the mesh's corners with creases kept
        sharp ("smooth", :mod:`pyshadow.shading_normals`). With "smooth",
        AO, bent normals, filters and shading use them, directions below a
        pixel's geometric plane count as occluded on every backend, and
        ``Frame.geometric_normal`` holds the face normals. A given
        ``gbuffer`` then needs its ``face`` buffer.
    crease_angle : float, optional
        Radians in [0, pi/2) (default :data:`pyshadow.shading_normals.DEFAULT_CREASE_ANGLE`,
        30 degrees): faces meeting at a larger angle keep a sharp edge with
        ``normals="smooth"``.

    Returns
    -------
    Frame
    """
    from . import visibility as vis
    from .gbuffer import render_gbuffer

    vis._check_scene(scene)         # a (scene, camera) pair, a mesh, None: AttributeErrors from inside
    check_camera(camera)
    ao_scale, sampling = _check_render_options(denoise, ao_scale, sampling)
    if not (isinstance(normals, str) and normals in NORMAL_MODES):      # an array's ``in`` has no truth value
        raise ValueError(f"normals must be 'flat' or 'smooth', got {normals!r}")
    crease_angle = check_crease_angle(crease_angle)
    phong = False
    if lighting is not None:
        from .lighting.phong import PhongLighting
        from .lighting.shade import Lighting, asks_ambient_occlusion, check_albedo_ids
        phong = isinstance(lighting, PhongLighting)
        if not (phong or isinstance(lighting, Lighting)):
            raise TypeError(f"lighting must be a pyshadow.lighting.Lighting or PhongLighting, got {lighting!r}")
        check_albedo_ids(scene, lighting, "render")      # before any AO is traced
    smooth = normals == "smooth"
    colour = surface = None
    drawn, ids = scene.draw_items(ground_size)
    if gbuffer is not None:
        gbuffer = _check_gbuffer(gbuffer, camera, len(drawn), frame=True)
    items = drawn if smooth or lighting is not None else []
    gouraud = phong and lighting.per_vertex
    if smooth or gouraud or any(visual_of(mesh) is not None for mesh, _ in items):
        from .materials import surface_colours
        from .shading_normals import pixel_surface, shading_gbuffer
        gbuffer = render_gbuffer(items, camera) if gbuffer is None else gbuffer
        placed = _on_faces(scene, items, gbuffer, camera, gbuffer["object_id"] >= 0, factor=100.0)  # a far camera
        surface = pixel_surface(items, placed, camera)      # the pixels' faces and barycentrics at those points
        if smooth:
            gbuffer = shading_gbuffer(items, gbuffer, camera, crease_angle, surface)
        if lighting is not None:
            colour = surface_colours(items, *surface[1:])   # the covered pixels in flat order, as covered_pixels
    g = render_gbuffer(drawn, camera) if gbuffer is None else gbuffer
    obj = _instance_ids(g, ids)
    hit = obj != -1
    exact = getattr(vis.get_backend(visibility), "exact_surface_points", False)    # a ray tracer's small lift
    sp = _points_at(camera, _on_faces(scene, drawn, g, camera, hit, exact), obj,
                    hit if ao_scale == 1 else ao_pass(obj, g["depth"], g["normal"], ao_scale, _UPSAMPLE_RADIUS))
    geo = g["geometric_normal"].reshape(-1, 3)[sp.index] if smooth else None
    H, W = camera.height, camera.width
    ao, bent = np.ones((H, W), np.float32), np.zeros((H, W, 3), np.float32)
    transfer, own, asked = None, None, lighting is None or asks_ambient_occlusion(lighting, visibility, "render")
    if not asked:       # a lighting needing no AO, a backend answering none (a shadow map): NaN where covered
        ao[hit], bent[hit] = np.nan, np.nan
    if len(sp.index) and asked:
        one_pass = (lighting is not None and not phong and lighting.mode == "transfer" and ao_scale == 1 and not smooth
                    and hasattr(vis.get_backend(visibility), "sh_transfer"))
        if one_pass:            # the AO kernel's pass that also sums the transfer: AO and bent normals as below
            a, b, transfer = vis.get_backend(visibility).sh_transfer(
                scene, sp.points, sp.normals, sampling=sampling, bias=bias, indices=sp.index,
                surface_ids=sp.surface_ids)
        elif smooth:
            from .shading_normals import ambient_occlusion

            a, b = ambient_occlusion(scene, sp.points, sp.normals, geo, backend=visibility, sampling=sampling,
                                     indices=sp.index, surface_ids=sp.surface_ids, bias=bias)
        else:
            a, b = vis.ambient_occlusion(scene, sp.points, sp.normals, backend=visibility, sampling=sampling,
                                         return_bent_normals=True, bias=bias, indices=sp.index,
                                         surface_ids=sp.surface_ids)
        _put_pixels(ao, sp.index, a)
        _put_pixels(bent, sp.index, b)
    # the Frame's float32 buffers: a given G-buffer's float64 ones rounded (they were float64), float32 ones as they are
    f32 = {k: np.asarray(g[k], np.float32) for k in ("depth", "normal", "position") + ("geometric_normal",) * smooth}
    frame = Frame(ao=ao, bent_normal=bent, depth=f32["depth"], normal=f32["normal"], object_id=sp.object_id,
                  position=f32["position"], geometric_normal=f32.get("geometric_normal"))
    if (ao_scale != 1 or denoise is not None) and asked:
        from . import filters

        if ao_scale != 1:           # the AO pass's pixels off the grid keep their own AO and bent normal
            low = ao[::ao_scale, ::ao_scale]
            frame.ao = filters.upsample(low, g["depth"], g["normal"], scale=ao_scale, radius=_UPSAMPLE_RADIUS)
            own = sp.index[(sp.index // W % ao_scale != 0) | (sp.index % W % ao_scale != 0)]
            frame.ao.reshape(-1)[own] = ao.reshape(-1)[own]
        if denoise == "bilateral":
            frame.ao = filters.bilateral(frame.ao, g["depth"], g["normal"])
        elif denoise == "separable":
            frame.ao = filters.bilateral(frame.ao, g["depth"], g["normal"], separable=True)
        elif denoise == "box":
            frame.ao = filters.edge_aware_box(frame.ao, g["depth"], g["normal"])
    if phong:
        frame.radiance = _phong_radiance(scene, camera, sp, frame, lighting, visibility, bias, ao_scale, colour,
                                         items, surface)
    elif lighting is not None:
        frame.radiance = _radiance(scene, camera, sp, frame, lighting, visibility, bias, ao_scale, sampling,
                                   transfer, colour, own)
    return frame


def _bent_rows(frame, sp, ao_scale, own, index, nrm) -> np.ndarray:
    """(K, 3) float64 bent normals of the covered pixels ``index`` (shading normals ``nrm``) for the
    sky term: the frame's own; with ``ao_scale`` > 1 upsampled from the AO pass's grid like the AO,
    except at the pass's pixels ``own`` off the grid, and made unit (``nrm`` where they cancel)."""
    if ao_scale == 1:
        return np.asarray(frame.bent_normal.reshape(-1, 3)[index], np.float64)
    from . import filters

    g, s = sp.gbuffer, ao_scale
    bent = np.stack([filters.upsample(frame.bent_normal[::s, ::s, c], g["depth"], g["normal"], scale=s,
                                      radius=_UPSAMPLE_RADIUS, fill=0.0) for c in range(3)], axis=2)
    bent.reshape(-1, 3)[own] = frame.bent_normal.reshape(-1, 3)[own]
    b = np.asarray(bent.reshape(-1, 3)[index], np.float64)
    length = np.linalg.norm(b, axis=1, keepdims=True)
    return np.where(length > 1e-6, b / np.maximum(length, 1e-30), nrm)


def _phong_radiance(scene, camera, sp, frame, lighting, visibility, bias, ao_scale, colour, items,
                    surface) -> np.ndarray:
    """``Frame.radiance`` of :func:`render` for a :class:`~pyshadow.lighting.phong.PhongLighting`:
    thesis 000's display colour ``c`` (eq. 3.2 and its modes) of every covered pixel, with the
    frame's (filtered, upsampled) AO and ``e`` towards ``camera.eye``; ``colour``, ``surface``:
    the pixels' mesh colours and :func:`pyshadow.shading_normals.pixel_surface` (or None)."""
    from .lighting.phong import phong_shade, vertex_terms

    out, full, nrm, albedo, geo = _lit_pixels(camera, sp, frame, lighting, ao_scale, colour)
    if full is None:
        return out
    terms = None
    if lighting.per_vertex:
        terms = vertex_terms(items, surface[1], surface[2], surface[3], nrm, camera.eye, lighting)
    c, _, _ = phong_shade(scene, full.points, nrm, camera.eye, lighting, frame.ao.reshape(-1)[full.index],
                          backend=visibility, surface_ids=full.surface_ids, bias=bias, albedo=albedo,
                          geometric_normals=geo, terms=terms)
    out[full.index] = c
    return out.reshape(camera.height, camera.width, 3)


def _lit_pixels(camera, sp, frame, lighting, ao_scale, colour):
    """What both lit paths start from: the zero (H*W, 3) radiance, the covered pixels at full
    resolution, their unit normals (float64), albedos (times ``colour``) and geometric normals (or
    None); ``full`` None (and ``out`` shaped (H, W, 3)) when no pixel is covered."""
    H, W = camera.height, camera.width
    out = np.zeros((H * W, 3), np.float32)
    full = sp if ao_scale == 1 else covered_pixels(camera, sp.gbuffer, sp.object_id)
    if not len(full.index):
        return out.reshape(H, W, 3), None, None, None, None
    nrm = np.asarray(full.normals, np.float64)
    nrm = nrm / np.linalg.norm(nrm, axis=1, keepdims=True)
    albedo = lighting.albedo_of(full.surface_ids, len(full.index))
    if colour is not None:
        albedo = albedo * colour
    geo = None if frame.geometric_normal is None else frame.geometric_normal.reshape(-1, 3)[full.index]
    return out, full, nrm, albedo, geo


def _radiance(scene, camera, sp, frame, lighting, visibility, bias, ao_scale, sampling, transfer,
              colour=None, own=None) -> np.ndarray:
    """``Frame.radiance`` of :func:`render` (see its ``lighting``); ``transfer``: the covered pixels'
    SH transfer when the AO pass summed it already (mode "transfer", full resolution), else None;
    ``colour``: (K, 3) surface colours of every covered pixel (flat order) or None (ones); ``own``: with
    ``ao_scale`` > 1, the flat indices of the AO pass's pixels off its grid (else None). With
    ``Frame.geometric_normal`` set, the hemisphere rule of :mod:`pyshadow.shading_normals` applies."""
    from .lighting.shade import (lights_radiance, sampled_sky_radiance, sky_radiance, sun_radiance, transfer_sky,
                                 transfer_sky_radiance)

    out, full, nrm, albedo, geo = _lit_pixels(camera, sp, frame, lighting, ao_scale, colour)
    if full is None:
        return out
    if transfer is not None or not lighting.has_sky:    # no sky: its term 0, no AO or sky rays read
        sky = 0.0 if transfer is None else transfer_sky(lighting, transfer, albedo)
    elif lighting.mode in ("sampled", "transfer"):     # along the AO directions of every covered pixel
        term = sampled_sky_radiance if lighting.mode == "sampled" else transfer_sky_radiance
        sky = term(scene, full.points, nrm, lighting, albedo, backend=visibility, sampling=sampling,
                   surface_ids=full.surface_ids, indices=full.index, bias=bias, geometric_normals=geo)[0]
    else:
        b = _bent_rows(frame, sp, ao_scale, own, full.index, nrm)     # only this term reads them
        sky = sky_radiance(lighting, frame.ao.reshape(-1)[full.index], b, albedo)
    sun, _ = sun_radiance(scene, full.points, nrm, lighting, albedo, backend=visibility, bias=bias,
                          surface_ids=full.surface_ids, indices=full.index, geometric_normals=geo)
    sun += lights_radiance(scene, full.points, nrm, lighting, albedo, backend=visibility, bias=bias,
                           surface_ids=full.surface_ids, indices=full.index, geometric_normals=geo)
    with np.errstate(over="ignore"):                    # beyond float32: +inf, as shade()'s (no warning)
        out[full.index] = sky + sun
    return out.reshape(camera.height, camera.width, 3)

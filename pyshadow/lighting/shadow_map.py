"""The classic scene shadow map, re-rendered from the light: the baseline a CSM is compared against.

Issue 20 item 4; thesis 001, 4.4.1 (the map and its depth tolerance ε);
lecture 004 (hard shadows, percentage-closer filtering). A
:class:`ShadowMapVisibility` is a visibility backend
(:mod:`pyshadow.visibility.base`): ``pyshadow.visibility.visible(scene,
points, directions, backend=ShadowMapVisibility())`` and the lighting calls
that take ``backend=`` answer through it. It answers rays that belong to one
light:

* rays that share one direction (unbounded: a directional light): an
  orthographic depth map along the light, R x R texels, fitted to the
  rectangle that holds the casters' world bounding spheres seen from the
  light (texels are square only when that rectangle is); casters far apart
  across the light get maps of their own, each point answered by its cell's
  (:mod:`pyshadow.lighting.shadow_fit`: one map over a 1 m box and one 1 km away
  had 0.53 m texels);
* rays that end at one common point (``points + directions * max_distance``
  equal to 1e-6 of the rays' length plus the scene's size: a point or spot
  light): a cube map of six 90 degree faces, R x R texels each, at that point
  (caster faces nearer it than ``NEAR_CUT`` of its reach plus ``NEAR_ULPS`` float64
  spacings of its coordinates are cut: a lamp standing on a face).
  A light whose casters lie in a cone within an eighth of a face (``tan`` of its
  half-angle at most ``FIT_TAN``) or under ``FIT_TEXELS`` texels has its cube turned
  to the cone's axis, the cone widened by the largest power of two ``k`` that keeps
  it in a face: texels, ε's texel term ``k`` times finer; ε + ``FIT_ULPS`` float32
  ulps of depth. (Fitted only under 2 texels, a lamp 100 m from 2 m of casters saw
  them in 4 texels of a 256^2 face, ε 0.8 m: 138 of 2,400 points differed from
  Embree, which shadows 987; 300 m away, 121 at 1024^2, where 256^2, fitted there, had 4.)
  Under ``FAR_TEXELS`` texels (float32 depths from the light hold too little
  there: at 1e7 they are a world unit apart) :meth:`ShadowMapVisibility.visible`
  answers from the orthographic map along the cone's axis instead, each point
  moved across it to where its own ray crosses the casters' mean depth (rays
  of the cone differ from the axis by under its half-angle: the error is below
  ``FAR_TEXELS`` / 4 texels over the casters' depth).

Any other ray set is refused with a ``ValueError``. The map holds every
caster instance (each needs its mesh) placed by its current transform; it is
rendered when first needed and kept while the scene's casters, their meshes
(by content), transforms and the light stay the same (:meth:`Scene.set_transform`
makes the next query render again; a caster mesh changed in place is refused, as on
every backend, and a new scene holding it renders it anew). The ground plane is not
in the map: it is decided analytically for each ray, by the rule every backend applies
(:func:`pyshadow.visibility.finite.ground_blocks`, tolerance
:func:`pyshadow.contact.ground_tolerance`), so the ground agrees with the other backends
exactly.

Depth tolerance ε (the bias rule)
    The point's texel (the nearest texel centre) and each PCF tap (the texel
    ``(dj, di)`` from it) compare a *receiver depth* against the stored
    depth. With normals (``visible(..., normals=...)``; the lighting calls
    always pass them) the receiver depth is that of the point's tangent
    plane at the tap's texel centre (the receiver-plane rule: exact for a
    flat receiver at any slope, so a lit flat face shows no acne at grazing
    light; the slope followed is at most ``TAN_MAX`` = 1e4 per unit of
    lateral distance, light 0.006 degrees over the face: at 10, 84 degrees,
    a sun 2 degrees over a lit box top shadowed 30 % of it; the price: a
    texel's footprint on a receiver, 1 / tan(elevation) texels long, is one
    answer, so a receiver within it before a caster is shadowed). Without
    normals it is the point's own depth, and the slope is covered by the
    tolerance instead. The tap is lit when ``receiver depth - ε <= stored
    depth``, with

    ``ε = bias + t (BIAS_TEXELS + [no normals] NO_NORMAL_SLOPE (h + 1/sqrt 2))``

    where ``t`` is the world size of a texel at the tap (the larger side of
    an orthographic texel; ``2 z / R`` on a cube face at depth ``z``), ``h``
    the PCF radius (``pcf // 2``), ``bias`` the user's value in world units
    (>= 0), ``BIAS_TEXELS`` = 1 (the rasterised depth at a texel centre
    comes from the receiver's neighbouring triangle there: curvature and
    creases within a texel) and ``NO_NORMAL_SLOPE`` = 2 (slopes up to 63
    degrees over the farthest tap). The price of ε is light leaking
    ("peter-panning") where an occluder is within ε of the receiver along
    the light: at a contact with light at elevation ``e`` over the receiver,
    over a strip of width about ``ε cos e`` plus a texel.

Percentage-closer filtering
    ``pcf`` = k (1, 3, 5 or 7): the fraction of the k x k taps that are lit
    (:meth:`ShadowMapVisibility.lit_fraction`); ``visible`` answers True
    where more than half are (``pcf=1``: the hard shadow map). Orthographic
    taps off the map are lit (no caster projects there); a cube tap whose
    receiver point falls on another face is looked up on that face.

The trapezoidal warp of thesis 001 (4.4.2) is not implemented.
"""
from __future__ import annotations

import math
from collections import OrderedDict

import numpy as np
import pyopencl as cl

from .. import _cl
from .._cl.launch import fill
from .._validate import check_both, kernel_rows, unit_normals
from ..contact import ground_tolerance
from ..mesh_kept import MeshKept
from ..scene_arrays import scene_arrays
from ._checks import _floats
from .shadow_fit import _ortho_frame, cell_points, far_axis, part_limit, split_casters
from .shadow_map_checks import PCF_SIZES, _check_bias, _check_pcf
from .shadow_map_kept import _MAPS_LOCK, _keep_map, _kept_map, _placed_casters, _placed_state

__all__ = ["ShadowMapVisibility", "ShadowMap", "light_of_rays", "render_reference", "lookup_reference",
           "BIAS_TEXELS", "NO_NORMAL_SLOPE", "TAN_MAX", "PCF_SIZES", "MIN_RESOLUTION", "MAX_RESOLUTION"]

MIN_RESOLUTION, MAX_RESOLUTION = 8, 8192
BIAS_TEXELS = 1.0
NO_NORMAL_SLOPE = 2.0
TAN_MAX = 1e4
FIT_TAN, FIT_TEXELS = 0.125, 2.0   # a fitted cube: casters' cone (tan of its half-angle) at most FIT_TAN, or
FIT_ULPS = 4.0                     # under FIT_TEXELS texels across; ε's float32 ulps
FAR_TEXELS = 2.0 ** -8      # below this cone (texels): a point light's rays answered by the orthographic map
LIGHT_TOL = 1e-6            # rays of one light: directions / endpoints equal to this (relative)
LIGHT_ULPS = 8.0            # ... plus this many float64 spacings of a kept point light's coordinates
CACHE_MAPS = 4              # rendered maps kept per backend object
NEAR_CUT, NEAR_ULPS = 2.0 ** -32, 4096.0   # faces nearer a point light than this times its reach, plus as many
#   float64 spacings of its coordinates, are cut
#   (a lamp on a wall, rebuilt from its rays' ends, lies float64 spacings inside the wall as often as not, and
#   the face then hid every ray crossing it within that over the sine of its angle: all of them at 1 ulp)


def _check_resolution(resolution) -> int:
    if isinstance(resolution, bool) or not isinstance(resolution, (int, np.integer)):
        raise ValueError(f"resolution must be an int in {MIN_RESOLUTION}..{MAX_RESOLUTION}, got {resolution!r}")
    if not MIN_RESOLUTION <= int(resolution) <= MAX_RESOLUTION:
        raise ValueError(f"resolution must be in {MIN_RESOLUTION}..{MAX_RESOLUTION}, got {resolution}")
    return int(resolution)


def light_of_rays(points, directions, max_distance=None, scale=1.0):
    """The one light a set of shadow rays belongs to.

    Parameters
    ----------
    points : ndarray, shape (N, 3), float64
        World ray origins (finite).
    directions : ndarray, shape (N, 3), float64
        World unit directions.
    max_distance : None or ndarray, shape (N,), float64
        Validated ray lengths (``inf``: unbounded).
    scale : float
        The scene's size (world units) for the endpoint tolerance.

    Returns
    -------
    kind : {'directional', 'point'}
    light : ndarray, shape (3,), float64
        The unit direction towards a directional light, or a point light's
        world position.

    Raises
    ------
    ValueError
        Unbounded rays whose directions lie more than ``LIGHT_TOL`` radians
        from their mean;
        bounded rays whose ends differ by more than ``LIGHT_TOL`` times the
        longest ray plus ``scale``; a mix of bounded and unbounded rays.
    """
    if max_distance is None or np.isinf(max_distance).all():
        w, ref = directions.mean(axis=0), "their mean"
        if not np.linalg.norm(w) > 0.5:     # far from one direction (unit rows within LIGHT_TOL: about 1)
            w, ref = directions[0].copy(), "ray 0's direction"
        w /= np.linalg.norm(w)
        cos = directions @ w                # unit rows: the angle to the mean is below LIGHT_TOL
        if not cos.min() >= 1.0 - 0.5 * LIGHT_TOL ** 2:
            i = int(np.argmin(cos))
            raise ValueError(f"a shadow map answers the rays of one light: unbounded rays must share one "
                             f"direction (a directional light), but ray {i}'s direction "
                             f"{np.round(directions[i], 6).tolist()} lies "
                             f"{float(np.arccos(np.clip(cos[i], -1, 1))):.3g} rad from {ref} "
                             f"{np.round(w, 6).tolist()} (> {LIGHT_TOL})")
        return "directional", w
    if not np.isfinite(max_distance).all():
        raise ValueError("a shadow map answers the rays of one light: max_distance must be finite for every ray "
                         "(a point light) or infinite for every ray (a directional light), not a mix")
    ends = points + max_distance[:, None] * directions
    light = ends[0] + (ends - ends[0]).mean(axis=0)     # not ends.mean(axis=0): its sum rounds N times at the
    #                                                   # ends' size (1.3e-13 off at 4,000 rays 3 from the origin)
    dev = np.abs(ends - light).max(axis=1)
    tol = LIGHT_TOL * (float(max_distance.max()) + float(scale))
    if float(dev.max()) > tol:
        i = int(dev.argmax())
        raise ValueError(f"a shadow map answers the rays of one light: bounded rays must end at one point "
                         f"(a point light), but ray {i} ends at {np.round(ends[i], 6).tolist()}, "
                         f"{float(dev[i]):.3g} from their mean end {np.round(light, 6).tolist()} (> {tol:.3g})")
    return "point", light


#: the six cube faces: (forward, up) in face order +X, -X, +Y, -Y, +Z, -Z (the kernel's cube_face)
_CUBE_FACES = (((1, 0, 0), (0, 1, 0)), ((-1, 0, 0), (0, 1, 0)), ((0, 1, 0), (0, 0, 1)),
               ((0, -1, 0), (0, 0, 1)), ((0, 0, 1), (0, 1, 0)), ((0, 0, -1), (0, 1, 0)))


def _cube_cameras(position, resolution):
    from ..camera import axis_camera

    return [axis_camera(position, f, u, resolution) for f, u in _CUBE_FACES]


def _near_cut(centres, radii, position) -> float:
    """The depth before which a point light's cube cuts its casters' faces (``NEAR_CUT``): that fraction of
    the farthest caster sphere's reach plus ``NEAR_ULPS`` float64 spacings of the light's coordinates."""
    reach = float((np.linalg.norm(centres - position, axis=1) + radii).max())
    return NEAR_CUT * reach + NEAR_ULPS * float(np.spacing(np.abs(position).max()))


def _beyond(tris, end):
    """Camera-space triangles (M, 3, 3) float64 clipped to depths ``>= end`` (those wholly beyond as given):
    a caster face within the rounding of the light's position is no occluder (``NEAR_CUT``)."""
    from ..gbuffer import clip_polygon

    cut = (tris[:, :, 2] < end).any(axis=1)
    if not cut.any():
        return tris
    keep = [tris[~cut]]
    for tri in tris[cut]:
        poly = clip_polygon(list(tri), [(np.array([0.0, 0.0, -1.0]), -end)])
        keep += [np.stack([poly[0], poly[k], poly[k + 1]])[None] for k in range(1, len(poly) - 1)]
    return np.concatenate(keep)


def _placed_now(scene, casters) -> list:
    """The instances ``casters`` of ``scene``, less any that another thread removed (``Scene.remove``) since the
    caster ids were read: drawn as after the removal (a placeholder has no mesh)."""
    return [inst for inst in (scene.instances[i] for i in casters) if not inst.removed]


class ShadowMap:
    """One rendered shadow map (a device buffer) and the frame its lookups need.

    Attributes
    ----------
    kind : {'directional', 'point'}
    light : ndarray, shape (3,), float64
        Unit direction towards the light, or the light's world position.
    resolution : int
        Texels per side (per face of a cube map).
    origin : ndarray, shape (3,), float64
        World point the lookups' coordinates are relative to (the light's
        position for a cube map).
    frame : ndarray, float32
        The kernel's frame (``kernels/shadow_map.cl``).
    texel : float or None
        World size of a texel (the larger side) of an orthographic map.
    basis, zoom, slack : ndarray (3, 3) or None, float, float
        A fitted cube's map of light-relative offsets, its ``k`` and ε's float32 term (None, 1, 0 if none).
    nbytes : int
        Bytes of the depth buffers (float32 per texel; 0 without casters).
    parts, axes, cells : tuple of ShadowMap, ndarray (2, 3), list of (lo, hi)
        An orthographic map split over groups of casters far apart (:mod:`.shadow_fit`): its maps, the world
        axes u, v across the light and each map's cell ``lo <= (p . u, p . v) < hi``; its own frame and
        texel are those of one map over all (no buffer). Empty, None, None if not split.
    """

    def __init__(self, kind, light, resolution, origin, frame, buffer, texel=None, fit=(None, 1.0, 0.0),
                 split=((), None, None)):
        self.kind, self.light, self.resolution = kind, light, resolution
        self.origin, self.frame, self.buffer, self.texel = origin, frame, buffer, texel
        self.basis, self.zoom, self.slack = fit
        self.parts, self.axes, self.cells = split
        self.nbytes = 0 if buffer is None else 4 * (6 if kind == "point" else 1) * resolution ** 2
        self.nbytes += sum(part.nbytes for part in self.parts)

    def depth(self) -> np.ndarray:
        """A host copy of the depths, float32 (R, R) or (6, R, R) (+inf where no caster); of a split map,
        ValueError (its :attr:`parts` each have theirs)."""
        if self.parts:
            raise ValueError(f"this map is split into {len(self.parts)} maps over casters far apart: "
                             f"read each one's depth() (ShadowMap.parts)")
        R = self.resolution
        out = np.full((6, R, R) if self.kind == "point" else (R, R), np.inf, np.float32)
        if self.buffer is not None:
            cl.enqueue_copy(_cl.queue(), out, self.buffer)
        return out


class ShadowMapVisibility:
    """A visibility backend answering the rays of one light from a re-rendered shadow map.

    Parameters
    ----------
    resolution : int, optional
        Texels per side of the orthographic map, or of each cube face,
        ``MIN_RESOLUTION`` .. ``MAX_RESOLUTION`` (8 .. 8192).
    bias : float, optional
        The user's part of ε, world units (>= 0; default 0). A ``bias``
        passed to :meth:`visible` replaces it for that call.
    pcf : {1, 3, 5, 7}, optional
        Percentage-closer filter size (1: hard).
    bias_texels : float, optional
        The texel part of ε (default ``BIAS_TEXELS``), >= 0.

    Notes
    -----
    The module docstring gives the rays it answers and the rule of ε. It cannot answer ambient occlusion
    (:attr:`answers_ambient_occlusion` False): it shades and renders a Lighting without a sky, which asks
    none (:mod:`pyshadow.lighting.shade_checks`). :attr:`renders` counts the maps rendered.
    """

    name = "shadow-map"
    answers_ambient_occlusion = False       # read by pyshadow.lighting.shade_checks

    def __init__(self, resolution: int = 1024, bias=None, pcf: int = 1, bias_texels: float = BIAS_TEXELS):
        self.resolution = _check_resolution(resolution)
        self.bias = _check_bias(bias)
        self.pcf = _check_pcf(pcf)
        if bias_texels is None:
            raise ValueError("bias_texels must be a finite number >= 0, got None")
        self.bias_texels = _check_bias(bias_texels, "bias_texels")
        self.renders = 0
        self._maps: OrderedDict = OrderedDict()
        self._meshes = MeshKept()          # mesh -> its triangles on the device (kept while the mesh lives)

    def __repr__(self) -> str:
        return f"<ShadowMapVisibility {self.resolution}^2 pcf={self.pcf}>"

    def __getstate__(self) -> dict:
        """Pickles and copies (Dask sends its tasks' arguments pickled) leave the kept maps and meshes' device
        buffers behind, which do not pickle: a used backend was ``TypeError: cannot pickle 'Buffer'``."""
        return {**self.__dict__, "_maps": OrderedDict(), "_meshes": MeshKept()}

    # -- the protocol --------------------------------------------------
    def visible(self, scene, points, directions, *, bias=None, surface_ids=None, normals=None,
                max_distance=None, straddle="error") -> np.ndarray:
        """Does each ray reach its light? (N,) bool: more than half of the PCF taps lit.

        Parameters as :meth:`lit_fraction` (those of
        :func:`pyshadow.visibility.visible`, with the differences it lists).
        """
        return self.lit_fraction(scene, points, directions, bias=bias, surface_ids=surface_ids, normals=normals,
                                 max_distance=max_distance, straddle=straddle) > 0.5

    def lit_fraction(self, scene, points, directions, *, bias=None, surface_ids=None, normals=None,
                     max_distance=None, straddle="error") -> np.ndarray:
        """The fraction of each ray's PCF taps that are lit.

        Parameters
        ----------
        scene : pyshadow.Scene
            Every caster needs its mesh.
        points : array_like, shape (N, 3)
            World positions, float32 or float64 (others converted), finite.
        directions : array_like, shape (N, 3)
            World directions towards the light (any non-zero length): one
            shared direction (unbounded rays), or, with ``max_distance``,
            segments that end at one point (module docstring).
        bias : float, optional
            The user's part of ε, world units (>= 0); default the
            constructor's (0 if None there). Not the normalised depth units
            of the CSM backends.
        surface_ids : int or array_like of int, optional
            Validated as for :func:`pyshadow.visibility.visible`, not needed:
            the receiver-plane rule replaces a self-bias.
        normals : array_like, shape (N, 3), optional
            World normals of the points' surfaces (any non-zero length;
            finite): the receiver-plane rule. Without them ε grows by the
            slope term (module docstring).
        max_distance : float or array_like, shape (N,), optional
            Ray lengths, world units (> 0): the distance to a point light.
            All finite (a point light) or all ``inf``/None (directional).
        straddle : {'error', 'embree'}, optional
            Validated and ignored: a shadow map answers a light inside a
            caster's bounding sphere.

        Returns
        -------
        ndarray, shape (N,), float32
            In [0, 1], in steps of ``1 / pcf^2``; 0 where the ground plane
            blocks the ray (:func:`pyshadow.visibility.finite.ground_blocks`).

        Raises
        ------
        ValueError
            Bad shapes or values, rays of more than one light, a caster
            without its mesh or with one changed in place since
            :meth:`Scene.add`; before anything is rendered or launched.
        """
        from ..visibility.finite import (check_max_distance, check_straddle, ground_blocks, ground_offsets,
                                         unit_directions)

        p = kernel_rows(points, "points")
        w = kernel_rows(directions, "directions", len(p))
        check_both(p, "points", w, "directions")
        n = len(p)
        m = None                        # the receiver-plane rule needs the normals' directions only: unit
        if normals is not None:         # rows (float32 keeps none of a length below 1e-45 or above 3e38)
            m = unit_normals(normals, n, "normals")
        scene.caster_slots(surface_ids, n)
        tmax = check_max_distance(max_distance, n)
        check_straddle(straddle)
        b = self.bias if bias is None else _check_bias(bias)
        if n == 0:
            return np.zeros(0, np.float32)
        p = np.asarray(p, np.float64)
        w = unit_directions(w)
        kind, light = light_of_rays(p, w, tmax, scene.scale())
        axis = far_axis(scene, light, self.resolution, FAR_TEXELS) if kind == "point" else None
        if axis is not None:            # a far point light: the map along its casters' cone, rays moved to it
            sm, wa = self.shadow_map(scene, direction=axis[0]), w @ axis[0]
            s = np.where(wa > 0, (axis[1] - p) @ axis[0], 0.0)         # to the casters' depth (rays towards it)
            q = p + (s / np.where(wa > 0, wa, 1.0))[:, None] * w - s[:, None] * axis[0]
        else:
            sm, q = self.shadow_map(scene, **{"direction" if kind == "directional" else "position": light}), p
        frac = self._lookup(sm, q, m, 0.0 if b is None else b)
        if scene.ground is not None:
            point = kind != "directional"
            blocked = ground_blocks(p[:, 1] - scene.ground, w[:, 1], tmax if point else None, ground_tolerance(scene),
                                    ground_offsets(scene, p) if point else 0.0)
            frac[blocked] = 0.0
        return frac

    def ambient_occlusion(self, scene, points, normals, *, sampling=None, return_bent_normals=False, bias=None,
                          indices=None, surface_ids=None, **options):
        """Not answerable: a shadow map holds one light's depths, AO asks every direction (any options)."""
        raise ValueError(f"{self!r}: a shadow map answers the rays of one light (one direction, or one end "
                         f"point); it cannot answer ambient occlusion: use backend='csm', 'csm-vote' or 'embree' "
                         f"for AO and a sky; this backend shades a Lighting without a sky (sun, local lights)")

    # -- maps ----------------------------------------------------------
    def shadow_map(self, scene, *, direction=None, position=None) -> ShadowMap:
        """The shadow map of a directional light or a point light, rendered unless kept.

        Parameters
        ----------
        scene : pyshadow.Scene
        direction : array_like, shape (3,), optional
            World direction towards a directional light (normalised here).
        position : array_like, shape (3,), optional
            World position of a point light. Exactly one of the two.

        Returns
        -------
        ShadowMap
            Kept (up to ``CACHE_MAPS`` of them) while the casters, their
            transforms and the light are unchanged: a direction within
            ``LIGHT_TOL`` of the kept one's, a position within ``LIGHT_TOL``
            times its distance to the nearest caster's bounding sphere, plus
            ``LIGHT_ULPS`` float64 spacings of its coordinates or its reach
            over the casters (a lamp 4 cm from a small box in a scene with a
            body 1e4 away reused a lamp 9 mm beside it at 0.01).
        """
        if (direction is None) == (position is None):
            raise ValueError("give exactly one of direction= (a directional light) or position= (a point light)")
        kind, what = ("directional", "direction") if position is None else ("point", "position")
        light = np.array(_floats(direction if position is None else position, f"the light's {what}", "3 numbers"))
        light = light.reshape(-1)       # a copy: the kept map's light does not follow the caller's array
        if light.shape != (3,) or not np.isfinite(light).all():
            raise ValueError(f"the light's {what} must be 3 finite numbers, got {light.tolist()}")
        if kind == "directional":      # scaled by its largest component first where its square leaves float64
            if not np.abs(light).max() > 0:     # (1e200 came out as a zero direction, 1e-320 refused as zero)
                raise ValueError("the light's direction must not be zero")
            light = unit_normals(light[None], 1, "the light's direction")[0]
        arr = scene_arrays(scene)
        casters, placed, content = _placed_casters(scene, arr)
        state = _placed_state(scene, kind, self.resolution, placed, content)
        tol = LIGHT_TOL         # a point light: relative to its distance to the nearest caster (its shadows move by
        if kind == "point":     # that fraction), not to the world origin or the scene's size
            c, r = arr["world_centre"][casters], arr["world_radius"][casters]
            dist = np.linalg.norm(c - light, axis=1)
            near = float(np.maximum(dist - r, 0.0).min()) if len(casters) else 0.0
            reach = float((dist + r).max()) if len(casters) else 0.0
            tol = LIGHT_TOL * near + LIGHT_ULPS * float(np.spacing(max(float(np.abs(light).max()), reach)))
        sm = _kept_map(self._maps, state, light, tol)
        if sm is None:
            sm = (self._render_directional(scene, casters, light) if kind == "directional"
                  else self._render_point(scene, casters, light))
            _keep_map(self, scene, state, sm, CACHE_MAPS)
        return sm

    def clear(self) -> None:
        """Forget the kept maps: the next query renders its map again."""
        with _MAPS_LOCK:
            self._maps.clear()

    def _mesh_triangles(self, mesh):
        """(device buffer of (T, 9) float32 corners relative to the mesh's centre, T, centre)."""
        held = self._meshes.get(mesh)      # for its content (trimesh's hash): a mesh changed in place since misses
        if held is None or held[3] != id(_cl.context()):   # (another device's buffer)
            v = np.asarray(mesh.vertices, np.float64)
            centre = 0.5 * (v.min(axis=0) + v.max(axis=0))
            tris = (v - centre)[np.asarray(mesh.faces)].reshape(-1, 9)
            # (not the mesh: an entry held it, and its buffer, for as long as the backend lived)
            held = self._meshes[mesh] = (_cl.to_device(tris, np.float32), len(tris), centre, id(_cl.context()))
        return held[:3]

    def _new_depth(self, faces):
        nbytes = 4 * faces * self.resolution ** 2
        buf = _cl.empty(nbytes)
        fill(_cl.queue(), buf, np.float32(np.inf), nbytes)
        return buf

    def _raster(self, buf, tris, n_tris, m, cube, zoff):
        if n_tris:
            k = _cl.kernel("shadow_map.cl", "sm_raster", {"TAN_MAX": TAN_MAX})
            k(_cl.queue(), (n_tris,), None, tris, np.int32(n_tris), _cl.to_device(m.reshape(12), np.float32),
              np.int32(self.resolution), np.int32(cube), np.int32(zoff), buf)

    def _render_directional(self, scene, casters, direction, whole=True):
        """The orthographic map fitted to the casters' world spheres seen along ``direction``; split over
        groups of them far apart (:mod:`.shadow_fit`) where ``whole``."""
        R = self.resolution
        A, b, origin, frame, texel = _ortho_frame(scene, casters, direction, R)
        if whole and len(casters) > 1:
            arr = scene_arrays(scene)
            axes, groups = split_casters(arr["world_centre"][casters], arr["world_radius"][casters], direction,
                                         part_limit(R))
            if len(groups) > 1:
                parts = tuple(self._render_directional(scene, casters[k], direction, False) for k, _, _ in groups)
                return ShadowMap("directional", direction, R, origin, frame, None, texel,
                                 split=(parts, axes, [(lo, hi) for _, lo, hi in groups]))
        if not len(casters):
            return ShadowMap("directional", direction, R, origin, frame, None, texel)
        buf = self._new_depth(1)
        for inst in _placed_now(scene, casters):
            tris, n_tris, centre = self._mesh_triangles(inst.mesh)
            T = inst.transform
            m = np.concatenate([A @ T[:3, :3], (A @ (T[:3, :3] @ centre + T[:3, 3] - origin) + b)[:, None]], axis=1)
            self._raster(buf, tris, n_tris, m, 0, 0)
        return ShadowMap("directional", direction, R, origin, frame, buf, texel)

    def _render_point(self, scene, casters, position):
        """The cube map at ``position``: six 90 degree faces of the casters' depths (along each face's axis);
        fitted to a narrow cone of casters (module docstring; :class:`ShadowMap`'s ``basis, zoom, slack``)."""
        from .local import _sphere_cone
        from .shadow_map_cube import face_triangles

        R, arr, basis, k, slack = self.resolution, scene_arrays(scene), None, 1.0, 0.0
        c, r = arr["world_centre"][casters], arr["world_radius"][casters] * (1 + 1e-6)
        cone, half = _sphere_cone(position, c, r)
        if half < 0.5 and (math.tan(half) <= FIT_TAN or R * math.tan(half) < FIT_TEXELS):  # a face fitted to them
            k = 2.0 ** math.floor(-math.log2(math.tan(half)))
            basis, slack = cone * [[k], [k], [1.0]], FIT_ULPS * 2.0 ** -23 * float(((c - position) @ cone[2] + r).max())
        cams = _cube_cameras(position if basis is None else np.zeros(3), R)
        frame = np.concatenate([cam.rotation.reshape(9) for cam in cams]).astype(np.float32)
        if not len(casters):
            return ShadowMap("point", position, R, position, frame, None)
        buf = self._new_depth(6)
        items = [(p.mesh, p.transform) for p in _placed_now(scene, casters)]
        if basis is not None:           # the casters placed in the fitted cube's coordinates
            items = [(mesh, np.block([[basis @ T[:3, :3], (basis @ (T[:3, 3] - position))[:, None]],
                                      [np.zeros((1, 3)), np.ones((1, 1))]])) for mesh, T in items]
        eye = np.concatenate([np.eye(3), np.zeros((3, 1))], axis=1)
        end = 0.0 if basis is not None else _near_cut(c, r, position)
        for f, cam in enumerate(cams):
            tris = _beyond(face_triangles(items, cam), end)     # a face just beside the light kept (its module)
            self._raster(buf, _cl.to_device(tris.reshape(-1, 9), np.float32), len(tris), eye, 1, f * R * R)
        return ShadowMap("point", position, R, position, frame, buf, None, (basis, k, slack))

    def _lookup(self, sm, p, m, bias):
        """Lit fraction of the PCF taps of each point, (N,) float32 (validated float64 rows)."""
        n = len(p)
        if sm.parts:                    # a split map: each point answered by its cell's map
            out = np.ones(n, np.float32)
            for part, k in zip(sm.parts, cell_points(p, sm.axes, sm.cells)):
                if len(k):
                    out[k] = self._lookup(part, p[k], None if m is None else m[k], bias)
            return out
        if sm.buffer is None:
            return np.ones(n, np.float32)
        half = self.pcf // 2
        texels = self.bias_texels + (0.0 if m is not None else NO_NORMAL_SLOPE * (half + math.sqrt(0.5)))
        p, texels = p - sm.origin, texels / sm.zoom
        if sm.basis is not None:        # a fitted cube: its coordinates, normals by the inverse transpose
            p, m, bias = p @ sm.basis.T, None if m is None else m @ np.linalg.inv(sm.basis), bias + sm.slack
        out = np.empty(n, np.float32)
        q = _cl.queue()
        k = _cl.kernel("shadow_map.cl", "sm_lookup", {"TAN_MAX": TAN_MAX / sm.zoom})
        pts = _cl.to_device(p, np.float32)
        nrm = _cl.to_device(m if m is not None else np.zeros((1, 3)), np.float32)
        res = _cl.empty(4 * n)
        k(q, (n,), None, sm.buffer, np.int32(sm.resolution), np.int32(sm.kind == "point"),
          _cl.to_device(sm.frame), np.int32(n), pts, nrm, np.int32(m is not None), np.float32(bias),
          np.float32(texels), np.int32(half), res)
        cl.enqueue_copy(q, out, res)
        return out


from .shadow_map_ref import lookup_reference, render_reference  # noqa: E402  (they use this module's frame)

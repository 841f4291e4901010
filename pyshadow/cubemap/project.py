"""Cube-map AO onto a camera's pixels: several probes, best-quality choice, coverage placement.

Seed 002, sections 4.4 (projective texturing, the depth test, face choice
by the largest component, best quality among several cube maps), 4.5 (the
7 x 7 edge-aware low-pass filter, Listing 4.15) and 4.6 (a new cube map at
the camera when under 75 % of the visible pixels are shaded, counted on an
8 x 8 grid).

Which probe shades a pixel
--------------------------
A pixel's surface point ``x`` (normal ``n``, facing the camera) is seen by a
probe at ``c`` when, with ``u = x - c``, ``r = |u|``: the texel of ``u``
(:func:`~pyshadow.cubemap.probe.direction_texels`) shows the same instance,
the texel's surface depth along ``u`` (its plane's; its centre depth where
the plane is grazing, ``|n.u| < 0.1``) is within ``tolerance * r`` of ``r``
-- or, grazing, its plane's is and the plane is seen that far: the texel's
centre ray, or one of its eight neighbours', meets it at ``r`` or beyond --
``n . (c - x) > 0``
(the probe sees the side the camera sees) and the texel has an AO value.
Among the probes that see it the one of the largest quality
``Q = Q_a Q_b Q_c`` wins, with (seed 002, Figure 4.10, which gives the
terms' intent but no formulas; these are ours):

* ``Q_a = D / (D + r)`` -- nearer probes sample the surface more finely;
* ``Q_b = max_i |u_i| / r`` -- 1 at a face centre, ``1/sqrt 3`` at a cube
  corner (texels are stretched off-centre);
* ``Q_c = n . (c - x) / r`` -- the surface faces the probe.

Pixels no probe sees are NaN in ``ao`` and False in ``covered`` unless
``fallback`` gives a value.
"""
from __future__ import annotations

import time
import warnings
from dataclasses import dataclass

import numpy as np

from .._validate import check_int, nonzero, rows3, squared_lengths, unit_normals
from ..lighting._checks import _number, flag
from ..sampling import Sampling
from .estimators import ESTIMATORS, GRAZING, horizon_defaults, march_defaults, texel_ao
from .probe import CubeProbe, _check_resolution, _check_scene, _direction_texels

__all__ = ["CubeMapAO", "Projection", "quality", "coverage_grid", "seed_box_filter", "normal_hash"]


def quality(points, normals, centre, max_distance) -> np.ndarray:
    """The quality ``Q_a Q_b Q_c`` (module docstring) of a probe at ``centre`` for surface points.

    Parameters
    ----------
    points, normals : ndarray, shape (K, 3), float
        World points and normals (facing the viewer; normalised here, a zero normal faces no probe).
    centre : array_like, shape (3,)
    max_distance : float
        ``D`` of ``Q_a``, world units.

    Returns
    -------
    ndarray, shape (K,), float64
        In ``[0, 1]``; 0 where the surface faces away from the probe.
    """
    max_distance = march_defaults(max_distance)["max_distance"]
    # (normals of other rows were broadcast against the points; NaN gave NaN, outside [0, 1])
    p = rows3(points, "points")
    n = rows3(normals, "normals", len(p)).copy()          # (normalised below: not the caller's array)
    c = np.asarray(centre)
    if c.shape != (3,) or c.dtype.kind not in "iuf" or not np.isfinite(c).all():
        raise ValueError(f"centre must be 3 finite numbers, got {centre!r}")
    odd = np.flatnonzero((np.abs(squared_lengths(n) - 1.0) > 2e-6) & n.any(axis=1))
    if len(odd):        # (a normal of length 10 gave 10 Q, outside [0, 1]); unit rows are kept as given
        n[odd] = unit_normals(n[odd], len(odd))
    u = p - c.astype(np.float64)
    r = np.maximum(np.linalg.norm(u, axis=1), 1e-300)
    qa = max_distance / (max_distance + r)
    qb = np.abs(u).max(axis=1) / r
    qc = np.maximum(0.0, -np.einsum("ij,ij->i", n, u) / r)
    return qa * qb * qc


@dataclass(eq=False)
class Projection:
    """Cube-map AO of one camera image.

    Attributes
    ----------
    ao : ndarray, shape (H, W), float32
        AO in [0, 1] where covered; ``fallback`` (NaN by default) where a
        surface pixel is seen by no probe; 1 on the background.
    covered : ndarray, shape (H, W), bool
        A probe shades the pixel.
    probe : ndarray, shape (H, W), int32
        Index of the probe that shades it; -1 uncovered, -2 background.
    quality : ndarray, shape (H, W), float32
        Its quality factor (0 where uncovered).
    depth, normal : ndarray
        The camera's G-buffer depth (H, W) and normals (H, W, 3), for filtering.
    """

    ao: np.ndarray
    covered: np.ndarray
    probe: np.ndarray
    quality: np.ndarray
    depth: np.ndarray
    normal: np.ndarray

    @property
    def coverage(self) -> float:
        """Fraction of the surface pixels a probe shades (1 for an image without surface)."""
        surf = self.probe != -2
        return float(self.covered[surf].mean()) if surf.any() else 1.0


def _probe_sees(probe, ao_map, points, normals, ids, tolerance, lookup):
    """AO, quality inputs and a mask of which points ``probe`` sees (module docstring)."""
    R, c = probe.resolution, probe.centre
    u = points - c
    r = np.linalg.norm(u, axis=1)
    uh = u / np.maximum(r, 1e-300)[:, None]
    if normals is None:                                   # no normals: every point faces the probe
        normals = -uh
    face, row, col, x, y = _direction_texels(uh, R)
    every = slice(None)                                   # all points (a view, no copy)

    def depths(fl, k):
        """Centre depth, plane depth along ``uh[k]`` (NaN where none > 0) and ``|n.u|`` of texels ``fl``."""
        n = probe.normal.reshape(-1, 3)[fl].astype(np.float64)
        den = np.einsum("ij,ij->i", n, uh[k])
        zc = probe.depth.reshape(-1)[fl].astype(np.float64)
        P = probe.texel_offsets(fl)                       # P - c from the depth (float32 world P moves far out)
        with np.errstate(divide="ignore", invalid="ignore"):
            zp = np.einsum("ij,ij->i", n, P) / den
        return zc, np.where((zp > 0) & np.isfinite(zc) & np.isfinite(zp), zp, np.nan), np.abs(den)

    def same(k, fl, z):
        """Depth ``z`` of texels ``fl`` along ``uh[k]`` is the points' distance, and the instance theirs."""
        ok = np.abs(z - r[k]) <= tolerance * r[k]
        if ids is not None:
            ok &= probe.object_id.reshape(-1)[fl] == (ids if ids.size == 1 else ids[k])
        return ok

    def test(fl):
        zc, zp, g = depths(fl, every)
        a = ao_map.reshape(-1)[fl]
        return same(every, fl, np.where((g >= GRAZING) & np.isfinite(zp), zp, zc)) & np.isfinite(a), a, zc, zp, g

    flat = (face * R + row) * R + col
    own, ao, zc, zp, g = test(flat)
    k = np.flatnonzero(~own & (g < GRAZING) & np.isfinite(ao))
    own[_grazing_seen(probe, k[same(k, flat[k], zp[k])], zc, r, tolerance, (face, row, col), depths, same)] = True
    seen = own & (np.einsum("ij,ij->i", normals, -u) > 0)
    if lookup == "bilinear":
        fx = (x + 1.0) * 0.5 * R - 0.5
        fy = (1.0 - y) * 0.5 * R - 0.5
        c0, r0 = np.floor(fx).astype(np.int64), np.floor(fy).astype(np.int64)
        ax, ay = fx - c0, fy - r0
        num = np.zeros(len(points))
        den = np.zeros(len(points))
        for dr, dc, wgt in ((0, 0, (1 - ax) * (1 - ay)), (0, 1, ax * (1 - ay)), (1, 0, (1 - ax) * ay),
                            (1, 1, ax * ay)):
            fl = (face * R + np.clip(r0 + dr, 0, R - 1)) * R + np.clip(c0 + dc, 0, R - 1)
            ok, a = test(fl)[:2]
            wgt = np.where(np.where(fl == flat, own, ok), wgt, 0.0)
            num += wgt * np.nan_to_num(a)
            den += wgt
        ao = np.where(den > 0, num / np.maximum(den, 1e-300), ao)
    return seen, ao


def _grazing_seen(probe, k, zc, r, tolerance, texels, depths, same):
    """Which points ``k`` on their own texel's plane, seen grazing (``|n.u| <`` GRAZING), the probe sees.

    The centre depth of a grazing texel is no measure of its other points (ground 3.5-10 from a probe 0.35
    above it, 12 % of a camera's floor pixels, went unseen), and its plane holds along the point's direction
    only as far as the centre ray met it unhidden: a body standing on the plane beyond (a wall on the floor)
    hides the rest within the texel (ground pixels in front of a wall, seen from behind it, read the ground
    there). So a point no farther than the centre ray's hit is seen, and one farther when one of the eight
    texels around shows the same plane (and instance) and its centre ray meets it at the point's distance or
    beyond. Returns those of ``k`` seen (``texels``: face, row and column of every point's texel).
    """
    R, (face, row, col) = probe.resolution, texels
    ok = zc[k] >= (1 - tolerance) * r[k]
    far = k[~ok]
    vouched = np.zeros(len(far), bool)
    for dr, dc in ((-1, 0), (1, 0), (0, -1), (0, 1), (-1, -1), (-1, 1), (1, -1), (1, 1)):
        i = np.flatnonzero(~vouched)
        f = far[i]
        fl = (face[f] * R + np.clip(row[f] + dr, 0, R - 1)) * R + np.clip(col[f] + dc, 0, R - 1)
        reach = probe.depth.reshape(-1)[fl] >= (1 - tolerance) * r[f]    # (planes only of those that may vouch)
        i, f, fl = i[reach], f[reach], fl[reach]
        vouched[i[same(f, fl, depths(fl, f)[1])]] = True
    return np.concatenate([k[ok], far[vouched]])


#: The default relative depth tolerance of a probe's visibility test (:meth:`CubeMapAO.project`, ``assign``, ``place``).
TOLERANCE = 0.02


def check_tolerance(tolerance) -> float:
    """The relative depth tolerance of the visibility test as a float in (0, 1) (ValueError otherwise)."""
    try:
        t = float(tolerance)
    except (TypeError, ValueError):
        raise ValueError(f"tolerance must be in (0, 1), got {tolerance!r}") from None
    if not 0 < t < 1:
        raise ValueError(f"tolerance must be in (0, 1), got {tolerance!r}")
    return t


def coverage_grid(covered, background, grid: int = 8) -> float:
    """Seed 002, section 4.6: the shaded fraction counted on a ``grid x grid`` image.

    The image is cut into ``grid x grid`` cells (``np.array_split`` of rows
    and columns); a cell is background when most of its pixels are, else
    shaded when at least as many of its pixels are shaded as unshaded. The
    result is shaded cells over non-background cells (1 when all are background).

    Parameters
    ----------
    covered, background : ndarray, shape (H, W), bool
    grid : int, optional
        Cells per side, 1 .. min(H, W) (default 8, the thesis's 8 x 8 target).
    """
    covered, background = np.asarray(covered), np.asarray(background)
    if covered.ndim != 2 or background.shape != covered.shape:
        raise ValueError(f"covered and background must be (H, W) images of one shape, got {covered.shape} and "
                         f"{background.shape}")
    # (a 2 counted as two shaded pixels, a float image failed in NumPy's '~')
    covered, background = (_mask(a, name) for a, name in ((covered, "covered"), (background, "background")))
    H, W = covered.shape
    if isinstance(grid, bool) or not isinstance(grid, (int, np.integer)) or not 1 <= grid <= min(H, W):
        raise ValueError(f"grid must be an int in 1..{min(H, W)}, got {grid!r}")
    shaded = total = 0
    for rows in np.array_split(np.arange(H), grid):
        for cols in np.array_split(np.arange(W), grid):
            bg = background[np.ix_(rows, cols)]
            cv = covered[np.ix_(rows, cols)] & ~bg
            if bg.mean() > 0.5:
                continue
            total += 1
            shaded += int(cv.sum() >= (~bg).sum() - cv.sum())
    return shaded / total if total else 1.0


def _mask(a, name):
    """A bool image: bool, or integers 0 and 1 only (TypeError naming ``name`` otherwise)."""
    if a.dtype.kind in "iu" and ((a == 0) | (a == 1)).all():
        return a.astype(bool)
    if a.dtype.kind != "b":
        raise TypeError(f"{name} must be a bool image (or of 0 and 1 only), got dtype {a.dtype}")
    return a


#: Options of the horizon estimator alone (:func:`pyshadow.cubemap.texel_ao`); the rest are the march's.
HORIZON_OPTIONS = ("directions", "steps")


def _march_options(options: dict) -> dict:
    """``options`` without :data:`HORIZON_OPTIONS` (what :func:`~pyshadow.cubemap.raymarch_visible` takes)."""
    return {k: v for k, v in options.items() if k not in HORIZON_OPTIONS}


class CubeMapAO:
    """Cube-map AO of a scene: probes, their per-texel AO, projection onto cameras.

    Parameters
    ----------
    scene : pyshadow.Scene
    max_distance : float
        ``D``: occluders farther than this from a point do not count (world units, > 0).
    resolution : int, optional
        Face resolution of new probes (:class:`CubeProbe`).
    estimator : {'raymarch', 'horizon'} or None, optional
        Per-texel AO (:mod:`pyshadow.cubemap.estimators`); None: probes
        only, no per-texel AO (for :class:`CubeMapVisibility`; nothing to
        :meth:`project`).
    sampling : pyshadow.Sampling, optional
        Sample directions of the raymarch estimator (default ``Sampling()``).
    device : bool, optional
        Raymarch on the OpenCL device (else the NumPy reference).
    ground_size : float, optional
        Side of the drawn ground quad.
    **options
        Estimator options (:func:`pyshadow.cubemap.texel_ao`), checked here: the march's
        (:func:`~pyshadow.cubemap.march_defaults`; also with ``estimator=None``, the
        :class:`CubeMapVisibility` march's) or the horizon estimator's ``directions`` and ``steps``.

    Raises
    ------
    ValueError, TypeError
        An unknown estimator, a bad distance, resolution or option; a scene not a ``pyshadow.Scene``.

    Attributes
    ----------
    probes : list of CubeProbe
    ao_maps : list of ndarray, each (6, R, R) float32 (None with ``estimator=None``)
    timings : list of dict
        Per probe: ``render_s`` and ``ao_s`` (seconds).
    """

    def __init__(self, scene, max_distance, *, resolution: int = 128, estimator: str = "raymarch",
                 sampling: Sampling | None = None, device: bool = True, ground_size: float | None = None,
                 **options):
        _check_scene(scene, "CubeMapAO")
        if estimator is not None and estimator not in ESTIMATORS:
            raise ValueError(f"estimator must be one of {ESTIMATORS} or None, got {estimator!r}")
        # checked before a probe is rendered (add_probe's march raised only after the render); with
        # estimator=None too: CubeMapVisibility marches with them
        march = _march_options(options) if estimator != "horizon" else {}
        self.max_distance = march_defaults(max_distance, **march)["max_distance"]
        if estimator == "horizon":
            horizon_defaults(**options)         # (raised only after the first probe's render)
        _check_resolution(resolution)
        if sampling is not None and not isinstance(sampling, Sampling):     # (refused after the first render)
            raise TypeError(f"sampling must be a pyshadow.Sampling, e.g. pyshadow.Sampling(36), got {sampling!r}")
        device = flag(device, "device")         # "no" was true: the device ran
        self.scene, self.resolution, self.estimator = scene, int(resolution), estimator
        self.sampling, self.device, self.ground_size, self.options = sampling, device, ground_size, options
        self.probes: list[CubeProbe] = []
        self.ao_maps: list[np.ndarray] = []
        self.timings: list[dict] = []

    def add_probe(self, centre) -> int:
        """Render a probe at ``centre`` (world, (3,)) and its per-texel AO; returns its index."""
        t0 = time.perf_counter()
        probe = CubeProbe(self.scene, centre, self.resolution, ground_size=self.ground_size)
        t1 = time.perf_counter()
        ao = None if self.estimator is None else texel_ao(
            probe, self.max_distance, estimator=self.estimator, sampling=self.sampling, device=self.device,
            **self.options)
        t2 = time.perf_counter()
        self.probes.append(probe)
        self.ao_maps.append(ao)
        self.timings.append({"render_s": t1 - t0, "ao_s": t2 - t1})
        return len(self.probes) - 1

    @property
    def march_options(self) -> dict:
        """The ``"raymarch"`` rule's options among :attr:`options` (``thickness``, ``step``, ``bias``,
        ``max_steps``), those :class:`CubeMapVisibility` marches rays with: the horizon estimator's
        ``directions`` and ``steps`` left out."""
        return _march_options(self.options)

    @property
    def stale(self) -> bool:
        """True when any probe is stale (the scene changed since it was rendered: a body moved or added, the ground)."""
        return any(p.stale for p in self.probes)

    def refresh(self) -> int:
        """Re-render every stale probe at its centre; returns how many were."""
        old = [(i, p.centre) for i, p in enumerate(self.probes) if p.stale]
        for i, c in old:
            j = self.add_probe(c)
            self.probes[i], self.ao_maps[i], self.timings[i] = self.probes.pop(j), self.ao_maps.pop(j), \
                self.timings.pop(j)
        return len(old)

    @property
    def nbytes(self) -> int:
        """Bytes of the probes' maps and AO maps."""
        return sum(p.nbytes for p in self.probes) + sum(a.nbytes for a in self.ao_maps if a is not None)

    def project(self, camera, *, gbuffer=None, lookup: str = "nearest", tolerance: float = TOLERANCE,
                fallback: float | None = None, on_empty: str = "raise") -> Projection:
        """AO of ``camera``'s pixels from the best probe that sees each (module docstring).

        Parameters
        ----------
        camera : pyshadow.Camera
        gbuffer : dict, optional
            The camera's G-buffer of ``scene.draw_items(ground_size)`` (default: rendered).
        lookup : {'nearest', 'bilinear'}, optional
            ``'bilinear'``: the four texels around the point, weighted, those
            that fail the depth test left out (renormalised).
        tolerance : float, optional
            Relative depth tolerance of the visibility test, in (0, 1).
        fallback : float, optional
            AO of surface pixels no probe sees (default NaN; ``covered`` tells them).
        on_empty : {'raise', 'fallback'}, optional
            What to do when no probe sees any surface pixel of the camera:
            ``ValueError`` (default) or the fallback image.

        Raises
        ------
        ValueError
            Bad options; no probe at all; with ``on_empty='raise'``, a camera
            with surface pixels none of which a probe sees.

        Warns
        -----
        UserWarning
            A stale probe (:attr:`stale`: the scene changed since it was
            rendered; :meth:`refresh`): it answers for the scene as it was.
        """
        if lookup not in ("nearest", "bilinear"):
            raise ValueError(f"lookup must be 'nearest' or 'bilinear', got {lookup!r}")
        if on_empty not in ("raise", "fallback"):
            raise ValueError(f"on_empty must be 'raise' or 'fallback', got {on_empty!r}")
        check_tolerance(tolerance)
        fill = np.nan if fallback is None else _number(fallback, "fallback")
        if not self.probes:
            raise ValueError("CubeMapAO.project: no probe placed yet (add_probe or place first)")
        if self.estimator is None:
            raise ValueError("CubeMapAO.project: built with estimator=None, the probes hold no AO")
        self._warn_stale("project")
        return self._project(camera, gbuffer, lookup, float(tolerance), fill, on_empty)

    def _project(self, camera, gbuffer, lookup, tolerance, fill, on_empty):
        """:meth:`project` past its checks; with ``estimator=None`` (for :meth:`place`) AO 0 where covered."""
        from ..render import surface_points

        sp = surface_points(self.scene, camera, ground_size=self.ground_size, gbuffer=gbuffer)
        H, W = camera.height, camera.width
        pts = sp.points
        nrm = sp.normals.astype(np.float64)
        nrm /= np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-300)
        best_i, best_q, best_ao = self._best(pts, nrm, sp.surface_ids, tolerance, lookup)
        covered_pts = best_i >= 0
        if len(pts) and not covered_pts.any() and on_empty == "raise":
            raise ValueError(f"no probe sees any of the camera's {len(pts)} surface pixels "
                             "(place a probe, e.g. CubeMapAO.place(camera), or on_empty='fallback')")
        ao_img = np.ones(H * W, np.float32)
        probe_img = np.full(H * W, -2, np.int32)
        q_img = np.zeros(H * W, np.float32)
        ao_img[sp.index] = np.where(covered_pts, best_ao, fill)
        probe_img[sp.index] = best_i
        q_img[sp.index] = np.maximum(best_q, 0.0)
        g = sp.gbuffer
        return Projection(ao=ao_img.reshape(H, W), covered=(probe_img >= 0).reshape(H, W),
                          probe=probe_img.reshape(H, W), quality=q_img.reshape(H, W),
                          depth=np.asarray(g["depth"], np.float32), normal=np.asarray(g["normal"], np.float32))

    def _warn_stale(self, name):
        """A UserWarning when a probe is stale: its maps show the scene before a move (answers for it)."""
        if self.stale:
            warnings.warn(f"CubeMapAO.{name}: the probes are stale (the scene changed since they were rendered) and "
                          "answer for the scene as it was: call refresh()", UserWarning, stacklevel=3)

    def _best(self, points, normals, ids, tolerance, lookup="nearest"):
        """Best probe (index, -1 none), its quality and its AO for each point (module docstring)."""
        best_q = np.zeros(len(points))
        best_ao = np.full(len(points), np.nan)
        best_i = np.full(len(points), -1, np.int32)
        for i, (probe, ao_map) in enumerate(zip(self.probes, self.ao_maps)):
            if ao_map is None:                                  # probes only: any texel will do
                ao_map = np.zeros(probe.depth.shape, np.float32)
            seen, ao = _probe_sees(probe, ao_map, points, normals, ids, tolerance, lookup)
            nrm = normals if normals is not None else probe.centre - points
            nrm = nrm / np.maximum(np.linalg.norm(nrm, axis=1, keepdims=True), 1e-300)
            q = np.where(seen, quality(points, nrm, probe.centre, self.max_distance), -1.0)
            better = seen & (q > best_q)
            best_q[better], best_ao[better], best_i[better] = q[better], ao[better], i
        return best_i, best_q, best_ao

    def assign(self, points, normals=None, surface_ids=None, *, tolerance: float = TOLERANCE):
        """Which probe answers each world point: the best-quality one that sees it.

        Parameters
        ----------
        points : ndarray, shape (K, 3), float
            World points on surfaces.
        normals : ndarray, shape (K, 3), float, optional
            Their unit normals; None: each point is taken as facing every probe
            (no side test, ``Q_c = 1``).
        surface_ids : ndarray, shape (K,), int, optional
            Instance ids (``GROUND_ID`` for the ground); None: not compared.
        tolerance : float, optional
            Relative depth tolerance of the visibility test.

        Returns
        -------
        probe : ndarray, shape (K,), int32
            Probe index, -1 where no probe sees the point.
        quality : ndarray, shape (K,), float64

        Raises
        ------
        ValueError
            Bad points, normals, ids or tolerance (a stale probe: a UserWarning, as :meth:`project`).
        """
        p = rows3(points, "points")
        n = None if normals is None else nonzero(rows3(normals, "normals", len(p)), "normals")
        ids = None if surface_ids is None else np.asarray(surface_ids)
        if ids is not None and ids.dtype.kind not in "iu":     # compared with the probes' int ids: never equal
            raise TypeError(f"surface_ids must be integers, got {ids.dtype}")
        if ids is not None and ids.ndim > 1:
            raise ValueError(f"surface_ids must be one id or one per point, shape (K,), got shape {ids.shape}")
        ids = None if ids is None else ids.reshape(-1)
        if ids is not None and ids.size != 1 and len(ids) != len(p):
            raise ValueError(f"surface_ids has {len(ids)} entries but points has {len(p)} rows (shapes must match)")
        tolerance = check_tolerance(tolerance)
        self._warn_stale("assign")
        best_i, best_q, _ = self._best(p, n, ids, tolerance)
        return best_i, np.maximum(best_q, 0.0)

    def place(self, camera, *, threshold: float = 0.75, grid: int = 8, gbuffer=None) -> bool:
        """Seed 002, 4.6: add a probe at ``camera.eye`` when under ``threshold`` of the image is shaded.

        The shaded fraction is :func:`coverage_grid` (a ``grid x grid``
        count, ``grid`` an int >= 1; an image with fewer rows or columns is
        counted pixel by pixel along them) of the pixels :meth:`project` with
        its defaults shades (with ``estimator=None`` too: the pixels a probe
        sees); with no probe yet, a probe is always placed. Returns True when a
        probe was added (a UserWarning when a probe is stale: :meth:`project`).
        """
        if not 0 < _number(threshold, "threshold") <= 1:
            raise ValueError(f"threshold must be in (0, 1], got {threshold!r}")
        grid = check_int(grid, "grid", 1)
        if self.probes:
            self._warn_stale("project")
            # (through project(), maps built with estimator=None raised: "the probes hold no AO")
            pr = self._project(camera, gbuffer, "nearest", TOLERANCE, np.nan, "fallback")    # project's defaults
            # (the default 8 x 8 refused every camera under 8 pixels a side: "grid must be an int in 1..4, got 8")
            if coverage_grid(pr.covered, pr.probe == -2, min(grid, *pr.covered.shape)) >= threshold:
                return False
        self.add_probe(camera.eye)
        return True


# ---------------------------------------------------------------------------
# seed 002, 4.5: the 7 x 7 edge-aware low-pass filter
# ---------------------------------------------------------------------------
def normal_hash(normal) -> np.ndarray:
    """Seed 002 eq. (4.5): ``0.14 (nx/2+1/2) + 0.29 (ny/2+1/2) + 0.5 (nz/2+1/2)``, (H, W) float64."""
    n = np.asarray(normal, np.float64)
    if n.ndim < 1 or n.shape[-1] != 3:
        raise ValueError(f"normal must have shape (..., 3), got {n.shape}")
    return 0.14 * (n[..., 0] * 0.5 + 0.5) + 0.29 * (n[..., 1] * 0.5 + 0.5) + 0.5 * (n[..., 2] * 0.5 + 0.5)


def seed_box_filter(ao, depth, normal, *, rule: str = "seed", size: int = 7, depth_threshold: float = 0.01,
                    hash_threshold: float = 0.1) -> np.ndarray:
    """Seed 002's edge-aware box filter (Listing 4.15), or pyshadow's form of it.

    Parameters
    ----------
    ao : ndarray, shape (H, W), float
        AO image; NaN marks uncovered pixels (they count for no neighbour and stay NaN).
    depth : ndarray, shape (H, W), float
        Distance along each pixel's ray (world units), ``inf`` on background.
    normal : ndarray, shape (H, W, 3), float
        Unit normals.
    rule : {'seed', 'relative'}, optional
        ``'seed'``: Listing 4.15 as written -- the mean over the ``size x
        size`` window (cut at the border) of the pixels with
        ``|z_q - z_p| < depth_threshold`` (world units) and
        ``|hash_q - hash_p| < hash_threshold`` (:func:`normal_hash`).
        ``'relative'``: :func:`pyshadow.filters.edge_aware_box` with
        ``size`` (relative depth, normal cosine; its defaults); the image
        must then have no NaN on surface pixels (use ``fallback=``).
    size : int, optional
        Odd window side (default 7).

    Returns
    -------
    ndarray, shape (H, W), float32
        Background (infinite depth) pixels pass through unchanged.
    """
    from .. import filters

    for name, a in (("ao", ao), ("depth", depth), ("normal", normal)):    # complex: a ComplexWarning, then
        if np.asarray(a).dtype.kind not in "iuf":                         # the real part; strings: converted
            raise TypeError(f"{name} must hold real numbers, got dtype {np.asarray(a).dtype}")
    ao = np.asarray(ao, np.float32)
    depth = np.asarray(depth, np.float32)
    if ao.ndim != 2 or depth.shape != ao.shape or np.shape(normal) != ao.shape + (3,):
        raise ValueError(f"ao (H, W), depth (H, W) and normal (H, W, 3) must agree, got {ao.shape}, "
                         f"{depth.shape}, {np.shape(normal)}")
    if isinstance(size, bool) or not isinstance(size, (int, np.integer)) or size < 1 or size % 2 == 0:
        raise ValueError(f"size must be an odd int >= 1, got {size!r}")
    for name, thr in (("depth_threshold", depth_threshold), ("hash_threshold", hash_threshold)):
        if isinstance(thr, bool) or not isinstance(thr, (int, float, np.integer, np.floating)) or not thr > 0:
            raise ValueError(f"{name} must be a number > 0, got {thr!r}")
    if rule == "relative":
        if np.isnan(ao[np.isfinite(depth)]).any():
            raise ValueError("rule='relative' needs AO on every surface pixel (project with fallback=)")
        return filters.edge_aware_box(ao, depth, normal, size=int(size))
    if rule != "seed":
        raise ValueError(f"rule must be 'seed' or 'relative', got {rule!r}")
    H, W = ao.shape
    z = depth.astype(np.float64)
    hsh = normal_hash(normal)
    a = ao.astype(np.float64)
    num = np.zeros((H, W))
    cnt = np.zeros((H, W))
    half = max(min(size // 2, max(H, W) - 1), 0)   # farther offsets read only padding (empty: -1 failed np.pad)
    pad = lambda x, v: np.pad(x, half, constant_values=v)  # noqa: E731
    zp, hp, ap = pad(z, np.inf), pad(hsh, np.inf), pad(a, np.nan)
    for dy in range(-half, half + 1):
        for dx in range(-half, half + 1):
            sl = (slice(half + dy, half + dy + H), slice(half + dx, half + dx + W))
            with np.errstate(invalid="ignore"):
                ok = (np.abs(zp[sl] - z) < depth_threshold) & (np.abs(hp[sl] - hsh) < hash_threshold) \
                    & np.isfinite(ap[sl])
            num += np.where(ok, ap[sl], 0.0)
            cnt += ok
    out = np.where(cnt > 0, num / np.maximum(cnt, 1), a)
    return np.where(np.isfinite(z), out, a).astype(np.float32)

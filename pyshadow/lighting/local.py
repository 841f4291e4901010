"""Local lights: point, sphere and spot lights with their shadows, through finite shadow rays.

Units, consistent with :class:`~pyshadow.lighting.DirectionalLight` and the
sky (the project's lighting notes): a light's ``intensity`` is RGB radiant
(or luminous) intensity in the sky's radiance units times sr times world
length squared (W/sr where radiance is W/(m^2 sr) and the scene is in
metres), so that a surface facing the light at distance ``d`` receives the
irradiance ``E = intensity / d^2`` in the units of ``DirectionalLight.irradiance``
and the terms add. Outgoing radiance (Lambertian)

    ``L_o = albedo / pi * intensity * spot(l) * max(n . l, 0) / d^2 * V``

with ``l`` the unit direction from the point to the light, ``spot`` the
spot light's cone factor (1 for a point light) and ``V`` the visibility of
the segment from the point to the light: :func:`pyshadow.visibility.visible`
with ``max_distance = d`` (:mod:`pyshadow.visibility.finite`; a light inside a
caster's bounding sphere is refused unless ``straddle="embree"``).

A sphere light (``radius > 0``) of uniform radiance ``L = intensity / (pi R^2)``
subtends the cone of half-angle ``a = asin(R / d)``; with ``samples = K`` its
``K`` directions are spread uniformly in solid angle over that cone (the
Fibonacci spiral of :func:`pyshadow.lighting.shade.sun_directions`, turned per
point by its pattern index and the seed), each traced to the sphere's
surface, and ``E = L * Omega * mean_k(max(n . l_k, 0) V_k)`` with ``Omega = 2 pi
(1 - cos a)`` (for ``R << d``: ``intensity / d^2 * mean(cos V)``). ``K = 1`` or
``radius = 0``: one ray to the centre, hard shadows, ``E = intensity * max(n . l, 0) / d^2 * V``
(a sphere wholly above the horizon gives exactly that; ``L * Omega * cos`` of the centre
alone would overstate it by ``2 / (1 + cos a)``: the mean cosine over the cone is
``cos * (1 + cos a) / 2``). Embree
(``backend="embree"``) answers the identical rays: the ground truth.

Disc and rectangle lights (one-sided, area-sampled, the same units) live in
:mod:`pyshadow.lighting.area`; :func:`lights_radiance` sums every kind.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ._checks import _floats, _number, in_range, unit_direction
from ._value import ArrayValue
from .sun import _GOLDEN

__all__ = ["PointLight", "SpotLight", "point_light_radiance", "lights_radiance", "light_directions"]

#: Spot half-angles (rad) below this have their cone factor from the angle (as ``-2 sin^2(angle / 2)``,
#: ``cos - 1`` without its rounding) rather than from the cosine.
NARROW_SPOT = 1e-3


def _position(x, name):
    v = _floats(x, name, "a finite 3-vector")
    if v.shape != (3,) or not np.isfinite(v).all():
        raise ValueError(f"{name}: expected a finite 3-vector (got {x!r})")
    return v


def _intensity(x, name):
    v = _floats(x, name, "an RGB 3-vector or a scalar")
    if v.shape not in ((3,), ()):
        raise ValueError(f"{name}: expected an RGB 3-vector or a scalar (got shape {v.shape})")
    v = np.broadcast_to(v, (3,)).copy()
    if not np.isfinite(v).all() or (v < 0).any():
        raise ValueError(f"{name}: must be finite and >= 0 (got {v.tolist()})")
    return v


@dataclass(frozen=True, eq=False)
class PointLight(ArrayValue):
    """A point light (``radius = 0``: hard shadows) or a sphere light (soft shadows).

    Attributes
    ----------
    position : ndarray, shape (3,), float64
        World position of the light's centre.
    intensity : ndarray, shape (3,), float64
        RGB intensity (>= 0): the irradiance on a surface facing the light at
        distance ``d`` is ``intensity / d^2`` (sky radiance units x sr; module
        docstring). A scalar means grey.
    radius : float
        Radius of the sphere light, world units (>= 0, finite).
    """

    position: np.ndarray
    intensity: np.ndarray
    radius: float = 0.0

    def __post_init__(self):
        self._set("position", _position(self.position, "light position"))
        self._set("intensity", _intensity(self.intensity, "light intensity"))
        r = _number(self.radius, "light radius")
        if not (math.isfinite(r) and r >= 0):
            raise ValueError(f"light radius: must be finite and >= 0 (got {self.radius!r})")
        self._set("radius", r)

    def factor(self, to_point) -> np.ndarray:
        """Angular factor of the intensity towards unit directions light -> point, (N,) (1 here)."""
        return np.ones(len(to_point))


@dataclass(frozen=True, eq=False)
class SpotLight(PointLight):
    """A spot light: a point (or sphere) light shining into a cone.

    Attributes
    ----------
    direction : ndarray, shape (3,)
        Unit axis of the cone, from the light towards where it shines.
    angle : float
        Half-angle of the cone, rad, in (0, pi/2]: no light outside it.
    falloff : float
        Width of the soft edge, rad, in [0, angle]: the factor rises from 0
        at ``angle`` to 1 at ``angle - falloff`` (smoothstep in the cosine);
        0 is a hard edge.
    """

    direction: np.ndarray = None
    angle: float = math.pi / 4
    falloff: float = 0.0

    def __post_init__(self):
        super().__post_init__()
        if self.direction is None:
            raise ValueError("spot direction: required (a unit 3-vector)")
        self._set("direction", unit_direction(self.direction, "spot direction"))
        a = _number(self.angle, "spot angle")
        if not (math.isfinite(a) and 0 < a <= math.pi / 2):
            raise ValueError(f"spot angle: must lie in (0, pi/2] (got {self.angle!r})")
        self._set("angle", a)
        self._set("falloff", in_range(self.falloff, "spot falloff", 0.0, a))

    def factor(self, to_point) -> np.ndarray:
        """Cone factor in [0, 1] of unit directions light -> point, (N,)."""
        t = np.asarray(to_point, np.float64)
        c = t @ self.direction
        lo, hi = math.cos(self.angle), math.cos(self.angle - self.falloff)
        if self.angle < NARROW_SPOT:    # cos(angle) rounds towards 1 (to 1 below 1.5e-8 rad): compare minus
            b = np.arctan2(np.linalg.norm(np.cross(t, self.direction), axis=-1), c)  # versines, same order
            c, lo, hi = (-2.0 * np.sin(0.5 * x) ** 2 for x in (b, self.angle, self.angle - self.falloff))
        if hi <= lo:                    # hard edge, the edge itself lit; cos(pi / 2) rounds to 6e-17, not 0
            return (c >= (0.0 if self.angle == math.pi / 2 else lo)).astype(np.float64)
        x = np.clip((c - lo) / (hi - lo), 0.0, 1.0)
        return np.where(c >= lo, x * x * (3.0 - 2.0 * x), 0.0)


def light_directions(axis, half_angle, k: int, indices, seed: int = 0) -> np.ndarray:
    """K unit directions per point spread uniformly in solid angle over a cone, (N, K, 3) float64.

    Parameters
    ----------
    axis : ndarray, shape (N, 3)
        Unit cone axes (point -> light centre).
    half_angle : ndarray, shape (N,)
        Half-angles, rad, in [0, pi/2].
    k : int
    indices : ndarray of int, shape (N,)
        Pattern index of each point (turns its spiral).
    seed : int

    ``cos a_j = 1 - (j + 1/2) / K (1 - cos half_angle)``, azimuth
    ``2 pi (j g + t_i)`` as :func:`pyshadow.lighting.shade.sun_directions`.
    """
    d = np.asarray(axis, np.float64)
    n = len(d)
    if k == 1:
        return d[:, None, :].copy()
    a = np.where(np.abs(d[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 0.0, 1.0]])
    e1 = np.cross(d, a)
    e1 /= np.linalg.norm(e1, axis=1, keepdims=True)
    e2 = np.cross(d, e1)
    j = np.arange(k)
    cos_a = 1.0 - (j[None, :] + 0.5) / k * (1.0 - np.cos(half_angle))[:, None]
    sin_a = np.sqrt(np.maximum(0.0, 1.0 - cos_a ** 2))
    u = float(np.random.default_rng(seed).random())
    turn = np.mod(u + (np.asarray(indices, np.int64)[:n] % (1 << 20)) * _GOLDEN, 1.0)
    phi = 2.0 * math.pi * (j[None, :] * _GOLDEN + turn[:, None])
    out = (cos_a[..., None] * d[:, None, :] + (sin_a * np.cos(phi))[..., None] * e1[:, None, :]
           + (sin_a * np.sin(phi))[..., None] * e2[:, None, :])
    return out / np.linalg.norm(out, axis=2, keepdims=True)


def _sphere_cone(position, centres, radii):
    """The cone from ``position`` holding spheres: ``(frame, half-angle)``, the frame (3, 3) float64 unit rows
    ``e1, e2, axis`` (right-handed), the half-angle in rad; ``(None, pi)`` where ``position`` lies within a
    sphere, there are none, or they lie around it (their unit directions' sum under half their count).

    The axis is that sum's direction; the half-angle the largest angle of a centre from it (by ``atan2``:
    exact for the tiny cones of far lights) plus the angle its sphere subtends, ``asin(r / d)``.
    """
    v = np.asarray(centres, np.float64) - position
    dist = np.linalg.norm(v, axis=1)
    a = (v / np.where(dist > 0, dist, 1.0)[:, None]).sum(axis=0)
    if not (len(v) and (dist > radii).all() and np.linalg.norm(a) > 0.5 * len(v)):
        return None, math.pi
    a /= np.linalg.norm(a)
    e1 = np.cross(np.eye(3)[int(np.argmin(np.abs(a)))], a)
    e1 /= np.linalg.norm(e1)
    half = np.arctan2(np.linalg.norm(np.cross(v, a), axis=1), v @ a) + np.arcsin(radii / dist)
    return np.stack([e1, np.cross(a, e1), a]), float(half.max())


def _check_shading(scene, albedo, indices, seed, surface_ids, geometric_normals, n):
    """The shared arguments of a local light's radiance, checked by name: ``(albedo (n, 3), indices, seed)``.

    ``albedo`` a scalar, RGB triple or (n, 3) values in [0, 1]; ``seed`` an
    int >= 0 (also where one ray a point needs none); ``surface_ids`` one or
    n instance ids of ``scene``; ``geometric_normals`` (n, 3) finite, non-zero.
    """
    from .._validate import check_indices, nonzero, rows3
    from ._checks import check_seed
    from .phong import _point_albedo

    if surface_ids is not None:
        scene.caster_slots(surface_ids, n)
    if geometric_normals is not None:
        nonzero(rows3(geometric_normals, "geometric_normals", n), "geometric_normals")
    return _point_albedo(albedo, n), check_indices(indices, n), check_seed(seed)


def point_light_radiance(scene, points, normals, light: PointLight, albedo, *, backend="csm", samples: int = 1,
                         surface_ids=None, indices=None, seed: int = 0, bias=None, straddle: str = "error",
                         geometric_normals=None):
    """Radiance of surface points lit by a point, sphere or spot light, with its shadow.

    Parameters
    ----------
    scene : pyshadow.Scene
    points : array_like, shape (N, 3)
        World positions (none may coincide with the light's centre or lie
        within a sphere light; on its surface they may: their rays to it have
        no length and reach it; each up to the rounding of the coordinates,
        4 float64 spacings of the largest of the point's, the centre's and the
        radius, as for :class:`~pyshadow.lighting.PhongLighting`).
    normals : array_like, shape (N, 3)
        World unit surface normals (normalised here; zero rows are an error).
    light : PointLight or SpotLight
    albedo : float or array_like, shape (3,) or (N, 3)
        Linear RGB albedo in [0, 1] (a scalar: grey).
    backend : str, optional
        Visibility backend (:func:`pyshadow.visibility.backends`); ``"embree"``
        is the ground truth on the identical rays.
    samples : int, optional
        Rays per point over a sphere light (``K``, >= 1; 1 for a point light).
    surface_ids, indices, seed, bias : optional
        As for :func:`pyshadow.visibility.visible` (``surface_ids``, ``bias``);
        the pattern index of each point (default ``arange(N)``) and the seed
        that turn the sphere light's spiral (an int >= 0, checked also where unused).
    straddle : {'error', 'embree'}, optional
        Rays ending inside a caster's bounding sphere (a light inside one):
        refused, or answered by Embree (:mod:`pyshadow.visibility.finite`).
    geometric_normals : ndarray, shape (N, 3), optional
        Finite, non-zero rows (any length).
        With ``normals`` shading normals: light directions at or below the
        geometric plane are shadowed (:mod:`pyshadow.shading_normals`).

    Returns
    -------
    radiance : ndarray, shape (N, 3), float64
        ``albedo / pi * E``, the module docstring's units.
    visibility : ndarray, shape (N,), float64
        Fraction of the point's light rays that reach the light (0 where the
        light is behind the surface or outside the spot's cone: nothing is
        traced there).
    """
    from .. import visibility as vis
    from .._validate import rows3, unit_normals

    if not isinstance(light, PointLight):
        raise TypeError(f"light: expected a PointLight or SpotLight (got {type(light).__name__})")
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or samples < 1:
        raise ValueError(f"samples: must be an int >= 1 (got {samples!r})")
    p = rows3(points, "points")
    nrm = unit_normals(normals, len(p))
    n = len(p)
    alb, idx, seed = _check_shading(scene, albedo, indices, seed, surface_ids, geometric_normals, n)
    to_light = light.position - p
    with np.errstate(over="ignore"):
        d = np.linalg.norm(to_light, axis=1)
    if n and not np.isfinite(d).all():                 # |p - light| beyond 1.3e154: no direction, no distance
        i = int(np.argmax(~np.isfinite(d)))
        raise ValueError(f"point {i} lies too far from the light (point {p[i].tolist()}, light "
                         f"{light.position.tolist()}): their distance overflows float64")
    if n:   # at the centre, or within a sphere light, but for the rounding of the coordinates (4 spacings of the
        # largest, PhongLighting's rule) is at it, or on its surface: a point p under a lamp of centre p + R n lay
        # within it half the time (0.85 - 0.75 < 0.1); one at the light but for rounding got I / d^2 of 7e24 I
        tol = 4.0 * np.finfo(np.float64).eps * np.maximum(np.abs(p).max(axis=1),
                                                           max(float(np.abs(light.position).max()), light.radius))
        ok = (d >= light.radius - tol) & (d > tol)      # on a sphere light's surface: E = I / R^2 facing it
        if not ok.all():
            i = int(np.argmin(np.where(ok, np.inf, d - light.radius)))
            where = "at the light" if light.radius == 0 or d[i] <= tol[i] else "within the sphere light"
            raise ValueError(f"point {i} lies {where} (distance {d[i]:.6g}, light radius {light.radius:g}): its "
                             f"irradiance is undefined")
    axis = to_light / np.where(d > 0, d, 1.0)[:, None]
    spot = light.factor(-axis)
    k = int(samples) if light.radius > 0 else 1
    rho = np.minimum(light.radius / d, 1.0) if n else np.zeros(0)                  # sin of the cone's half-angle
    half = np.arcsin(rho)
    dirs = light_directions(axis, half, k, idx, seed)                              # (N, K, 3)
    cos = np.maximum(np.einsum("nkj,nj->nk", dirs, nrm), 0.0)
    live = (cos > 0).any(axis=1) & (spot > 0)
    lit = np.zeros((n, k), bool)
    if live.any():
        rows = np.flatnonzero(live)
        # each ray runs to the sphere's near surface along its direction (to the centre: R = 0), in units
        # of d (no d^2 to overflow): t = d (cos b - sqrt(rho^2 - sin^2 b)), b the ray's angle to the axis
        c = np.einsum("nkj,nj->nk", dirs[rows], axis[rows])
        s2 = (np.cross(dirs[rows], axis[rows][:, None, :]) ** 2).sum(axis=2)
        tmax = d[rows][:, None] * (c - np.sqrt(np.maximum(rho[rows][:, None] ** 2 - s2, 0.0)))
        ids = None if surface_ids is None else np.repeat(np.broadcast_to(np.asarray(surface_ids), (n,))[rows], k)
        t = tmax.reshape(-1)
        go = t > 0              # a ray of no length (from a point on the sphere's surface) reaches it: not traced
        flat = np.ones(len(t), bool)
        if go.any():
            flat[go] = vis.visible(scene, np.repeat(p[rows], k, axis=0)[go], dirs[rows].reshape(-1, 3)[go],
                                   backend=backend, bias=bias, surface_ids=None if ids is None else ids[go],
                                   normals=np.repeat(nrm[rows], k, axis=0)[go], max_distance=t[go], straddle=straddle)
        lit[rows] = flat.reshape(len(rows), k)
    if geometric_normals is not None:
        from ..shading_normals import below_geometric

        lit = lit & ~below_geometric(dirs, geometric_normals)
    shaded = (cos * lit).mean(axis=1) * spot
    # E = I f^2 shaded: f = 1 / d for a point light; for a sphere L Omega = I f^2 with L = I / (pi R^2),
    # Omega = 2 pi (1 - cos a) = 4 pi sin^2(a / 2), so f = 2 sin(a / 2) / R (-> 1 / d as R / d -> 0,
    # where 1 - cos a would round to 0); I f (f shaded) neither squares d nor R. One ray (K = 1) to a sphere's
    # centre: its cosine is not the cone's mean cosine (that is cos (1 + cos a) / 2), so f = 1 / d, the exact
    # I cos / d^2 of a sphere above the horizon, as the K-ray mean converges to. Where R / d < 1e-8, f is 1 / d
    # to within (R / d)^2 / 8 < 2e-17, and 2 sin(a / 2) / R would lose R's digits: a radius of 5e-324 (a
    # subnormal R / d rounds to 0) made the light black
    f = 1.0 / d
    if light.radius > 0 and k > 1:
        f = np.where(rho < 1e-8, f, 2.0 * np.sin(0.5 * half) / light.radius)
    fs = f * shaded
    with np.errstate(over="ignore", invalid="ignore"):      # beyond float64: +inf, as shade's float32 (no warning)
        e = (light.intensity[None, :] * f[:, None]) * fs[:, None]
    e = np.where(fs[:, None] > 0, e, 0.0)       # unlit (shadow, behind, outside the cone): 0, not I f = inf times 0
    return alb / math.pi * e, np.where(live, lit.mean(axis=1), 0.0)


def lights_radiance(scene, points, normals, lighting, albedo, *, backend="csm", surface_ids=None, indices=None,
                    bias=None, geometric_normals=None) -> np.ndarray:
    """The sum of each light's radiance over ``lighting.lights``, (N, 3) float64.

    Point, sphere and spot lights through :func:`point_light_radiance`, disc
    and rectangle lights through :func:`pyshadow.lighting.area.area_light_radiance`;
    sphere and area lights take ``lighting.sun_samples`` rays a point, turned
    by ``lighting.seed``, and ``lighting.straddle`` decides the shadow rays
    ending inside a caster's bounding sphere; zeros without local lights.
    """
    from .._validate import check_rows
    from .area import AreaLight, area_light_radiance
    from ._checks import straddle_advice
    from .shade import _check_lighting

    out = np.zeros((len(check_rows(points, "points")), 3))
    for light in _check_lighting(lighting).lights:
        fn = area_light_radiance if isinstance(light, AreaLight) else point_light_radiance
        with straddle_advice("Lighting"):      # the visibility's advice names its own keyword: here Lighting's
            out += fn(scene, points, normals, light, albedo, backend=backend, samples=lighting.sun_samples,
                      surface_ids=surface_ids, indices=indices, seed=lighting.seed, bias=bias,
                      straddle=lighting.straddle, geometric_normals=geometric_normals)[0]
    return out

"""Sun extraction: split an environment map into a directional light and the sky without it.

The split is exact: on the texels the sun occupies, the sky keeps a smooth
(quadratic) background ``B_i = min(T_i, fit_i)`` and the sun takes the rest,
``T_i - B_i >= 0``; everywhere else the sky is the original. So
``sky.radiance + sun.texel_radiance(shape) == original`` texel by texel, and
the sun's irradiance at normal incidence is ``sum_i (T_i - B_i) Omega_i``
with the exact per-texel solid angles (not thesis 001's eq. 3.2, which
recovers about a quarter of the energy, nor its eq. 3.3 for the sky).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ._checks import in_range, positive
from ._value import ArrayValue
from .envmap import EnvironmentMap
from .sky import LUMINANCE_WEIGHTS, SUN_ANGULAR_RADIUS

__all__ = ["SunLight", "extract_sun"]


@dataclass(frozen=True, eq=False)
class SunLight(ArrayValue):
    """A directional light taken out of an environment map.

    Attributes
    ----------
    direction : ndarray, shape (3,), float64
        Unit vector towards the light, y up.
    irradiance : ndarray, shape (3,), float64
        RGB irradiance on a surface facing it (``E = irradiance * max(0, n . l)``),
        in the map's radiance units times sr.
    angular_radius : float
        Radius of the disc in rad: measured when the disc spans more than a
        texel, else the ``radius`` given to :func:`extract_sun` (a disc
        narrower than a texel cannot be measured).
    texels : ndarray, shape (K,), int64
        Flat indices (into the map's ``grid_shape``) of the texels the light
        was taken from.
    excess : ndarray, shape (K, 3), float64
        Radiance taken from each of those texels (>= 0).
    """

    direction: np.ndarray
    irradiance: np.ndarray
    angular_radius: float
    texels: np.ndarray
    excess: np.ndarray

    def texel_radiance(self, grid_shape) -> np.ndarray:
        """The light as a map: ``excess`` on its texels, 0 elsewhere, shape grid_shape + (3,)."""
        out = np.zeros((int(np.prod(grid_shape)), 3))
        out[self.texels] = self.excess
        return out.reshape(tuple(grid_shape) + (3,))


def _tangent_frame(d):
    a = np.array([1.0, 0.0, 0.0]) if abs(d[0]) < 0.9 else np.array([0.0, 0.0, 1.0])
    e1 = np.cross(d, a)
    e1 /= np.linalg.norm(e1)
    return e1, np.cross(d, e1)


_GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0


def sun_directions(light, k: int, indices, seed: int = 0) -> np.ndarray:
    """K directions over the light's disc for each point, (N, K, 3) float64, unit.

    Uniform in solid angle: ``cos a_j = 1 - (j + 1/2) / K (1 - cos r)``,
    azimuth ``2 pi (j g + t_i)`` with ``g`` the golden ratio's fraction and
    ``t_i = frac(u + i g)`` for the point's pattern index ``i`` and ``u``
    drawn from ``seed``. ``K = 1`` or ``r = 0``: the light's direction itself.

    Parameters
    ----------
    light : DirectionalLight or SunLight
        Anything with a unit ``direction`` (3,) and an ``angular_radius`` r in rad.
    k : int
        Directions per point (>= 1).
    indices : array_like of int, shape (N,)
        Pattern index of each point (>= 0): turns its pattern.
    seed : int
        >= 0.

    Raises
    ------
    TypeError
        ``k`` or ``indices`` not integers.
    ValueError
        ``k < 1``, a negative ``seed`` or index, ``indices`` not 1-D.
    """
    from .._validate import check_indices, check_int
    from ._checks import check_seed

    k = check_int(k, "k (directions per point)", 1)     # (0 gave no directions, 2.5 a skewed spread)
    seed = check_seed(seed)
    a = np.asarray(indices)
    if a.size == 0:                                       # [] is float64: no points, no directions
        a = a.astype(np.int64)
    if a.ndim != 1:
        raise ValueError(f"indices must be one pattern index per point, shape (N,) (got shape {a.shape})")
    idx = check_indices(a, len(a))                        # (-1 and 0.5 were taken as other points' patterns)
    n = len(idx)
    d = light.direction
    if k == 1 or light.angular_radius == 0.0:
        return np.broadcast_to(d, (n, 1, 3)).copy()
    e1, e2 = _tangent_frame(d)
    j = np.arange(k)
    cos_a = 1.0 - (j + 0.5) / k * (1.0 - math.cos(light.angular_radius))
    sin_a = np.sqrt(np.maximum(0.0, 1.0 - cos_a ** 2))
    u = float(np.random.default_rng(seed).random())
    turn = np.mod(u + (idx % (1 << 20)) * _GOLDEN, 1.0)
    phi = 2.0 * math.pi * (j[None, :] * _GOLDEN + turn[:, None])
    out = (cos_a[None, :, None] * d + (sin_a * np.cos(phi))[..., None] * e1
           + (sin_a * np.sin(phi))[..., None] * e2)
    return out / np.linalg.norm(out, axis=2, keepdims=True)


#: An excess below this fraction of a texel's radiance is the background fit's rounding (256 float64
#: spacings), not sun: such texels came and went when the map was scaled.
_ROUNDING = 2.0 ** -44


def _background(dirs, lum_or_rgb, omega, ring, centre):
    """Least-squares quadratic in the tangent coordinates (u, v) around ``centre``,
    Omega-weighted over the ``ring`` texels; returns a function of directions."""
    e1, e2 = _tangent_frame(centre)
    def design(d):
        u, v = d @ e1, d @ e2
        return np.stack([np.ones(len(d)), u, v, u * u, u * v, v * v], axis=1)
    A = design(dirs[ring]) * np.sqrt(omega[ring])[:, None]
    b = lum_or_rgb[ring] * np.sqrt(omega[ring])[:, None]
    coef, *_ = np.linalg.lstsq(A, b, rcond=None)
    return lambda d: design(d) @ coef


def _region(dirs, T, lum, omega, c, p, rad, rmax, thr):
    """Grow the cone around ``c``; return its texels, their background and their excess.

    The ring the background is fitted to stays within pi / 2 of ``c``, where the tangent coordinates
    (u, v) tell directions apart (beyond, a direction and its mirror image in the tangent plane share
    them: the ground below a horizon would be fitted as if it were sky). Where that leaves fewer ring
    texels than the quadratic's 6 coefficients (a map too coarse to tell a sun from its sky), no texels.
    The ring also keeps to the side of the horizon (y = 0) that ``c`` is on: a sky steps down to its
    ground there, which no quadratic follows, and the sky's glow above the horizon was taken for sun (a
    sun 2 degrees up on a 128-high clear sky measured 1.12 times its luminance, 1 degree up 1.53 times).
    """
    ang = np.arccos(np.clip(dirs @ c, -1.0, 1.0))
    # the texels any ring or region below can hold (rad <= rmax): the rest of the map is not visited again (a
    # 4096 x 2048 map's 8 M texels masked and copied each step took seconds); the same values, in map order
    near = np.flatnonzero(ang <= min(rmax + 8.0 * p, 0.5 * math.pi))
    dirs, T, lum, omega, ang = dirs[near], T[near], lum[near], omega[near], ang[near]
    side = (dirs[:, 1] >= 0.0) == (c[1] >= 0.0)
    lum_rgb = np.column_stack([lum, T])
    while True:
        for part in (side, True):           # both sides where the sun's holds too few texels (4 rows)
            ring = (ang > rad + p) & (ang <= min(rad + 3.0 * p, 0.5 * math.pi)) & part
            if ring.sum() < 24:
                ring = (ang > rad + p) & (ang <= min(rad + 8.0 * p, 0.5 * math.pi)) & part
            if ring.sum() >= 6:
                break
        if ring.sum() < 6:                  # no background to tell a sun from: all of it stays sky
            return np.zeros(0, np.int64), np.zeros((0, 3)), np.zeros((0, 3))
        fit = _background(dirs, lum_rgb, omega, ring, c)
        lum_fit = fit(dirs[ring])[:, 0]
        if not (lum[ring] > thr * np.maximum(lum_fit, 0.0)).any() or rad >= rmax:
            break
        rad = min(rad + p, rmax)
    inside = np.flatnonzero(ang <= rad + p)
    bg = np.clip(fit(dirs[inside])[:, 1:], 0.0, T[inside])
    excess = T[inside] - bg
    keep = (excess > _ROUNDING * T[inside]).any(axis=1)     # not the fit's rounding (4e-16..8e-16 on a flat sky)
    return near[inside[keep]], bg[keep], excess[keep]


def extract_sun(env: EnvironmentMap, *, radius: float = SUN_ANGULAR_RADIUS, enlarge: float = 4.0,
                threshold: float = 2.0, max_radius: float = 0.35):
    """Split ``env`` into a sun (a directional light) and the sky without it.

    Parameters
    ----------
    env : EnvironmentMap
        Any layout.
    radius : float
        Expected angular radius of the sun in rad, in (0, pi / 4] (default:
        the real sun's; pi / 4 is :data:`pyshadow.lighting.shade.MAX_SUN_RADIUS`,
        the largest sun :class:`~pyshadow.lighting.Lighting` takes).
    enlarge : float
        The search starts at ``enlarge * radius`` around the brightest texel
        (plus the texel pitch), for haze and camera blooming (thesis 001
        enlarges the sun by 4; here it is the radius that is enlarged).
    threshold : float
        The region grows, a texel pitch at a time, while the ring just outside
        it holds a texel brighter (in luminance) than ``threshold`` times the
        fitted background there.
    max_radius : float
        Largest region radius in rad, in [1e-6, pi / 4] (``MAX_SUN_RADIUS``).

    Returns
    -------
    sun : SunLight
    sky : EnvironmentMap
        Same layout as ``env``; ``sky.radiance + sun.texel_radiance(env.grid_shape)``
        equals ``env.radiance`` (to one rounding).

    Notes
    -----
    1. The brightest texel in luminance (Rec. 709 weights) seeds a cone of
       radius ``2 enlarge radius + 1.5 pitch`` (every texel a disc of that
       radius could touch when its centre is anywhere in the seed texel).
    2. A quadratic background ``a + b u + c v + d u^2 + e u v + f v^2`` in
       tangent coordinates around the cone's axis is fitted (Omega-weighted
       least squares, luminance and each channel) to the ring one to three
       pitches outside the cone (up to eight where that holds fewer than 24
       texels), within pi / 2 of the axis and on its side of the horizon
       y = 0; the cone grows by a pitch while that ring
       holds a texel brighter than ``threshold`` times the fit. The region is
       the cone plus the one-pitch buffer between it and the ring (where the
       partly covered edge texels of a disc lie).
    3. Inside the region, ``B_i = clip(fit_i, 0, T_i)`` per channel; the sun
       is ``T_i - B_i``. The axis moves to the luminance- and Omega-weighted
       mean direction of the excess and steps 2-3 repeat until it moves less
       than a quarter pitch (at most four times): the brightest texel of a
       large, faint disc on a graded sky can lie near its edge.
    4. Direction: that weighted mean. Radius: ``sqrt(2 <alpha^2> - pitch^2 / 3)``
       (a uniform disc has ``<alpha^2> = r^2 / 2``; ``pitch^2 / 3`` removes
       the texels' own spread) when that exceeds the pitch, else ``radius``;
       at most ``MAX_SUN_RADIUS`` (the region reaches a pitch or more past
       ``max_radius``: on a coarse map it can measure more, a sun Lighting refuses).
    A sky with no sun (overcast) yields a sun of nearly zero irradiance; a
    black map yields none (no texels, zero irradiance), and so does a map too
    coarse for step 2 (fewer than 6 ring texels within pi / 2 of the axis: a
    1 x 2 lat-long map, a cube of 2 x 2 faces, some 4 x 8 maps), which stays
    all sky. So does a flat disc (a clipped sun) wider than the start cone of
    step 1: the ring then lies inside it, the fit follows it and no ring texel
    stands out, so the cone never grows (a disc of radiance 1e4 on a sky of 1,
    4 degrees at 512 rows or 8 degrees at 128: zero irradiance); pass its
    ``radius``, and a ``max_radius`` of about twice it: where its texels are
    equal, the seed is the first of them in the map's order, on its edge (a
    disc of ``max_radius`` less 2 pitches kept 11 % to 70 % of its energy at
    256 and 512 rows, one of half ``max_radius`` all of it).
    """
    if not isinstance(env, EnvironmentMap):
        raise TypeError(f"env: expected an EnvironmentMap (got {type(env).__name__})")
    from .shade import MAX_SUN_RADIUS

    r0 = positive(radius, "radius")
    if r0 > MAX_SUN_RADIUS:                  # else the sun could be one Lighting refuses (or 10 rad: no disc)
        raise ValueError(f"radius: the sun's angular radius must lie in (0, MAX_SUN_RADIUS = pi / 4 = "
                         f"{MAX_SUN_RADIUS:.6g}], the largest sun Lighting takes (got {radius!r})")
    k = in_range(enlarge, "enlarge", 1.0, 100.0)
    thr = in_range(threshold, "threshold", 1.0, math.inf)
    rmax = in_range(max_radius, "max_radius (at most MAX_SUN_RADIUS = pi / 4)", 1e-6, MAX_SUN_RADIUS)
    T0 = env.radiance.reshape(-1, 3)
    # the split is scale-free: work on the map scaled by a power of two to a largest value in [0.5, 1)
    # (exact), so that neither the fit's squares overflow (1e300) nor the weighted mean direction
    # underflows to a zero vector (1e-300); the sun's excess and irradiance are scaled back
    shift = -math.frexp(float(T0.max()))[1] if T0.size and T0.max() > 0 else 0
    T = np.ldexp(T0, shift)
    dirs = env.directions().reshape(-1, 3)
    omega = env.solid_angles().reshape(-1)
    lum = T @ LUMINANCE_WEIGHTS
    p = env.pitch
    c = dirs[int(np.argmax(lum))]
    for _ in range(4):                       # re-centre on the excess until it stays put
        inside, bg, excess = _region(dirs, T, lum, omega, c, p, min(2.0 * k * r0 + 1.5 * p, rmax),
                                     rmax, thr)
        w = (excess @ LUMINANCE_WEIGHTS) * omega[inside]
        if w.sum() <= 0:
            break
        v = w @ dirs[inside]
        moved = float(np.arccos(np.clip(v @ c / np.linalg.norm(v), -1.0, 1.0)))
        c = v / np.linalg.norm(v)
        if moved <= 0.25 * p:
            inside, bg, excess = _region(dirs, T, lum, omega, c, p,
                                         min(2.0 * k * r0 + 1.5 * p, rmax), rmax, thr)
            break
    sky = T0.copy()
    sky[inside] = np.ldexp(bg, -shift)
    e_sun = np.ldexp(excess.T @ omega[inside], -shift)
    w = (excess @ LUMINANCE_WEIGHTS) * omega[inside]
    if w.sum() > 0:
        v = w @ dirs[inside]
        direction = v / np.linalg.norm(v)
        a = np.arccos(np.clip(dirs[inside] @ direction, -1.0, 1.0))
        spread = 2.0 * float(w @ a ** 2) / float(w.sum()) - p * p / 3.0
        measured = math.sqrt(max(spread, 0.0))
        ang_r = min(measured if measured > p else r0, MAX_SUN_RADIUS)
    else:
        direction, ang_r = c / np.linalg.norm(c), r0
    sun = SunLight(direction=direction, irradiance=e_sun, angular_radius=ang_r,
                   texels=inside.astype(np.int64), excess=T0[inside] - sky[inside])
    return sun, env.with_radiance(sky.reshape(env.radiance.shape))

"""Area lights: one-sided discs and rectangles with soft shadows, through finite shadow rays.

Units (as :mod:`pyshadow.lighting.local`, so the terms add with the sun and
the sky): a planar light of area ``A`` and uniform radiance ``L`` emitting
from its front face (along its unit normal ``n_L``, Lambertian) has the
intensity ``I = L A`` along its normal, in the sky's radiance units times sr
times world length squared; a surface facing it on its axis far away
receives ``E = I / d^2``, as from ``PointLight(intensity=I)``. The light is
given by ``intensity`` (RGB ``I``) or by ``power`` (RGB ``Phi = pi I``, the
flux of a one-sided Lambertian emitter: ``Phi = pi L A``).

Estimator (ratio: exact unshadowed irradiance times the sampled lit share).
With ``samples = K`` points ``y_k`` spread over the light's area (uniform in
area, stratified: a Vogel spiral on a disc, a Fibonacci lattice on a
rectangle, both turned per point by its pattern index and the seed, as the
sphere light's spiral), ``l_k = (y_k - p) / d_k``, ``d_k = |y_k - p|``,
``w_k = max(n . l_k, 0) max(-n_L . l_k, 0) / d_k^2``::

    E = E_0(p, n) * sum_k w_k V_k / sum_k w_k

``E_0`` the exact unshadowed irradiance ``integral L max(cos(theta), 0)
cos(theta_L) / d^2 dA`` (:mod:`pyshadow.lighting.area_exact`: closed forms,
the light clipped by the point's tangent plane), the fraction the lit share
of the sampled integrand (``visibility`` in the output); ``V_k`` from
:func:`pyshadow.visibility.visible` on the finite ray from ``p`` towards
``y_k`` with ``max_distance = d_k`` (:mod:`pyshadow.visibility.finite`).
Unshadowed the answer is exact for every ``K`` (the share is 1); shadows are
estimated (consistent: the share converges as ``K`` grows). Outgoing
radiance ``albedo / pi * E``. ``K = 1``: the single sample is the light's
centre, ``E = E_0 V(centre)`` (hard shadows). Where no sample lies in front
of the receiver's plane (``sum_k w_k = 0``) while a sliver of the light
does, the share and ``E`` are 0 (no ray to decide; nothing leaks through a
wall; how often: benchmarks/README.md, "Area lights near the light").
Embree (``backend="embree"``) traces the identical rays: the ground truth; a
converged reference is Embree with many samples.

The share is ``[0, 1]``, so the estimate never exceeds ``E_0``; near the light
(``h`` below about ``2 R / sqrt(K)``) penumbrae stay noisy: the weights peak
within about ``h`` of the point's foot, which few samples reach. The accuracy
near the light, against the area-sampling mean this replaced: benchmarks/README.md.

One-sided: a point behind the light's plane (``(p - c) . n_L <= 0``) gets no
light and nothing is traced for it. A point on the plane within the light's
extent (the light lies on its surface) gets none either where its normal
faces the way the light emits (``n . n_L > 0``: a lamp lying on a table top,
a panel set in a floor or a ceiling): every direction to the light lies in
the light's plane, along which it emits nothing (and for ``n = n_L`` the
irradiance just in front of the light is 0 too). Facing into the
light (``n . n_L <= 0``) its irradiance is undefined (0 on the plane, about
``pi L`` just in front of it) and the point is refused (``ValueError``).
"""
from __future__ import annotations

import math
import sys
from dataclasses import InitVar, dataclass

import numpy as np

from ._checks import _number, unit_direction
from ._value import ArrayValue
from .area_exact import unshadowed_factor
from .local import PointLight, SpotLight, _check_shading, _intensity, _position
from .sun import _tangent_frame as _frame   # two unit vectors completing a unit normal

__all__ = ["DiscLight", "RectLight", "AreaLight", "LIGHT_TYPES", "area_light_samples", "area_light_radiance"]

_GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0
_SQRT2_FRAC = math.sqrt(2.0) - 1.0
#: Rays per visibility call (points are taken in chunks of about this many rays).
CHUNK_RAYS = 1 << 20
#: Relative tolerance of the "point on the light's plane" test (times the light's size plus the distance).
PLANE_TOL = 1e-9
#: Largest |cos| of the angle between a rectangle's edges u and v (that of float32 data: a rotation held in
#: float32 leaves up to about 1e-7; the light normals' unit-length tolerance is the same 1e-6).
ORTHO_TOL = 1e-6
#: Smallest disc radius and rectangle edge length, world units: the square root of the smallest normal float64,
#: so that areas and squared lengths stay normal numbers.
MIN_EXTENT = math.sqrt(sys.float_info.min)


def _flux(obj, intensity, power):
    if (intensity is None) == (power is None):
        raise ValueError(f"{type(obj).__name__}: give exactly one of intensity= or power= "
                         f"(got intensity={intensity!r}, power={power!r})")
    if power is not None:
        return _intensity(power, "light power") / math.pi
    return _intensity(intensity, "light intensity")


def _extent(x, name):
    r = _number(x, name)
    if not (math.isfinite(r) and r > 0):
        raise ValueError(f"{name}: must be finite and > 0 (a zero-area light has no radiance; got {x!r})")
    if r < MIN_EXTENT:              # its square underflows: the area (and the rectangle's normal) came out 0, the
        raise ValueError(f"{name}: must be at least MIN_EXTENT = {MIN_EXTENT:.6g} (its square underflows "
                         f"float64, and the light's radiance with it; got {x!r})")    # radiance inf: NaN or 0 lit
    return r


def _finite_radiance(light):
    """Refuse ``light`` where its radiance ``I / A`` overflows float64 (a tiny, bright light)."""
    with np.errstate(over="ignore"):
        finite = np.isfinite(light.radiance).all()
    if not finite:
        raise ValueError(f"light intensity: {light.intensity.tolist()} over the area {light.area:.6g} is a radiance "
                         f"beyond float64 (a smaller intensity or a larger light)")


@dataclass(frozen=True, eq=False)
class DiscLight(ArrayValue):
    """A one-sided Lambertian disc light.

    Attributes
    ----------
    position : ndarray, shape (3,), float64
        World position of the disc's centre.
    normal : ndarray, shape (3,), float64
        Unit normal; the disc emits into the half-space it points to.
    radius : float
        Radius, world units (finite, >= ``MIN_EXTENT``, about 1.5e-154).
    intensity : ndarray, shape (3,), float64
        RGB intensity along the normal, ``I = L pi radius^2`` (>= 0, and ``L``
        finite in float64; module docstring). Give this or ``power`` (init only: ``Phi = pi I``).
    """

    position: np.ndarray
    normal: np.ndarray
    radius: float
    intensity: np.ndarray = None
    power: InitVar[object] = None

    def __post_init__(self, power):
        self._set("position", _position(self.position, "light position"))
        self._set("normal", unit_direction(self.normal, "light normal"))
        self._set("radius", _extent(self.radius, "disc light radius"))
        self._set("intensity", _flux(self, self.intensity, power))
        _finite_radiance(self)

    @property
    def area(self) -> float:
        """Area, world units squared."""
        return math.pi * self.radius ** 2

    @property
    def radiance(self) -> np.ndarray:
        """Uniform RGB radiance ``L = I / A``, (3,)."""
        return self.intensity / self.area

    def sample(self, uv) -> np.ndarray:
        """World points of unit-disc coordinates ``uv`` (..., 2) (|uv| <= 1), (..., 3)."""
        e1, e2 = _frame(self.normal)
        uv = np.asarray(uv, np.float64) * self.radius
        return self.position + uv[..., :1] * e1 + uv[..., 1:] * e2

    def inside(self, q) -> np.ndarray:
        """Whether in-plane offsets from the centre (..., 3) lie within the disc, (...,) bool."""
        return np.linalg.norm(q, axis=-1) <= self.radius * (1 + 1e-12)


@dataclass(frozen=True, eq=False)
class RectLight(ArrayValue):
    """A one-sided Lambertian rectangle light.

    Attributes
    ----------
    position : ndarray, shape (3,), float64
        World position of the rectangle's centre.
    u, v : ndarray, shape (3,), float64
        Edge half-vectors, world units (finite, of length >= ``MIN_EXTENT``, orthogonal to a
        relative 1e-6, as float32 data are): the corners are ``position +-
        u +- v``; the light emits along its normal ``u x v / |u x v|``.
    intensity : ndarray, shape (3,), float64
        RGB intensity along the normal, ``I = L 4 |u| |v|`` (>= 0, ``L`` finite). Give
        this or ``power`` (init only: ``Phi = pi I``).
    """

    position: np.ndarray
    u: np.ndarray
    v: np.ndarray
    intensity: np.ndarray = None
    power: InitVar[object] = None

    def __post_init__(self, power):
        self._set("position", _position(self.position, "light position"))
        for name in ("u", "v"):
            e = _position(getattr(self, name), f"rectangle light edge {name}")
            _extent(np.linalg.norm(e), f"rectangle light edge {name}: length")
            self._set(name, e)
        nu, nv = np.linalg.norm(self.u), np.linalg.norm(self.v)
        if abs(self.u @ self.v) > ORTHO_TOL * nu * nv:
            raise ValueError(f"rectangle light: edges u and v must be orthogonal (u.v = {self.u @ self.v:.6g})")
        self._set("intensity", _flux(self, self.intensity, power))
        _finite_radiance(self)

    @classmethod
    def facing(cls, position, normal, width: float, height: float, *, intensity=None, power=None):
        """A ``width`` x ``height`` rectangle centred at ``position`` emitting along the unit ``normal``.

        The ``width`` edge lies along the first vector of an orthonormal frame
        of ``normal`` (``normal x (1, 0, 0)`` normalised, or ``normal x (0, 0, 1)``
        when ``normal`` is within ~26 deg of the x axis).
        """
        n = unit_direction(normal, "light normal")
        e1, e2 = _frame(n)
        return cls(position, e1 * 0.5 * _extent(width, "rectangle width"),
                   e2 * 0.5 * _extent(height, "rectangle height"), intensity=intensity, power=power)

    @property
    def normal(self) -> np.ndarray:
        """Unit normal ``u x v / |u x v|``, (3,)."""
        c = np.cross(self.u, self.v)
        m = np.linalg.norm(c)
        if m < MIN_EXTENT:              # its square underflows (edges of 1e-100: a NaN normal, the light black)
            c = np.cross(self.u / np.linalg.norm(self.u), self.v / np.linalg.norm(self.v))
            m = np.linalg.norm(c)
        return c / m

    @property
    def area(self) -> float:
        """Area ``4 |u| |v|``, world units squared."""
        return 4.0 * float(np.linalg.norm(self.u) * np.linalg.norm(self.v))

    @property
    def radiance(self) -> np.ndarray:
        """Uniform RGB radiance ``L = I / A``, (3,)."""
        return self.intensity / self.area

    def sample(self, ab) -> np.ndarray:
        """World points of square coordinates ``ab`` (..., 2) in [-1, 1]^2, (..., 3)."""
        ab = np.asarray(ab, np.float64)
        return self.position + ab[..., :1] * self.u + ab[..., 1:] * self.v

    def inside(self, q) -> np.ndarray:
        """Whether in-plane offsets from the centre (..., 3) lie within the rectangle, (...,) bool."""
        a = np.abs(q @ self.u) / (self.u @ self.u)
        b = np.abs(q @ self.v) / (self.v @ self.v)
        return (a <= 1 + 1e-12) & (b <= 1 + 1e-12)


#: The area light classes.
AreaLight = (DiscLight, RectLight)
#: Every local light :class:`pyshadow.lighting.Lighting` accepts in ``lights``.
LIGHT_TYPES = (PointLight, SpotLight, DiscLight, RectLight)


def _pattern(light, k: int, indices, seed: int) -> np.ndarray:
    """Stratified light coordinates per point, (N, K, 2) float64 (module docstring)."""
    idx = np.asarray(indices, np.int64) % (1 << 20)
    n = len(idx)
    if k == 1:
        return np.zeros((n, 1, 2))
    u = np.random.default_rng(seed).random(2)
    j = np.arange(k)
    t = np.mod(u[0] + idx * _GOLDEN, 1.0)
    if isinstance(light, DiscLight):            # Vogel spiral: radius sqrt((j + 1/2) / K), golden azimuth
        r = np.sqrt((j + 0.5) / k)[None, :]
        phi = 2.0 * math.pi * (j[None, :] * _GOLDEN + t[:, None])
        return np.stack([r * np.cos(phi), r * np.sin(phi)], axis=-1)
    s = np.mod(u[1] + idx * _SQRT2_FRAC, 1.0)   # Fibonacci lattice, Cranley-Patterson shifted per point
    x = np.mod((j[None, :] + 0.5) / k + s[:, None], 1.0)
    y = np.mod(j[None, :] * _GOLDEN + t[:, None], 1.0)
    return np.stack([2.0 * x - 1.0, 2.0 * y - 1.0], axis=-1)


def area_light_samples(light, k: int, indices, seed: int = 0) -> np.ndarray:
    """The K sample points over the light's area for each point, (N, K, 3) float64, world.

    Parameters
    ----------
    light : DiscLight or RectLight
    k : int
        Samples per point (>= 1); 1 is the light's centre.
    indices : array_like of int, shape (N,)
        Pattern index of each point: turns its pattern.
    seed : int

    Disc: ``radius sqrt((j + 1/2) / K)`` at azimuth ``2 pi (j g + t_i)`` (``g``
    the golden ratio's fraction, ``t_i = frac(u_0 + i g)``). Rectangle:
    ``(frac((j + 1/2) / K + s_i), frac(j g + t_i))`` mapped to ``[-1, 1]^2``,
    ``s_i = frac(u_1 + i (sqrt 2 - 1))``; ``u_0, u_1`` drawn from ``seed``.
    Both are uniform in area and stratified.

    Raises
    ------
    TypeError
        ``light`` not a disc or rectangle light; ``k``, ``seed`` or ``indices`` not integers.
    ValueError
        ``k < 1``, ``seed < 0``, ``indices`` not 1-D or negative.
    """
    from .._validate import check_indices, check_int

    if not isinstance(light, AreaLight):
        raise TypeError(f"light: expected a DiscLight or RectLight (got {type(light).__name__})")
    k = check_int(k, "k (samples per point)", 1)
    seed = check_int(seed, "seed", 0)
    a = np.asarray(indices)
    if a.ndim != 1:
        raise ValueError(f"indices must be one pattern index per point, shape (N,) (got shape {a.shape})")
    return light.sample(_pattern(light, k, check_indices(a, len(a)), seed))


def _check_plane(light, p, nrm=None):
    """Signed heights above the light's plane (N,), 0 on it; refuse points on the plane within the light
    whose unit normals ``nrm`` (N, 3) face into it (module docstring; ``nrm`` None: every such point)."""
    q = p - light.position
    h = q @ light.normal
    size = light.radius if isinstance(light, DiscLight) else math.sqrt(light.area)
    with np.errstate(over="ignore"):
        dist = np.linalg.norm(q, axis=1)
    if not np.isfinite(dist).all():                # beyond about 1e154 from the light: no distance to shade with
        i = int(np.argmax(~np.isfinite(dist)))
        raise ValueError(f"point {i} lies too far from the {type(light).__name__} (point {p[i].tolist()}, light "
                         f"{light.position.tolist()}): their distance overflows float64")
    on = np.abs(h) <= PLANE_TOL * (size + dist)
    bad = on & light.inside(q - h[:, None] * light.normal)
    bad = np.flatnonzero(bad if nrm is None else bad & (nrm @ light.normal <= 0))
    if len(bad):
        facing = "" if nrm is None else ", facing into the light"
        raise ValueError(f"point {bad[0]} lies on the {type(light).__name__}'s plane within its extent{facing} "
                         f"({len(bad)} such points): its irradiance is undefined")
    return np.where(on, 0.0, h)


def area_light_radiance(scene, points, normals, light, albedo, *, backend="csm", samples: int = 16,
                        surface_ids=None, indices=None, seed: int = 0, bias=None, straddle: str = "error",
                        geometric_normals=None):
    """Radiance of surface points lit by a disc or rectangle light, with its soft shadow.

    Parameters
    ----------
    scene : pyshadow.Scene
    points : array_like, shape (N, 3)
        World positions (none on the light's plane within its extent with
        its normal facing into the light: module docstring).
    normals : array_like, shape (N, 3)
        World surface normals (normalised here; zero or non-finite rows are an error).
    light : DiscLight or RectLight
    albedo : float or array_like, shape (3,) or (N, 3)
        Linear RGB albedo in [0, 1] (a scalar: grey).
    backend : str, optional
        Visibility backend (:func:`pyshadow.visibility.backends`); ``"embree"``
        traces the identical rays: the ground truth.
    samples : int, optional
        Points ``K`` over the light per surface point (>= 1; 1: its centre,
        ``E = E_0 V(centre)``).
    surface_ids, indices, seed, bias : optional
        As for :func:`pyshadow.visibility.visible` (``surface_ids``, ``bias``);
        the pattern index of each point (default ``arange(N)``) and the seed
        that turn its pattern (:func:`area_light_samples`) (an int >= 0, checked also where unused).
    straddle : {'error', 'embree'}, optional
        Rays ending inside a caster's bounding sphere: refused or answered by
        Embree (:mod:`pyshadow.visibility.finite`).
    geometric_normals : ndarray, shape (N, 3), optional
        Finite, non-zero rows (any length).
        With ``normals`` shading normals: rays at or below the geometric
        plane are shadowed (:mod:`pyshadow.shading_normals`).

    Returns
    -------
    radiance : ndarray, shape (N, 3), float64
        ``albedo / pi * E`` (module docstring), the sun's units.
    visibility : ndarray, shape (N,), float64
        The lit share ``sum_k w_k V_k / sum_k w_k`` with ``w_k`` the k-th
        sample's weight (0 where no sample lights the point: behind the light
        or the surface; nothing is traced there); ``E = E_0 * visibility``.
    """
    from .. import visibility as vis
    from .._validate import rows3, unit_normals

    if not isinstance(light, AreaLight):
        raise TypeError(f"light: expected a DiscLight or RectLight (got {type(light).__name__})")
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or samples < 1:
        raise ValueError(f"samples: must be an int >= 1 (got {samples!r})")
    p = rows3(points, "points")
    n = len(p)
    nrm = unit_normals(normals, n)
    alb, idx, seed = _check_shading(scene, albedo, indices, seed, surface_ids, geometric_normals, n)
    ids_all = None if surface_ids is None else np.broadcast_to(np.asarray(surface_ids), (n,))
    gn = None if geometric_normals is None else np.asarray(geometric_normals, np.float64)
    h = _check_plane(light, p, nrm)
    k = int(samples)
    num, den, g = np.zeros(n), np.zeros(n), np.zeros(n)
    front = np.flatnonzero(h > 0)
    step = max(1, CHUNK_RAYS // k)
    for lo in range(0, len(front), step):
        rows = front[lo:lo + step]
        y = area_light_samples(light, k, idx[rows], seed)                          # (M, K, 3)
        dv = y - p[rows, None, :]
        d = np.linalg.norm(dv, axis=2)
        w_dir = dv / d[..., None]
        cos_s = np.maximum(np.einsum("mkj,mj->mk", w_dir, nrm[rows]), 0.0)
        cos_l = np.maximum(-(w_dir @ light.normal), 0.0)
        w = cos_s * cos_l / d ** 2
        lit = np.zeros(w.shape, bool)
        m, s = np.nonzero(w > 0)
        if len(m):
            ids = None if ids_all is None else ids_all[rows][m]
            lit[m, s] = vis.visible(scene, p[rows][m], w_dir[m, s], backend=backend, bias=bias, surface_ids=ids,
                                    normals=nrm[rows][m], max_distance=d[m, s], straddle=straddle)
        if gn is not None:
            from ..shading_normals import below_geometric

            lit &= ~below_geometric(w_dir, gn[rows])
        num[rows] = (w * lit).sum(axis=1)
        den[rows] = w.sum(axis=1)
        g[rows] = unshadowed_factor(light, p[rows], nrm[rows])
    frac = np.divide(num, den, out=np.zeros(n), where=den > 0)
    e = light.radiance[None, :] * (g * frac)[:, None]
    return alb / math.pi * e, frac


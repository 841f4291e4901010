"""Shading: surface points and a :class:`Lighting` in, linear RGB radiance out (issue 19).

Composed from the visibility protocol (:mod:`pyshadow.visibility`); no kernel
of its own but the AO kernel's transfer sums. The same code runs on every backend (``"csm"``, ``"csm-vote"``,
``"numpy"``, ``"numpy-vote"``, ``"embree"``), so the NumPy reference of the
composition is this module with ``backend="numpy"``.

Convention (Lambertian, the project's lighting notes): outgoing radiance
``L_o = albedo / pi * E`` with ``E`` the irradiance in the lighting's
radiance units times sr (lux for cd/m^2 skies). Two terms; the sky's comes
in one of the modes of ``Lighting(mode=)``:

sky, mode "bent" (thesis 000 section 5.3.4)
    ``albedo / pi * max(E_sky(b), 0) * AO`` with ``E_sky`` the
    9-coefficient irradiance of the sky's SH coefficients
    (:func:`pyshadow.lighting.irradiance_sh`, clamped at 0 where the order-3
    truncation rings) at the bent normal ``b``, and ``AO`` and ``b`` from
    :func:`pyshadow.visibility.ambient_occlusion`.
sky, mode "transfer" (precomputed radiance transfer, shadowed by every body)
    ``albedo / pi * max(sum_k L_k T_k, 0)`` with ``L_k`` the sky's SH
    coefficients and ``T_k`` the point's shadowed transfer, accumulated
    from the same cosine-weighted directions as AO
    (:mod:`pyshadow.lighting.transfer`: 9 sums instead of one, inside the
    AO kernel on the CSM backends). Other moving bodies shadow the sky
    where they are, not only by turning the bent normal.
sky, mode "sampled" (the accurate mode, thesis 000 section 7)
    ``albedo * (1/S) sum_s L_env(w_s) V(p, w_s)`` over the S
    cosine-weighted directions ``w_s`` that AO traces
    (:func:`pyshadow.sample_directions` for the ``sampling`` and the point's
    pattern index), ``V`` from :func:`pyshadow.visibility.visible` asked
    with the surface normal, ``L_env`` the sky's environment map at the
    nearest texel (:meth:`EnvironmentMap.lookup` of the direction
    normalised in float64). With the pdf ``cos / pi`` of the directions
    this is the unbiased estimator of ``albedo / pi * integral L_env V cos
    dOmega``, i.e. of ``albedo / pi * E`` with the sky's shadowed
    irradiance ``E``. Needs the map (a Lighting made from SH coefficients
    alone refuses the mode). The AO and bent normal reported with it are
    those of the same samples (:func:`pyshadow.sampling.ao_from_samples`).
sun (a directional light with its shadow)
    ``albedo / pi * E_sun / K * sum_k max(n . l_k, 0) V(p, l_k)`` with
    ``V`` from :func:`pyshadow.visibility.visible` asked with the surface
    normal (the surface rule: grazing light does not self-shadow a face).
    ``K = 1`` (``l_1`` the sun's direction) unless the sun has an angular
    radius > 0 and ``K > 1`` (``Lighting(sun_samples=K)``; by default
    :data:`SAMPLED_SUN_SAMPLES` in mode "sampled", 1 otherwise): then ``l_k``
    are K directions spread uniformly in solid angle over the sun's disc
    (a Fibonacci spiral on the cap, turned about the axis per point by the
    point's pattern index and the seed: deterministic), and the shadow is
    soft. A penumbra narrower than a CSM's map spacing or texel is not
    resolved (the project's lighting notes): the real sun (0.27 deg) comes out hard.

Without a sky (:attr:`Lighting.has_sky` False) the sky term is 0 in every mode and no AO is asked
(:mod:`pyshadow.lighting.shade_checks`): a backend of light rays alone shades the sun and local lights.

The sky given to :class:`Lighting` should not hold the sun when a sun is
given too (use the sky returned by :func:`pyshadow.lighting.extract_sun`, or
:meth:`Lighting.clear_sky`), else the sun is counted twice.
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from ._checks import _floats, check_seed, flag, in_range, light_tuple, positive, sh_coefficients, unit_direction
from ._value import ArrayValue
from .envmap import EnvironmentMap
from .local import lights_radiance
from .sh import SH_COUNT, _irradiance
from .shade_checks import _check_points, asks_ambient_occlusion, check_albedo_ids
from .sun import extract_sun, sun_directions

__all__ = ["Lighting", "DirectionalLight", "ShadedPoints", "shade", "shade_terms", "sky_radiance",
           "sampled_sky_radiance", "transfer_sky_radiance", "sun_radiance", "sun_directions", "MODES",
           "SAMPLED_SUN_SAMPLES", "DEFAULT_ALBEDO", "DEFAULT_GROUND_ALBEDO"]

#: Shading modes.
MODES = ("bent", "transfer", "sampled")
#: Rays per visibility call of the "sampled" sky and of the "transfer" sky's host route (points in chunks of as many).
SAMPLED_CHUNK_RAYS = 1 << 20
#: Sun rays a point in mode "sampled" unless ``Lighting(sun_samples=)`` says otherwise: over the real disc a
#: shadow edge's pixel then differs from the reference by steps of 1/16 of the sun's term, not all of it.
SAMPLED_SUN_SAMPLES = 16
#: Albedo of instances without one of their own.
DEFAULT_ALBEDO = (0.8, 0.8, 0.8)
#: Albedo of the ground plane.
DEFAULT_GROUND_ALBEDO = (0.5, 0.5, 0.5)
#: Largest sun angular radius accepted (rad).
MAX_SUN_RADIUS = math.pi / 4


def _albedo(a, name: str) -> np.ndarray:
    try:        # text ("0.5", read as 0.5), complex numbers (the imaginary part dropped) and bools (True read
        # as 1: white) are no albedo
        v = None if isinstance(a, (str, bytes)) or np.asarray(a).dtype.kind in "SUcb" \
            else np.asarray(a, dtype=np.float64)
    except (TypeError, ValueError):
        v = None
    if v is None or v.shape not in ((3,), ()):
        raise ValueError(f"{name}: expected an RGB albedo of shape (3,) or a scalar (got {a!r})")
    v = np.broadcast_to(v, (3,)).copy()
    if not np.isfinite(v).all():
        raise ValueError(f"{name}: not finite (got {v.tolist()})")
    if (v < 0).any() or (v > 1).any():
        raise ValueError(f"{name}: albedo must lie in [0, 1] per channel (got {v.tolist()})")
    return v


@dataclass(frozen=True, eq=False)
class DirectionalLight(ArrayValue):
    """A directional light: the sun.

    Attributes
    ----------
    direction : ndarray, shape (3,), float64
        Unit vector from the scene towards the light, y up.
    irradiance : ndarray, shape (3,), float64
        RGB irradiance on a surface facing the light (>= 0, finite; a scalar is grey), in the
        sky's radiance units times sr: the disc's radiance integrated over its solid angle. With
        K > 1 directions a facing surface gets ``irradiance * (1 + cos r) / 2`` (r the angular radius:
        the disc's mean cosine, 0.854 at pi / 4), with one ``irradiance`` itself.
    angular_radius : float
        Radius of the light's disc in rad, in [0, pi/4].
    """

    direction: np.ndarray
    irradiance: np.ndarray
    angular_radius: float = 0.0

    def __post_init__(self):
        d = unit_direction(self.direction, "sun direction")
        e = _floats(self.irradiance, "sun irradiance", "an RGB 3-vector or a scalar")
        e = np.full(3, e) if e.shape == () else e       # a scalar: grey (as a point light's intensity)
        if e.shape != (3,):
            raise ValueError(f"sun irradiance: expected an RGB 3-vector or a scalar (got shape {e.shape})")
        if not np.isfinite(e).all() or (e < 0).any():
            raise ValueError(f"sun irradiance: must be finite and >= 0 (got {e.tolist()})")
        r = in_range(self.angular_radius, "sun angular_radius", 0.0, MAX_SUN_RADIUS)
        self._set("direction", d)
        self._set("irradiance", e)
        self._set("angular_radius", r)

    @classmethod
    def of(cls, light) -> "DirectionalLight":
        """A DirectionalLight from anything with ``direction``, ``irradiance`` and ``angular_radius``
        (e.g. :class:`pyshadow.lighting.SunLight`)."""
        if isinstance(light, cls):
            return light
        try:
            return cls(light.direction, light.irradiance, light.angular_radius)
        except AttributeError:
            raise TypeError(f"sun: expected a DirectionalLight or SunLight "
                            f"(got {type(light).__name__})") from None


class Lighting:
    """What lights a scene: a sky as SH coefficients, an optional sun, the surfaces' albedos.

    Parameters
    ----------
    sky : EnvironmentMap or array_like of shape (9, 3), optional
        The sky (without the sun, if ``sun`` is given): an environment map
        (projected with :meth:`EnvironmentMap.sh`, and kept as :attr:`env`
        for the "sampled" mode) or its order-3 SH coefficients, linear RGB.
        Default: no sky (zeros).
    sun : DirectionalLight or SunLight, optional
        The directional light; its shadow comes from the visibility backend.
    lights : sequence of PointLight, SpotLight, DiscLight or RectLight, optional
        Local lights with their shadows (:mod:`pyshadow.lighting.local`, ``.area``),
        added to the sun's term; sphere and area lights take ``sun_samples`` rays.
    albedo : float or array_like (3,), optional
        RGB albedo in [0, 1] of every instance without one in ``albedos``.
    albedos : mapping {instance id: albedo}, optional
        Per-instance RGB albedo. Shading refuses an id its scene never held (``ValueError``); a removed
        instance's id (``Scene.remove``) is accepted and colours nothing.
    ground_albedo : float or array_like (3,), optional
        RGB albedo of the ground plane (``pyshadow.scene.GROUND_ID``).
    mode : {"bent", "transfer", "sampled"}, optional
        How the sky is shaded (module docstring). "sampled" needs ``sky``
        as an :class:`EnvironmentMap` (or no sky at all).
    sun_samples : int, optional
        Rays K a point (1 .. 1024) over the sun's disc (when its angular
        radius is > 0) and over sphere and area lights; 1: hard shadows.
        Default: :data:`SAMPLED_SUN_SAMPLES` in mode "sampled" (the accurate
        mode samples the sun's real disc), 1 in the others.
    seed : int >= 0, optional
        Seed of the per-point turn of the sun's directions.
    straddle : {"error", "embree"}, optional
        The local lights' shadow rays ending inside a caster's bounding sphere
        (a light inside one): refused or answered by Embree (as ``PhongLighting``'s).

    Raises
    ------
    ValueError
        Non-finite SH coefficients or a wrong shape, an albedo outside
        [0, 1] or non-finite, a zero or non-unit sun direction, negative or
        non-finite sun irradiance, an unknown mode, ``mode="sampled"`` with
        a sky given as SH coefficients only.

    Attributes
    ----------
    sh : ndarray (9, 3)
        The sky's SH coefficients.
    env : EnvironmentMap or None
        The sky's map, when the sky was given as one.
    """

    def __init__(self, sky=None, *, sun=None, albedo=DEFAULT_ALBEDO, albedos=None,
                 ground_albedo=DEFAULT_GROUND_ALBEDO, mode: str = "bent", sun_samples: int | None = None, seed: int = 0,
                 lights=(), straddle: str = "error"):
        from ..visibility.finite import check_straddle

        self.straddle = check_straddle(straddle)
        self.lights = light_tuple(lights)
        env = sky if isinstance(sky, EnvironmentMap) else None
        if sky is None:
            coef = np.zeros((SH_COUNT, 3))
        elif env is not None:
            coef = sky.sh()
        else:
            coef = sh_coefficients(sky, "sky", "an EnvironmentMap or SH coefficients")
        if not isinstance(mode, str) or mode not in MODES:     # (an array's `in` is no answer)
            raise ValueError(f"mode: expected one of {', '.join(MODES)} (got {mode!r})")
        if mode == "sampled" and sky is not None and env is None:
            raise ValueError("mode 'sampled' needs the sky as an EnvironmentMap (it looks up the map's radiance "
                             "per sample direction); this sky was given as SH coefficients only")
        self._sun_samples_asked = sun_samples
        if sun_samples is None:
            sun_samples = SAMPLED_SUN_SAMPLES if mode == "sampled" else 1
        if isinstance(sun_samples, bool) or not isinstance(sun_samples, (int, np.integer)) \
                or not 1 <= sun_samples <= 1024:
            raise ValueError(f"sun_samples: expected an int in 1 .. 1024 (got {sun_samples!r})")
        seed = check_seed(seed)
        per = {}
        if albedos is not None:
            if not isinstance(albedos, Mapping):
                raise ValueError(f"albedos: expected a mapping {{instance id: RGB}} "
                                 f"(got {type(albedos).__name__})")
            for k, v in albedos.items():
                if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 0:
                    raise ValueError(f"albedos: keys must be instance ids >= 0 (got {k!r})")
                per[int(k)] = _albedo(v, f"albedos[{k}]")
        self.sh = coef
        self.env = env
        self.sun = None if sun is None else DirectionalLight.of(sun)
        self.albedo = _albedo(albedo, "albedo")
        self.albedos = per
        self.ground_albedo = _albedo(ground_albedo, "ground_albedo")
        self.mode = mode
        self.sun_samples = int(sun_samples)
        self.seed = int(seed)

    @classmethod
    def from_environment(cls, env: EnvironmentMap, *, extract: bool = True, sun_radius: float | None = None,
                         **kwargs) -> "Lighting":
        """Lighting from an environment map: with ``extract``, its sun becomes a directional light
        (:func:`pyshadow.lighting.extract_sun`, told the disc's angular radius ``sun_radius`` in rad, in (0, pi / 4],
        default the real sun's: a much larger disc is otherwise found only in part; none where it has zero
        irradiance) and the rest the SH sky; else all of it is SH sky. ``extract`` is True or False
        (TypeError otherwise: "no" was true)."""
        if not isinstance(env, EnvironmentMap):
            raise TypeError(f"env: expected an EnvironmentMap (got {type(env).__name__})")
        r = None if sun_radius is None else positive(sun_radius, "sun_radius")     # also where unused
        radius = {} if r is None else {"radius": in_range(r, "sun_radius", 0, MAX_SUN_RADIUS)}   # extract_sun's range
        if not flag(extract, "extract"):
            return cls(env, **kwargs)
        sun, sky = extract_sun(env, **radius)
        # none found (zero irradiance: a flat or black map, an overcast sky): no light to trace shadows of
        return cls(sky, sun=sun if (sun.irradiance > 0).any() else None, **kwargs)

    @classmethod
    def clear_sky(cls, sun_direction, turbidity: float = 3.0, *, height: int = 64, **kwargs) -> "Lighting":
        """The Preetham clear sky (:func:`pyshadow.lighting.clear_sky` without its disc) as SH, and
        its sun (:func:`pyshadow.lighting.sun_irradiance`, the real angular radius) as the light."""
        from .sky import SUN_ANGULAR_RADIUS, clear_sky, sun_irradiance

        sky = clear_sky(sun_direction, turbidity, height=height, sun=False)
        sun = DirectionalLight(sun_direction, sun_irradiance(sun_direction, turbidity), SUN_ANGULAR_RADIUS)
        return cls(sky, sun=sun, **kwargs)

    def with_mode(self, mode: str, **changes) -> "Lighting":
        """The same sky, sun and albedos shaded in another ``mode``, with ``changes`` (``sun_samples``,
        ``seed``) to the constructor's other arguments; checked as in the constructor."""
        kw = dict(sun=self.sun, albedo=self.albedo, albedos=dict(self.albedos), ground_albedo=self.ground_albedo,
                  sun_samples=self._sun_samples_asked, seed=self.seed, lights=self.lights, straddle=self.straddle)
        sky = self.env if self.env is not None else (self.sh if self.sh.any() else None)    # zeros: no sky
        return Lighting(sky, mode=mode, **{**kw, **changes})

    @property
    def has_sky(self) -> bool:
        """Whether there is a sky term: SH coefficients not all 0, or a map not all black. Without one the
        sky term is 0 in every mode and :func:`shade_terms` asks no AO (sun and local lights only)."""
        return bool(self.sh.any()) or (self.env is not None and bool(self.env.radiance.any()))

    def albedo_of(self, surface_ids, n: int | None = None) -> np.ndarray:
        """RGB albedo of each point's surface, (N, 3) float64.

        ``surface_ids``: instance ids, ``GROUND_ID`` (-2) for the ground,
        -1 (unknown) for the default ``albedo``; a scalar applies to all ``n``.
        """
        from ..scene import GROUND_ID

        ids = np.asarray(-1 if surface_ids is None else surface_ids)
        if ids.ndim == 0:
            if n is None:
                raise ValueError("surface_ids: a scalar needs the number of points")
            ids = np.full(n, ids)
        if ids.ndim != 1 or (n is not None and len(ids) != n) or not np.issubdtype(ids.dtype, np.integer):
            raise ValueError(f"surface_ids: expected ({'N' if n is None else n},) ints (got shape {ids.shape}, "
                             f"dtype {ids.dtype})")
        out = np.tile(self.albedo, (len(ids), 1))
        out[ids == GROUND_ID] = self.ground_albedo
        for k, v in self.albedos.items():
            out[ids == k] = v
        return out

    def __repr__(self) -> str:
        sun = "none" if self.sun is None else (f"dir={np.round(self.sun.direction, 4).tolist()}, "
                                              f"E={np.round(self.sun.irradiance, 4).tolist()}, "
                                              f"r={self.sun.angular_radius:.4g}")
        return (f"Lighting(mode={self.mode!r}, sky L00={np.round(self.sh[0], 4).tolist()}, sun {sun}, "
                f"albedo={self.albedo.tolist()}, {len(self.albedos)} per-instance, "
                f"ground={self.ground_albedo.tolist()}, sun_samples={self.sun_samples})")


@dataclass(eq=False)
class ShadedPoints:
    """The terms of :func:`shade_terms`, one row per point.

    Attributes
    ----------
    radiance : (N, 3) float32
        ``sky + sun``, linear.
    sky, sun : (N, 3) float32
        The two terms of the module docstring (``sun`` with the local lights'
        radiance added, :mod:`pyshadow.lighting.local`).
    ao : (N,) float32
        "bent": :func:`pyshadow.visibility.ambient_occlusion`'s; "sampled": the
        visible fraction of the sky estimator's own directions (the same
        directions, asked through ``visible``). NaN where the Lighting has no sky
        (:attr:`Lighting.has_sky` False: no AO is asked, the sky term is 0).
    bent_normal : (N, 3) float32
        Normalised sum of the visible directions, as ``ao`` (NaN without a sky).
    sun_visibility : (N,) float32
        Fraction of the K sun directions that reach the sky from above the
        surface (1 without a sun).
    """

    radiance: np.ndarray
    sky: np.ndarray
    sun: np.ndarray
    ao: np.ndarray
    bent_normal: np.ndarray
    sun_visibility: np.ndarray


def _check_lighting(lighting):
    if not isinstance(lighting, Lighting):
        raise TypeError(f"lighting: expected a pyshadow.lighting.Lighting (got {type(lighting).__name__})")
    return lighting


def sky_radiance(lighting: Lighting, ao, bent_normals, albedo) -> np.ndarray:
    """The "bent" sky term ``albedo / pi * max(E_sky(bent), 0) * AO``, (N, 3) float64.

    Pure NumPy: ``ao`` (N,), ``bent_normals`` (N, 3) unit (zero rows give
    the sky's band-0 irradiance, as a direction-free fallback), ``albedo`` (N, 3).
    A Lighting in mode "sampled" is refused (its sky term is
    :func:`sampled_sky_radiance`'s), so that no caller shades it as "bent" unawares.
    """
    _check_lighting(lighting)
    if lighting.mode != "bent":
        raise ValueError(f"sky_radiance is the 'bent' sky term; this Lighting is in mode {lighting.mode!r}: "
                         f"shade it with pyshadow.lighting.shade / shade_terms (sampled_sky_radiance)")
    a = np.asarray(ao, dtype=np.float64)
    b = np.asarray(bent_normals, dtype=np.float64)
    alb = np.asarray(albedo, dtype=np.float64)
    n = len(a)
    if a.shape != (n,) or b.shape != (n, 3) or alb.shape != (n, 3):
        raise ValueError(f"sky_radiance: ao (N,), bent_normals (N, 3) and albedo (N, 3) must agree "
                         f"(got {a.shape}, {b.shape}, {alb.shape})")
    for what, x in (("ao", a), ("bent_normals", b), ("albedo", alb)):
        if not np.isfinite(x).all():            # NaN radiance otherwise
            raise ValueError(f"sky_radiance: {what} holds {int((~np.isfinite(x)).sum())} non-finite value(s)")
    if n == 0:
        return np.zeros((0, 3))
    e = np.maximum(_irradiance(np.asarray(lighting.sh, dtype=np.float64), b), 0.0)   # zero bent rows: band 0
    return alb / math.pi * e * a[:, None]


def sampled_sky_radiance(scene, points, normals, lighting: Lighting, albedo, *, backend="csm", sampling=None,
                         surface_ids=None, indices=None, bias=None, geometric_normals=None):
    """The "sampled" sky term, with the AO and bent normals of its samples.

    ``albedo * mean_s L_env(w_s) V(p, w_s)`` over the cosine-weighted
    directions ``w_s = pyshadow.sample_directions(normals, sampling=sampling,
    indices=indices)`` (those AO traces), ``V`` from
    :func:`pyshadow.visibility.visible` asked with the normals and
    ``surface_ids`` (module docstring); a CSM backend and lat-long map: in the AO
    kernel (:mod:`pyshadow.lighting.sampled`), else chunks of :data:`SAMPLED_CHUNK_RAYS` rays.

    Parameters
    ----------
    points, normals : ndarray (N, 3)
        World positions and unit normals (checked by the caller; see
        :func:`shade_terms`).
    lighting : Lighting
        Its :attr:`Lighting.env` is the sky (no map and zero SH: the term is 0).
    albedo : ndarray (N, 3)
    backend, sampling, surface_ids, indices, bias :
        As in :func:`shade_terms`.
    geometric_normals : ndarray (N, 3), optional
        When ``normals`` are shading normals: directions at or below the
        geometric plane are occluded (:mod:`pyshadow.shading_normals`).

    Returns
    -------
    sky : ndarray (N, 3), float64
    ao : ndarray (N,), float32
        Fraction of the directions that reach the sky.
    bent : ndarray (N, 3), float32
        Normalised sum of those directions (the normal where none does).
    """
    from ..sampling import Sampling, ao_from_samples
    from .sampled import device_sampled_sky
    from .transfer import sample_visibility

    _check_lighting(lighting)
    if sampling is None:
        sampling = Sampling()
    elif not isinstance(sampling, Sampling):
        raise TypeError(f"sampling must be a pyshadow.Sampling, got {sampling!r}")
    env = lighting.env
    if env is None and np.any(lighting.sh != 0):
        raise ValueError("the 'sampled' sky needs the sky's EnvironmentMap; this Lighting holds SH "
                         "coefficients only")
    p = np.asarray(points, dtype=np.float64)
    nrm = np.asarray(normals, dtype=np.float64)
    alb = np.asarray(albedo, dtype=np.float64)
    n, k = len(p), sampling.samples
    idx = np.arange(n) if indices is None else np.asarray(indices, dtype=np.int64)
    ids = None if surface_ids is None else np.broadcast_to(np.asarray(surface_ids), (n,))
    got = device_sampled_sky(scene, p, nrm, env, backend=backend, sampling=sampling, indices=indices, surface_ids=ids,
                             bias=bias, geometric_normals=geometric_normals)      # the AO kernel (.sampled)
    if got is not None:
        return alb * got[0], got[1], got[2]
    sky = np.zeros((n, 3))
    ao = np.zeros(n, np.float32)
    bent = np.zeros((n, 3), np.float32)
    step = max(1, SAMPLED_CHUNK_RAYS // k)
    for a in range(0, n, step):
        b = min(n, a + step)
        m = b - a
        dirs, lit = sample_visibility(scene, p[a:b], nrm[a:b], backend=backend, sampling=sampling,
                                      indices=idx[a:b], surface_ids=None if ids is None else ids[a:b],
                                      bias=bias, geometric_normals=None if geometric_normals is None
                                      else np.asarray(geometric_normals)[a:b])     # (m, S, 3) float32, (m, S)
        flat = dirs.reshape(-1, 3)
        if env is not None:
            w = flat.astype(np.float64)
            w /= np.linalg.norm(w, axis=1, keepdims=True)
            rad = env.lookup(w).reshape(m, k, 3)
            sky[a:b] = alb[a:b] * (rad * lit[..., None]).mean(axis=1)
        ao[a:b], bent[a:b] = ao_from_samples(dirs, lit, nrm[a:b].astype(np.float32), return_bent_normals=True)
    return sky, ao, bent


def transfer_sky_radiance(scene, points, normals, lighting: Lighting, albedo, *, backend="csm", sampling=None,
                          surface_ids=None, indices=None, bias=None, geometric_normals=None):
    """The "transfer" sky term ``albedo / pi * max(sum_k L_k T_k, 0)``, with the AO and bent normals.

    ``T`` from :func:`pyshadow.lighting.transfer.sh_transfer` (the AO kernel's
    9 extra sums on the CSM backends), ``L`` the sky's SH coefficients; the
    arguments as :func:`sampled_sky_radiance`'s. Returns (N, 3) float64,
    (N,) float32, (N, 3) float32.
    """
    from .transfer import sh_transfer

    _check_lighting(lighting)
    ao, bent, T = sh_transfer(scene, points, normals, backend=backend, sampling=sampling,
                              surface_ids=surface_ids, indices=indices, bias=bias, geometric_normals=geometric_normals)
    return transfer_sky(lighting, T, albedo), ao, bent


def transfer_sky(lighting: Lighting, transfer, albedo) -> np.ndarray:
    """``albedo / pi * max(sum_k L_k T_k, 0)`` for given transfer vectors ``T`` (N, 9): (N, 3) float64."""
    from .transfer import transfer_irradiance

    e = np.maximum(transfer_irradiance(lighting.sh, transfer), 0.0)
    return np.asarray(albedo, dtype=np.float64) / math.pi * e


def sun_radiance(scene, points, normals, lighting: Lighting, albedo, *, backend="csm", surface_ids=None,
                 indices=None, bias=None, geometric_normals=None):
    """The sun term and the visible fraction of its directions: ((N, 3) float64, (N,) float64).

    ``points`` (N, 3), ``normals`` (N, 3) unit, ``albedo`` (N, 3); zero
    radiance and visibility 1 without a sun. A direction at or below the
    surface's plane (``n . l <= 0``) is not visible. One :func:`pyshadow.visibility.visible`
    call of N K rays, asked with the normals; with ``geometric_normals`` (N, 3)
    (``normals`` then shading normals) directions at or below the geometric
    plane are shadowed (:mod:`pyshadow.shading_normals`).
    """
    from .. import visibility as vis

    _check_lighting(lighting)
    p = np.asarray(points, dtype=np.float64)
    nrm = np.asarray(normals, dtype=np.float64)
    n = len(p)
    sun = lighting.sun
    if sun is None or n == 0:
        return np.zeros((n, 3)), np.ones(n)
    idx = np.arange(n) if indices is None else np.asarray(indices, dtype=np.int64)
    dirs = sun_directions(sun, lighting.sun_samples, idx, lighting.seed)          # (N, K, 3)
    k = dirs.shape[1]
    cos = np.maximum(np.einsum("nkj,nj->nk", dirs, nrm), 0.0)
    ids = None if surface_ids is None else np.repeat(np.broadcast_to(np.asarray(surface_ids), (n,)), k)
    # cos > 0: a sun behind the face does not reach it (the CSM let some such rays through the body, Embree none)
    lit = vis.visible(scene, np.repeat(p, k, axis=0), dirs.reshape(-1, 3), backend=backend, bias=bias,
                      surface_ids=ids, normals=np.repeat(nrm, k, axis=0)).reshape(n, k) & (cos > 0)
    if geometric_normals is not None:
        from ..shading_normals import below_geometric

        lit = lit & ~below_geometric(dirs, geometric_normals)
    e = sun.irradiance[None, :] * (cos * lit).mean(axis=1)[:, None]
    return np.asarray(albedo, dtype=np.float64) / math.pi * e, lit.mean(axis=1)


def shade_terms(scene, points, normals, lighting: Lighting, *, backend="csm", sampling=None, surface_ids=None,
                indices=None, bias=None) -> ShadedPoints:
    """Shade surface points: the sky term, the sun term and what they came from.

    Parameters
    ----------
    scene : pyshadow.Scene
    points, normals : array_like, shape (N, 3)
        World positions and surface normals (normalised here; zero or
        non-finite rows are an error).
    lighting : Lighting
    backend : str or VisibilityBackend, optional
        Who answers AO and the sun's shadow rays (:mod:`pyshadow.visibility`). One that answers only
        light rays (:class:`pyshadow.lighting.ShadowMapVisibility`) shades a Lighting without a sky.
    sampling : pyshadow.Sampling, optional
        AO sampling (default ``Sampling()``); in mode "sampled" also the
        directions of the sky's estimator.
    surface_ids : int or array_like of int, optional
        Instance id of each point's surface (``GROUND_ID`` for the ground,
        -1 unknown): picks the albedo and the self-bias.
    indices : array_like of int, shape (N,), optional
        Sample-pattern index of each point (AO patterns and the sun's turn);
        default ``arange(N)``.
    bias : float, optional
        As in :func:`pyshadow.visibility.visible`.

    Returns
    -------
    ShadedPoints

    Raises
    ------
    ValueError
        Bad points, normals, ids or indices; a Lighting with a sky on a backend that answers no AO.
    """
    from .. import visibility as vis

    _check_lighting(lighting)
    p, nrm, idx = _check_points(scene, points, normals, surface_ids, indices, lighting, "shade_terms", sampling)
    albedo = lighting.albedo_of(surface_ids, len(p))
    n = len(p)
    if n == 0:
        z3, z1 = np.zeros((0, 3), np.float32), np.zeros(0, np.float32)
        return ShadedPoints(z3, z3, z3, z1, z3, z1)
    if not asks_ambient_occlusion(lighting, backend, "shade_terms") or not lighting.has_sky:
        sky, ao, bent = np.zeros((n, 3)), np.full(n, np.nan), np.full((n, 3), np.nan)     # no sky: no AO asked
    elif lighting.mode == "sampled":
        sky, ao, bent = sampled_sky_radiance(scene, p, nrm, lighting, albedo, backend=backend, sampling=sampling,
                                             surface_ids=surface_ids, indices=idx, bias=bias)
    elif lighting.mode == "transfer":
        sky, ao, bent = transfer_sky_radiance(scene, p, nrm, lighting, albedo, backend=backend, sampling=sampling,
                                              surface_ids=surface_ids, indices=idx, bias=bias)
    else:
        ao, bent = vis.ambient_occlusion(scene, p, nrm, backend=backend, sampling=sampling,
                                         return_bent_normals=True, bias=bias, indices=idx, surface_ids=surface_ids)
        sky = sky_radiance(lighting, ao, bent, albedo)
    sun, frac = sun_radiance(scene, p, nrm, lighting, albedo, backend=backend, surface_ids=surface_ids,
                             indices=idx, bias=bias)
    sun = sun + lights_radiance(scene, p, nrm, lighting, albedo, backend=backend, surface_ids=surface_ids,
                                indices=idx, bias=bias)
    f32 = np.float32
    with np.errstate(over="ignore"):                        # beyond float32 (or float64): +inf, no warning
        return ShadedPoints(radiance=(sky + sun).astype(f32), sky=sky.astype(f32), sun=sun.astype(f32),
                            ao=np.asarray(ao, f32), bent_normal=np.asarray(bent, f32), sun_visibility=frac.astype(f32))


def shade(scene, points, normals, lighting: Lighting, **kwargs) -> np.ndarray:
    """Linear RGB radiance leaving each surface point, (N, 3) float32 (:func:`shade_terms`'s ``radiance``)."""
    return shade_terms(scene, points, normals, lighting, **kwargs).radiance

"""Screen-space ambient occlusion (SSAO) from a G-buffer, with its NumPy reference.

The standard sample-based method: about each pixel's surface point ``p``
(normal ``n``) ``samples`` cosine-weighted directions ``w`` -- pyshadow's own
(:func:`pyshadow.sample_directions`, pattern = the pixel's index
``r * W + c``) -- give sample points ``q = p + radius * w`` on the
hemisphere of radius ``radius``. Each is projected into the camera's image;
it counts as occluded when the depth buffer at that pixel (nearest) holds a
surface closer to the camera than ``q`` by more than ``bias`` (view depth,
along the camera's forward axis) and that surface's view depth lies within
``radius`` of the pixel's own (the range check: a surface far in front is
another object, not an occluder near ``p``). Samples behind the eye, off the
image or over the background are open. AO = 1 - occluded fraction, 1 =
open, as everywhere in pyshadow.

What it estimates: a sample point at distance ``radius`` along ``w`` lies
behind the visible surface exactly when the ray from ``p`` along ``w`` has
entered an occluder before ``radius`` -- provided the occluder is thick and
its front is what the camera sees. So SSAO estimates the *distance-limited*
AO with ``D = radius`` (:func:`pyshadow.visibility.ambient_occlusion`,
``max_distance=radius``) on the same directions; it misses what the camera
does not see (off screen, hidden behind other surfaces, thin occluders seen
edge-on), and its nearest-pixel depth lookup with ``bias`` decides samples
that graze a surface.

:func:`screen_space_ao` runs ``kernels/ssao.cl``; :func:`screen_space_ao_reference`
does the same in float64 NumPy (same float32 inputs and directions) and
can return each pixel's margin: the two differ only at pixels with a
sample within float32 rounding of a decision (a pixel edge or a depth
threshold).
"""
from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from . import _cl
from ._validate import FLOAT32_MAX, unit_normals
from .sampling import MAX_SAMPLES, Sampling, direction_table, pattern_indices, sample_directions

__all__ = ["screen_space_ao", "screen_space_ao_reference", "view_depth"]

_MIN_DEPTH = float(np.finfo(np.float32).tiny)
_TINY = float(np.finfo(np.float64).tiny)     # floor of the margins' divisors (was 1e-30: not scale-free)


def _check(gbuffer, camera, radius, samples, seed, bias, range_check):
    """Validated inputs: float32 eye-relative points (N, 3), normals (N, 3), view depth (N,), and the options."""
    from .camera import Camera

    if not isinstance(camera, Camera):
        raise TypeError(f"camera must be a pyshadow.Camera, got {camera!r}")
    if not isinstance(gbuffer, Mapping):
        raise TypeError(f"gbuffer must be a mapping with 'depth' and 'normal' (render_gbuffer's dict or a Frame), "
                        f"got {type(gbuffer).__name__}")
    H, W = camera.height, camera.width
    for key, shape in (("depth", (H, W)), ("normal", (H, W, 3))):
        if key not in gbuffer:
            raise ValueError(f"gbuffer lacks {key!r} (screen_space_ao needs 'depth' and 'normal')")
        if np.shape(gbuffer[key]) != shape:
            raise ValueError(f"gbuffer[{key!r}] has shape {np.shape(gbuffer[key])}; the camera needs {shape}")
    radius = _number(radius, "radius", "a number (world units)")
    if not (np.isfinite(radius) and radius > 0):
        raise ValueError(f"radius must be finite and > 0 (world units), got {radius}")
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or not 1 <= samples <= MAX_SAMPLES:
        raise ValueError(f"samples must be an int in 1..{MAX_SAMPLES}, got {samples!r}")
    if bias is not None:
        bias = _number(bias, "bias", "a number (world units) or None")
    bias = 0.02 * radius if bias is None else bias
    if not (np.isfinite(bias) and bias >= 0):
        raise ValueError(f"bias must be finite and >= 0 (world units), got {bias}")
    for name, v in (("radius", radius), ("bias", bias)):        # the kernel reads them as float32
        if v > FLOAT32_MAX:
            raise ValueError(f"{name} must be at most {FLOAT32_MAX:.3g} (float32's range; world units), got {v:g}")
    if not isinstance(range_check, (bool, np.bool_)):
        raise TypeError(f"range_check must be a bool, got {range_check!r}")
    depth = _depth(gbuffer, camera).reshape(-1)
    normal = _real(gbuffer["normal"], "gbuffer['normal']").reshape(-1, 3)
    hit = np.isfinite(depth)
    try:                                # any length (unnormalised normals of a mesh in micrometres)
        unit = unit_normals(normal[hit], int(hit.sum()), "gbuffer['normal']")
    except ValueError as e:
        raise ValueError(f"gbuffer['normal'] must be finite and non-zero wherever depth is finite ({e})") from None
    dirs = camera.ray_directions().reshape(-1, 3)
    rel = np.where(hit[:, None], np.where(hit, depth, 0.0)[:, None] * dirs, 0.0)
    unit_scale = _fit_float32(rel, radius, bias)
    if unit_scale != 1.0:               # (ordinary scenes: nothing to scale)
        rel, depth, radius, bias = rel * unit_scale, depth * unit_scale, radius * unit_scale, bias * unit_scale
    n = np.zeros_like(normal)
    n[hit] = unit
    n[~hit] = (0.0, 1.0, 0.0)
    return (rel.astype(np.float32), n.astype(np.float32), _view_depth(depth, camera).reshape(-1), radius,
            Sampling(int(samples), seed=seed), np.float32(bias),
            np.float32(radius if range_check else np.inf))


def _fit_float32(rel, radius: float, bias: float) -> float:
    """A power of two that keeps the lengths of the SSAO kernel finite and normal in float32, 1 if they are.

    A sample point ``p + radius * w`` has coordinates up to ``|p|_1 + radius``
    (``|p|_1`` the sum of the absolute coordinates of a surface point ``p``
    relative to the eye), and its view coordinates up to ``sqrt(3)`` times
    that: where ``max |p|_1 + radius + bias`` exceeds ``2**125`` (4.3e37) they
    could overflow float32 (a G-buffer 3e38 away with a radius of 1.5e38 left
    84 of 768 pixels up to 0.16 off the unit scene's). SSAO does not change when
    every length is scaled by a power of two (no significand changes), so
    scaling them down by the least one that brings that sum to ``2**125`` keeps
    the answer; below it nothing is scaled. Scenes whose sum lies below
    ``2**-100`` (8e-31) are scaled up to it, so that neither a length (a small
    bias, a coordinate near 0) nor a product in the kernel is rounded to a
    float32 subnormal.
    """
    top = float(np.abs(rel).sum(axis=1).max(initial=0.0)) + radius + bias
    if top < 2.0 ** -100:               # likewise up: no length rounded to a float32 subnormal
        return float(2.0 ** (-100 - np.floor(np.log2(top))))
    if top <= 2.0 ** 125:
        return 1.0
    return float(2.0 ** (125 - np.ceil(np.log2(top))))


def _number(value, name: str, what: str) -> float:
    """``value`` as a float; TypeError naming ``name`` for what is no number (a bool, a string, complex)."""
    if isinstance(value, (bool, np.bool_, str, bytes)):     # True was a radius of 1, "0.5" one of 0.5
        raise TypeError(f"{name} must be {what}, got {value!r}")
    try:
        return float(value)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be {what}, got {value!r}") from None


def _real(a, name: str) -> np.ndarray:
    """``a`` as a float64 array; TypeError naming ``name`` unless it holds integers or floats (bool
    depths read as 0 and 1, strings were parsed, complex normals lost their imaginary part)."""
    a = np.asarray(a)
    if a.dtype.kind not in "iuf":
        raise TypeError(f"{name} must hold real numbers, got dtype {a.dtype}")
    return a.astype(np.float64, copy=False)


def _depth(gbuffer, camera) -> np.ndarray:
    """``gbuffer['depth']`` (H, W) as float64, checked: > 0 and within float32's normal range where
    finite, +inf on the background."""
    from .camera import Camera

    if not isinstance(camera, Camera):
        raise TypeError(f"camera must be a pyshadow.Camera, got {camera!r}")
    if not isinstance(gbuffer, Mapping):
        raise TypeError(f"gbuffer must be a mapping with 'depth' (render_gbuffer's dict or a Frame), "
                        f"got {type(gbuffer).__name__}")
    if "depth" not in gbuffer:
        raise ValueError("gbuffer lacks 'depth'")
    depth = _real(gbuffer["depth"], "gbuffer['depth']")
    if depth.shape != (camera.height, camera.width):
        raise ValueError(f"gbuffer['depth'] has shape {depth.shape}; the camera needs "
                         f"{(camera.height, camera.width)}")
    hit = np.isfinite(depth)
    odd = np.isnan(depth) | (depth == -np.inf)
    if odd.any():
        raise ValueError(f"gbuffer['depth'] holds {int(odd.sum())} NaN or -inf value(s); use +inf for the background")
    low = hit & (depth <= 0)
    if low.any():                       # (a renderer's 0 on the background)
        raise ValueError(f"gbuffer['depth'] must be > 0 where finite (the distance from the eye; +inf for the "
                         f"background), got {int(low.sum())} value(s) <= 0, down to {float(depth[low].min()):g}")
    if hit.any() and float(depth[hit].max()) > FLOAT32_MAX:
        raise ValueError(f"gbuffer['depth'] holds distances beyond float32's range (up to "
                         f"{float(depth[hit].max()):.3g}; the kernel reads at most {FLOAT32_MAX:.3g})")
    if hit.any() and float(depth[hit].min()) < _MIN_DEPTH:     # float32 subnormals (a view at 1e-46: all open)
        raise ValueError(f"gbuffer['depth'] holds distances below float32's normal range (down to "
                         f"{float(depth[hit].min()):.3g}; the kernel reads at least {_MIN_DEPTH:.3g})")
    return depth


def view_depth(gbuffer, camera) -> np.ndarray:
    """View depth (along ``camera.forward``) of each pixel's surface, (H, W) float32, +inf for the background.

    ``depth * (ray direction . forward)`` from the G-buffer's distance along
    each pixel's ray (world units), checked as :func:`screen_space_ao` checks
    it (a wrong shape, NaN, -inf or a distance <= 0 raises ValueError).
    """
    return _view_depth(_depth(gbuffer, camera), camera)


def _view_depth(depth, camera) -> np.ndarray:
    """:func:`view_depth` of checked distances ``depth`` (H, W) or (H * W,) float64."""
    cos = (camera.ray_directions() @ camera.forward).reshape(depth.shape)
    with np.errstate(invalid="ignore"):
        z = np.where(np.isfinite(depth), depth * cos, np.inf)
    return z.astype(np.float32)


def _camera_args(camera):
    f = 1.0 / camera.tan_half
    return [np.float32(x) for x in (*camera.right, *camera.up, *camera.forward, f / camera.aspect, f)]


def screen_space_ao(gbuffer, camera, radius, *, samples: int = 16, seed: int = 0, bias=None,
                    range_check: bool = True) -> np.ndarray:
    """SSAO of every pixel by the OpenCL kernel ``kernels/ssao.cl``.

    Parameters
    ----------
    gbuffer : dict
        :func:`pyshadow.render_gbuffer`'s dict (or a Frame): ``'depth'``
        (H, W), distance from the eye along each pixel's ray, world units,
        inf for the background (finite distances within float32's normal
        range, 1.2e-38 .. 3.4e38); ``'normal'`` (H, W, 3) world normals of
        any length (normalised here).
    camera : pyshadow.Camera
        The camera the G-buffer was rendered with.
    radius : float
        Radius of the sample hemisphere, world units (> 0): the distance
        limit D of the AO it estimates.
    samples : int, optional
        Directions per pixel, 1 .. 4096.
    seed : int, optional
        Seed of the sample patterns (:class:`pyshadow.Sampling`).
    bias : float, optional
        Depth tolerance, world units (>= 0); default ``0.02 * radius``.
    range_check : bool, optional
        Count an occluder only when its view depth is within ``radius`` of
        the pixel's own (default); False counts every closer surface.

    Returns
    -------
    ndarray, shape (H, W), float32
        Unoccluded fraction of the samples (1 = open; 1 on the background).
    """
    rel, n, z, radius, sampling, bias, rng = _check(gbuffer, camera, radius, samples, seed, bias, range_check)
    H, W = camera.height, camera.width
    out = np.empty(H * W, np.float32)
    S = sampling.samples
    table = direction_table(S, sampling.strategy, sampling.patterns, sampling.seed)
    pidx = pattern_indices(np.arange(H * W), sampling.patterns, sampling.seed)
    import pyopencl as cl

    q = _cl.queue()
    buf = _cl.empty(4 * H * W)
    k = _cl.kernel("ssao.cl", "ssao", {"SAMPLES": S})
    k(q, (H * W,), None, _cl.to_device(rel), _cl.to_device(n), _cl.to_device(z), _cl.to_device(pidx, np.int32),
      _cl.to_device(table), *_camera_args(camera), np.int32(W), np.int32(H), np.float32(radius), bias, rng, buf)
    cl.enqueue_copy(q, out, buf)
    return out.reshape(H, W)


def screen_space_ao_reference(gbuffer, camera, radius, *, samples: int = 16, seed: int = 0, bias=None,
                              range_check: bool = True, return_margin: bool = False):
    """NumPy (float64) version of :func:`screen_space_ao` on the same float32 inputs and directions.

    Parameters
    ----------
    gbuffer, camera, radius, samples, seed, bias, range_check
        As in :func:`screen_space_ao`.
    return_margin : bool, optional
        Also return each pixel's margin: the smallest distance, over its
        samples, of a decided quantity from its decision boundary (the
        projected column and row from a pixel edge, in pixels; the depth
        tests, relative to the view depth). A pixel where the kernel's
        answer differs must have a sample within float32 rounding of one.

    Returns
    -------
    ao : ndarray, shape (H, W), float32
    margin : ndarray, shape (H, W), float64
        Only with ``return_margin=True`` (inf for the background).
    """
    rel, n, z, radius, sampling, bias, rng = _check(gbuffer, camera, radius, samples, seed, bias, range_check)
    if not isinstance(return_margin, (bool, np.bool_)):
        raise TypeError(f"return_margin must be a bool, got {return_margin!r}")
    H, W = camera.height, camera.width
    hit = np.flatnonzero(np.isfinite(z))
    ao = np.ones(H * W, np.float32)
    margin = np.full(H * W, np.inf)
    cam = np.asarray(_camera_args(camera), np.float64)
    R, sx, sy = cam[:9].reshape(3, 3), cam[9], cam[10]
    bias, rng = float(bias), float(rng)
    zf = z.astype(np.float64)
    step = max(1, (1 << 20) // sampling.samples)
    for s in range(0, len(hit), step):
        pix = hit[s:s + step]
        w = sample_directions(n[pix], sampling=sampling, indices=pix).astype(np.float64)
        q = rel[pix, None, :].astype(np.float64) + radius * w            # (P, S, 3)
        xc, yc, zc = (q @ R.T).transpose(2, 0, 1)
        front = zc > 0
        with np.errstate(divide="ignore", invalid="ignore"):
            col = (xc / zc * sx + 1.0) * 0.5 * W
            row = (1.0 - yc / zc * sy) * 0.5 * H
        inside = front & (col >= 0) & (col < W) & (row >= 0) & (row < H)
        j = np.clip(np.where(inside, col, 0).astype(np.int64), 0, W - 1)
        k = np.clip(np.where(inside, row, 0).astype(np.int64), 0, H - 1)
        zb = zf[k * W + j]
        zp = zf[pix][:, None]
        known = inside & np.isfinite(zb)
        occ = known & (zb < zc - bias) & (np.abs(zp - zb) <= rng)
        ao[pix] = np.float32(1.0) - occ.sum(axis=1).astype(np.float32) / np.float32(sampling.samples)
        if return_margin:
            scale = np.maximum(np.abs(zc), _TINY)            # only 0 floored: margins are scale-free
            with np.errstate(invalid="ignore"):
                m = np.minimum.reduce([
                    np.abs(col - np.round(col)), np.abs(row - np.round(row)),
                    np.where(known, np.abs(zb - (zc - bias)) / scale, np.inf),
                    np.where(known & np.isfinite(rng), np.abs(np.abs(zp - zb) - rng) / scale, np.inf),
                    np.abs(zc) / np.maximum(np.linalg.norm(q, axis=2), _TINY)])
            margin[pix] = np.nanmin(np.where(np.isnan(m), 0.0, m), axis=1)
    ao = ao.reshape(H, W)
    return (ao, margin.reshape(H, W)) if return_margin else ao

"""Display and storage of linear radiance: tone mapping to 8 bits, EXR or HDR output.

``tonemap`` maps linear radiance ``L`` (any unit) to 8-bit display values:

``curve="srgb"`` (default)
    ``v = OETF(clip(exposure * L, 0, 1))`` with the sRGB transfer function
    (IEC 61966-2-1, :func:`pyshadow.io.linear_to_srgb`): values above
    ``1 / exposure`` clip to white.
``curve="exponential"`` (thesis 001, eq. 4.9-4.10)
    ``v = (1 - exp(-exposure * L)) ** (1 / gamma)``: never clips; ``gamma``
    is the display gamma applied after it (default 2.2; 1 leaves
    ``1 - e^(-s L)`` as is).

Then ``round(255 v)`` (half up) as uint8. Negative radiance (none comes out
of :mod:`~pyshadow.lighting.shade`) maps to 0, NaN is an error.
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..io import linear_to_srgb, write_image
from ._checks import positive

__all__ = ["tonemap", "auto_exposure", "write_radiance", "CURVES", "EXPOSURE_TARGET", "EXPOSURE_PERCENTILE"]

#: Names accepted by ``tonemap(curve=)``.
CURVES = ("srgb", "exponential")
#: :func:`auto_exposure`: the display value (linear, before the curve) its luminance percentile maps to.
EXPOSURE_TARGET = 0.8
EXPOSURE_PERCENTILE = 99.0


def _radiance(radiance, name: str = "radiance", image: bool = True) -> np.ndarray:
    """``radiance`` as an array, shape (H, W, 3); with ``image=False`` any (..., 3) (per-vertex colours, (N, 3))."""
    want = "(H, W, 3)" if image else "(H, W, 3) or (N, 3)"
    try:
        a = np.asarray(radiance)
    except ValueError:                          # a ragged list
        raise ValueError(f"{name}: expected shape {want} (got a ragged sequence)") from None
    if (a.ndim != 3 if image else a.ndim < 2) or a.shape[-1] != 3 or min(a.shape[:-1]) < 1:
        raise ValueError(f"{name}: expected shape {want} (got shape {a.shape})")
    if not np.issubdtype(a.dtype, np.floating):
        raise TypeError(f"{name}: expected a float array (got dtype {a.dtype})")
    if np.isnan(a).any():
        raise ValueError(f"{name}: {int(np.isnan(a).any(axis=-1).sum())} pixel(s) hold NaN")
    return a


def auto_exposure(radiance, covered=None) -> float:
    """The exposure that maps the :data:`EXPOSURE_PERCENTILE` (99th) percentile of the pixels' Rec. 709
    luminance to :data:`EXPOSURE_TARGET` (0.8): about 1 % of them clip (highlights), whatever the radiance's
    unit (cd/m^2 for the built-in skies, where an exposure of 1 is white everywhere).

    Parameters
    ----------
    radiance : array_like, shape (H, W, 3) or (N, 3), float
        Linear RGB: an image, or per-vertex colours.
    covered : array_like of bool, shape (H, W) or (N,), optional
        The pixels to measure (``Frame.object_id != -1`` leaves out the background and keeps the ground plane);
        default every pixel whose luminance is finite.

    Returns
    -------
    float
        ``EXPOSURE_TARGET / percentile``; 1.0 where that percentile is 0 or not finite (a black image).

    Raises
    ------
    ValueError
        ``radiance`` not of shape (..., 3), or ``covered`` not of its shape less the last axis.
    TypeError
        ``covered`` not of dtype bool (ids such as ``Frame.object_id`` would index rows).
    """
    from .sky import LUMINANCE_WEIGHTS

    a = np.asarray(radiance, np.float64)
    if a.ndim < 2 or a.shape[-1] != 3:
        raise ValueError(f"radiance: expected shape (H, W, 3) or (N, 3) (got shape {a.shape})")
    keep = np.ones(a.shape[:-1], bool) if covered is None else np.asarray(covered)
    if keep.dtype != np.bool_:                  # (ints, e.g. Frame.object_id, would index rows)
        raise TypeError(f"covered: expected a bool mask such as Frame.object_id != -1 (got dtype {keep.dtype})")
    if keep.shape != a.shape[:-1]:
        raise ValueError(f"covered: expected shape {a.shape[:-1]} (got shape {keep.shape})")
    lum = a[keep] @ LUMINANCE_WEIGHTS
    if covered is None:
        lum = lum[np.isfinite(lum)]
    with np.errstate(invalid="ignore"):        # a percentile among +inf pixels (covered): inf - inf, NaN: 1.0
        p = float(np.percentile(lum, EXPOSURE_PERCENTILE)) if lum.size else 0.0
    return EXPOSURE_TARGET / p if p > 0 and np.isfinite(p) else 1.0


def tonemap(radiance, exposure: float | str = 1.0, curve: str = "srgb", *, gamma: float = 2.2) -> np.ndarray:
    """Linear radiance (H, W, 3) -> display values (H, W, 3) uint8 (module docstring).

    Parameters
    ----------
    radiance : ndarray, shape (H, W, 3) or (N, 3), float
        Linear RGB: an image (e.g. ``Frame.radiance``), or per-vertex colours (``shade`` of a mesh's vertices,
        for a pyvista ``rgb`` array of the same shape); +inf maps to white.
    exposure : float or "auto"
        Scale ``s > 0`` applied to the radiance first; "auto": :func:`auto_exposure` of the image (the
        built-in skies are in cd/m^2: at 1 they are white everywhere).
    curve : {"srgb", "exponential"}
    gamma : float
        Display gamma of the exponential curve (ignored by "srgb").
    """
    a = _radiance(radiance, image=False)
    if isinstance(exposure, str) and exposure != "auto" and exposure.strip().lower() == "auto":
        raise ValueError(f"exposure: expected a number > 0 or 'auto' (lower case, no spaces; got {exposure!r})")
    s = auto_exposure(a) if isinstance(exposure, str) and exposure == "auto" else positive(exposure, "exposure")
    if s == np.inf:                             # "auto" of a subnormal percentile: 0.8 / p overflows (NaN from 0 * inf);
        a = np.ldexp(a.astype(np.float64), 600)     # the exposure is scale-free: scale by 2^600 (exact) and ask again
        s = auto_exposure(a)
    if not isinstance(curve, str) or curve not in CURVES:     # (an array's `in` is no answer)
        raise ValueError(f"curve: expected one of {', '.join(CURVES)} (got {curve!r})")
    with np.errstate(over="ignore"):            # beyond float64: +inf, white as documented
        x = np.maximum(a.astype(np.float64) * s, 0.0)
    if curve == "srgb":
        v = linear_to_srgb(x)
    else:
        g = positive(gamma, "gamma")
        v = np.power(-np.expm1(-x), 1.0 / g)
    return np.floor(np.clip(v, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)


def write_radiance(path, radiance) -> None:
    """Write linear radiance (H, W, 3) atomically (:func:`pyshadow.io.write_image`): a float32 EXR or a
    Radiance HDR (RGBE).

    ``path`` must end in ``.exr`` or ``.hdr``; NaN or negative values are
    refused (radiance is finite or +inf, and >= 0). EXR keeps float32 (beyond
    its range: +inf); HDR keeps each value within 2^-8 (0.4 %) of its pixel's
    largest channel and cannot hold +inf or values from about 1.7e38 up
    (ValueError: write an EXR; see :mod:`pyshadow.io`).
    """
    p = Path(os.fspath(path))
    if p.suffix.lower() not in (".exr", ".hdr"):
        raise ValueError(f"path: radiance is written as EXR or Radiance HDR; {str(p)!r} ends in neither .exr "
                         "nor .hdr")
    a = _radiance(radiance)
    if (a < 0).any():
        raise ValueError(f"radiance: {int((a < 0).any(axis=2).sum())} pixel(s) are negative")
    write_image(p, a)                           # EXR float32: beyond its range -> +inf, as documented

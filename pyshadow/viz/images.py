"""2-D arrays as flat image panels, colour bars and bent-normal colours.

An image panel shows an ``(H, W)`` scalar or ``(H, W, 3)`` RGB array in a
subplot seen straight on, one unit cell per pixel, row 0 at the top
(``origin='upper'``, camera images) or at the bottom (``origin='lower'``,
depth maps and CSM texel grids; see :mod:`pyshadow.viz`). A colour bar fills
a strip subplot and describes every panel or mesh drawn with the same colour
map and range.
"""
from __future__ import annotations

import numpy as np

from ..io import encode_8bit
from .plotter import TEXT_COLOR, _pv, _viewport_pixels, add_title

__all__ = [
    "image_panel",
    "colour_bar",
    "bent_normal_rgb",
]


def _check_clim(clim, who: str, log: bool = False) -> tuple[float, float]:
    """``clim`` as two floats ``lo < hi``, finite with a finite span (``lo > 0`` for a log scale).

    VTK replaces a reversed range by another one (with an error on the
    console only), and a range wider than float64 maps every value to one end.
    """
    try:
        lo, hi = (float(v) for v in np.asarray(clim, dtype=np.float64).reshape(-1))
    except (TypeError, ValueError):
        raise ValueError(f"{who}: clim must be two numbers (low, high), got {clim!r}") from None
    if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi and np.isfinite(hi - lo)):
        raise ValueError(f"{who}: clim must be finite with low < high (and a span within float64), "
                         f"got {clim!r}")
    if log and not lo > 0:
        raise ValueError(f"{who}: clim of a log scale must be positive, got {clim!r}")
    return lo, hi


def image_panel(plotter, image, *, title: str | None = None, cmap: str = "gray", clim=None,
                mask=None, origin: str = "upper", log_scale: bool = False, name: str = "values",
                title_fit: str | None = None):
    """Show a 2-D array as an image in the active subplot, seen straight on.

    Parameters
    ----------
    plotter : pyvista.Plotter
    image : array_like, shape (H, W) numeric, or (H, W, 3) RGB
        Scalar images are colour-mapped (the map's colours are display
        values: ``'gray'`` draws 0.5 as 128). RGB images are shown as
        colours, in the colour space of :func:`pyshadow.write_image`'s
        PNG: ``uint8`` as is (sRGB-encoded, as :func:`pyshadow.lighting.tonemap`
        gives), floats (or bools) as *linear* values in [0, 1], clipped,
        sRGB-encoded and rounded to 0..255 (the bytes a PNG of the same
        array holds: linear 0.5 draws 188). Other integer RGB types raise
        TypeError (their range is not known).
    title : str, optional
        Text along the top edge of the subplot.
    title_fit : str, optional
        Size the title's font for this text (see :func:`add_title`).
    cmap : str, optional
        Colour map of a scalar image.
    clim : (float, float), optional
        Colour range, finite with low < high; default the finite minimum
        and maximum (positive ones with ``log_scale``), or for an image of
        one value a range with that value in its middle (a factor 2 either
        side with ``log_scale``).
    mask : array_like of bool, shape (H, W), optional
        Pixels to leave out (they show the background). Non-finite pixels
        (in any channel of an RGB image) are always left out, and so are
        pixels <= 0 with ``log_scale``.
    origin : {'upper', 'lower'}
        Where row 0 is drawn: at the top (camera images) or at the bottom
        (depth maps, CSM texel grids).
    log_scale : bool, optional
        Logarithmic colour mapping (positive values).
    name : str, optional
        Name of the cell array holding the pixel values.

    Returns
    -------
    pyvista.Actor or None
        ``None`` when every pixel is masked.

    Raises
    ------
    ValueError
        Wrong shape, unknown ``origin``, a mask of another shape, a bad
        ``clim`` (reversed, equal, non-finite; not positive with
        ``log_scale``).
    TypeError
        A complex or non-numeric image, an integer RGB image not ``uint8``.

    Notes
    -----
    Pixel ``(r, c)`` is the unit cell ``[c, c+1] x [y, y+1]`` of a
    ``pv.ImageData`` in the plane z = 0 (``y = H-1-r`` for ``origin='upper'``,
    ``y = r`` for ``'lower'``), drawn without lighting so colours are exact.
    The camera is parallel, looks down -z and fits the whole ``W x H``
    rectangle (masked pixels included) with room for the title.
    """
    pv = _pv()
    img = np.asarray(image)
    rgb = img.ndim == 3 and img.shape[2] == 3
    if not (img.ndim == 2 or rgb):
        raise ValueError(f"image_panel: image must have shape (H, W) or (H, W, 3), got {img.shape}")
    if origin not in ("upper", "lower"):
        raise ValueError(f"image_panel: origin must be 'upper' or 'lower', got {origin!r}")
    H, W = img.shape[:2]
    if H == 0 or W == 0:
        raise ValueError(f"image_panel: empty image of shape {img.shape}")
    keep = np.ones((H, W), bool)
    if mask is not None:
        m = np.asarray(mask, dtype=bool)
        if m.shape != (H, W):
            raise ValueError(f"image_panel: mask must have shape {(H, W)}, got {m.shape}")
        keep &= ~m
    if img.dtype.kind == "c":
        raise TypeError(f"image_panel: image must be real, got {img.dtype}")
    if img.dtype.kind not in "biuf":     # strings ('0.5' was read as a number in an RGB image), dates, objects
        raise TypeError(f"image_panel: image must be numeric, got {img.dtype}")
    if rgb:
        if img.dtype.kind in "iu" and img.dtype != np.uint8:
            raise TypeError(f"image_panel: an RGB image must be uint8 (0..255) or float (0..1), "
                            f"got {img.dtype}")
        if img.dtype != np.uint8:
            img = np.asarray(img, np.float64)
            keep &= np.isfinite(img).all(axis=2)
            img = encode_8bit(np.nan_to_num(img))      # linear, as write_image reads floats: its PNG's bytes
    else:
        img = np.asarray(img, dtype=np.float64)
        keep &= np.isfinite(img)
        if log_scale:                    # no place on a log scale (they would set the range)
            keep &= img > 0
        if clim is not None:
            clim = _check_clim(clim, "image_panel", log=log_scale)
    if origin == "upper":
        img, keep = img[::-1], keep[::-1]
    grid = pv.ImageData(dimensions=(W + 1, H + 1, 1))
    # a copy: with origin='lower' the grid kept the caller's array (editing it later changed the panel)
    grid.cell_data[name] = np.array(img.reshape(H * W, 3) if rgb else img.reshape(-1))
    actor = None
    if keep.any():
        shown = grid if keep.all() else grid.extract_cells(np.flatnonzero(keep.reshape(-1)))
        if rgb:
            actor = plotter.add_mesh(shown, scalars=name, rgb=True, lighting=False,
                                     show_scalar_bar=False)
        else:
            vals = img[keep]
            if clim is None:
                lo, hi = float(vals.min()), float(vals.max())
                if not np.isfinite(hi - lo):
                    raise ValueError(f"image_panel: the image's values span [{lo:g}, {hi:g}], "
                                     "beyond float64; pass clim or rescale the image")
                if hi == lo:             # one value: the middle of the colour map, not its lowest colour
                    d = 0.5 * max(1.0, abs(lo))
                    clim = (lo / 2.0, lo * 2.0) if log_scale else (lo - d, lo + d)
                    if not (np.isfinite(clim).all() and clim[0] < lo < clim[1] and (clim[0] > 0 or not log_scale)):
                        raise ValueError(f"image_panel: every pixel is {lo:g}, too near float64's limits "
                                         "to centre a colour range on; pass clim")
                else:
                    clim = (lo, hi)
            actor = plotter.add_mesh(shown, scalars=name, cmap=cmap, clim=clim, lighting=False,
                                     log_scale=log_scale, show_scalar_bar=False)
    # straight-on parallel camera that fits the whole image below a title strip
    w, h = _viewport_pixels(plotter)
    aspect = w / h
    title_frac = 0.14 if title else 0.04
    half_h = max(0.5 * H, 0.5 * W / aspect) / (1.0 - title_frac)
    cx, cy = 0.5 * W, 0.5 * H + half_h * (title_frac - 0.02)
    dist = 2.0 * max(H, W)
    plotter.camera_position = [(cx, cy, dist), (cx, cy, 0.0), (0.0, 1.0, 0.0)]
    plotter.camera.parallel_projection = True
    plotter.camera.parallel_scale = half_h
    plotter.renderer.ResetCameraClippingRange()
    if title:
        add_title(plotter, title, fit=title_fit)
    return actor


def _label_format(lo: float, hi: float, n_labels: int) -> str:
    """``'%.2f'`` where it prints each of ``n_labels`` evenly spaced labels on ``[lo, hi]`` within 2 % of
    the step between them, else the shortest ``'%.{k}g'`` that does (``'%.2f'`` wrote 0.00 for every
    label of a range (0, 0.004))."""
    if n_labels < 2:
        return "%.2f"
    values = np.linspace(lo, hi, int(n_labels))
    tol = 0.02 * (hi - lo) / (int(n_labels) - 1)
    for fmt in ["%.2f"] + [f"%.{k}g" for k in range(3, 18)]:
        if max(abs(float(fmt % v) - v) for v in values) <= tol:
            return fmt
    return "%.17g"


def colour_bar(plotter, title: str, *, cmap: str = "gray", clim=(0.0, 1.0), n_labels: int = 5,
               fmt: str | None = None):
    """A horizontal colour bar filling the active subplot (a strip under panels).

    Meshes and images drawn with the same ``cmap`` and ``clim`` share it.

    Parameters
    ----------
    plotter : pyvista.Plotter
    title : str
        Written under the bar, with the labels.
    cmap : str, optional
    clim : (float, float), optional
    n_labels : int, optional
    fmt : str, optional
        printf-style label format; default ``'%.2f'`` where that prints every
        label within 2 % of the step between labels, else the shortest
        ``'%.{k}g'`` that does (a range (0, 0.004) is labelled 0, 0.001, ...).

    Returns
    -------
    vtkScalarBarActor

    Raises
    ------
    ValueError
        ``clim`` reversed, equal or not finite.
    """
    clim = _check_clim(clim, "colour_bar")
    if fmt is None:
        fmt = _label_format(clim[0], clim[1], n_labels)
    w, h = _viewport_pixels(plotter)
    size = int(np.clip(round(min(h / 3.2, w / 30.0)), 6, 16))
    key, n = title, 1
    while key in plotter.scalar_bars:     # pyvista keeps one bar per title (a repeat returns None)
        n += 1
        key = f"{title} ({n})"
    bar = plotter.add_scalar_bar(title=key, cmap=cmap, clim=clim,
                                 n_labels=n_labels, fmt=fmt, vertical=False, position_x=0.1,
                                 position_y=0.04, width=0.8, height=0.92, color=TEXT_COLOR,
                                 title_font_size=size, label_font_size=size)
    bar.SetTitle(title)
    bar.SetTextPositionToPrecedeScalarBar()      # labels under the bar, the title above it
    return bar


def bent_normal_rgb(bent, mask=None):
    """Bent normals as colours: ``(b + 1) / 2`` per channel.

    Parameters
    ----------
    bent : array_like, shape (H, W, 3)
        Unit vectors (world x, y, z -> red, green, blue). Pixels with a
        non-finite component become black (0).
    mask : array_like of bool, shape (H, W), optional
        Pixels without a surface; they become black (0).

    Returns
    -------
    ndarray, shape (H, W, 3), uint8

    Raises
    ------
    ValueError
        ``bent`` not (H, W, 3), or ``mask`` not (H, W).
    """
    b = np.asarray(bent, dtype=np.float64)
    if b.ndim != 3 or b.shape[2] != 3:
        raise ValueError(f"bent_normal_rgb: bent must have shape (H, W, 3), got {b.shape}")
    off = ~np.isfinite(b).all(axis=2)
    if mask is not None:
        m = np.asarray(mask, dtype=bool)
        if m.shape != b.shape[:2]:
            raise ValueError(f"bent_normal_rgb: mask must have shape {b.shape[:2]}, got {m.shape}")
        off |= m
    rgb = np.round(np.clip((np.nan_to_num(b) + 1.0) * 0.5, 0.0, 1.0) * 255.0).astype(np.uint8)
    rgb[off] = 0
    return rgb

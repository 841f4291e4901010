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

from .plotter import TEXT_COLOR, _pv, _viewport_pixels, add_title

__all__ = [
    "image_panel",
    "colour_bar",
    "bent_normal_rgb",
]


def image_panel(plotter, image, *, title: str | None = None, cmap: str = "gray", clim=None,
                mask=None, origin: str = "upper", log_scale: bool = False, name: str = "values",
                title_fit: str | None = None):
    """Show a 2-D array as an image in the active subplot, seen straight on.

    Parameters
    ----------
    plotter : pyvista.Plotter
    image : array_like, shape (H, W) numeric, or (H, W, 3) RGB
        Scalar images are colour-mapped; RGB images are shown as colours:
        ``uint8`` as is, floats in [0, 1] scaled to 0..255 (clipped).
    title : str, optional
        Text along the top edge of the subplot.
    title_fit : str, optional
        Size the title's font for this text (see :func:`add_title`).
    cmap : str, optional
        Colour map of a scalar image.
    clim : (float, float), optional
        Colour range; default the finite minimum and maximum.
    mask : array_like of bool, shape (H, W), optional
        Pixels to leave out (they show the background). Non-finite pixels
        of a scalar image are always left out.
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
        Wrong shape, unknown ``origin``, a mask of another shape.

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
    if rgb:
        if img.dtype != np.uint8:
            img = np.round(np.clip(np.asarray(img, np.float64), 0.0, 1.0) * 255.0).astype(np.uint8)
    else:
        if not (np.issubdtype(img.dtype, np.number) or img.dtype == bool):
            raise ValueError(f"image_panel: image must be numeric, got {img.dtype}")
        img = np.asarray(img, dtype=np.float64)
        keep &= np.isfinite(img)
    if origin == "upper":
        img, keep = img[::-1], keep[::-1]
    grid = pv.ImageData(dimensions=(W + 1, H + 1, 1))
    grid.cell_data[name] = img.reshape(H * W, 3) if rgb else img.reshape(-1)
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
                clim = (lo, hi if hi > lo else lo + 1.0)
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


def colour_bar(plotter, title: str, *, cmap: str = "gray", clim=(0.0, 1.0), n_labels: int = 5,
               fmt: str = "%.2f"):
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
        printf-style label format.

    Returns
    -------
    vtkScalarBarActor
    """
    w, h = _viewport_pixels(plotter)
    size = int(np.clip(round(min(h / 3.2, w / 30.0)), 6, 16))
    bar = plotter.add_scalar_bar(title=title, cmap=cmap, clim=tuple(float(v) for v in clim),
                                 n_labels=n_labels, fmt=fmt, vertical=False, position_x=0.1,
                                 position_y=0.04, width=0.8, height=0.92, color=TEXT_COLOR,
                                 title_font_size=size, label_font_size=size)
    bar.SetTextPositionToPrecedeScalarBar()      # labels under the bar, the title above it
    return bar


def bent_normal_rgb(bent, mask=None):
    """Bent normals as colours: ``(b + 1) / 2`` per channel.

    Parameters
    ----------
    bent : array_like, shape (H, W, 3)
        Unit vectors (world x, y, z -> red, green, blue).
    mask : array_like of bool, shape (H, W), optional
        Pixels without a surface; they become black (0).

    Returns
    -------
    ndarray, shape (H, W, 3), uint8
    """
    b = np.asarray(bent, dtype=np.float64)
    if b.ndim != 3 or b.shape[2] != 3:
        raise ValueError(f"bent_normal_rgb: bent must have shape (H, W, 3), got {b.shape}")
    rgb = np.round(np.clip((b + 1.0) * 0.5, 0.0, 1.0) * 255.0).astype(np.uint8)
    if mask is not None:
        rgb[np.asarray(mask, dtype=bool)] = 0
    return rgb

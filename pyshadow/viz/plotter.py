"""Plotters for :mod:`pyshadow.viz`: off-screen setup, windows, screenshots, titles.

Every other module of the package draws into a ``pv.Plotter`` made by
:func:`make_plotter` and finishes with :func:`finish` (a PNG or a window).
Sizes are in screen pixels of the render window; a subplot's share of the
window is its VTK viewport. pyvista is imported inside the functions
(:func:`_pv`), so importing this module needs neither pyvista nor a display.
The choice of the off-screen render window is described in the
"Off-screen rendering" section of :mod:`pyshadow.viz`.
"""
from __future__ import annotations

import argparse
import ctypes.util
import os
import sys

import numpy as np

__all__ = [
    "BACKGROUND",
    "TEXT_COLOR",
    "configure_offscreen",
    "make_plotter",
    "finish",
    "save_screenshot",
    "font_size",
    "add_title",
    "update_title",
]

BACKGROUND = "#c9d3df"     # light blue-grey: differs from AO black (0) and white (1)
TEXT_COLOR = "black"


def _pv():
    """Import pyvista, with an error that says what is missing."""
    try:
        import pyvista as pv
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise ImportError(
            "pyshadow.viz needs pyvista (pip install pyvista); the rest of pyshadow works without it"
        ) from exc
    return pv


def _has_display() -> bool:
    if sys.platform != "linux":
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


def configure_offscreen() -> str:
    """Choose VTK's off-screen render window for this machine.

    Call before the first render window is created (:func:`make_plotter`
    does it for ``off_screen=True``).

    Returns
    -------
    str
        The render window class VTK will use: the value of
        ``VTK_DEFAULT_OPENGL_WINDOW`` if it was already set, ``'default'``
        where a display exists (or not on Linux; VTK's own choice), else
        ``'vtkEGLRenderWindow'`` or ``'vtkOSOpenGLRenderWindow'`` (now set in
        ``os.environ``).

    Raises
    ------
    RuntimeError
        On Linux without a display, EGL or OSMesa; the message names the
        system packages that provide them.
    """
    key = "VTK_DEFAULT_OPENGL_WINDOW"
    if os.environ.get(key):
        return os.environ[key]
    if _has_display():
        return "default"
    if ctypes.util.find_library("EGL"):
        os.environ[key] = "vtkEGLRenderWindow"
    elif ctypes.util.find_library("OSMesa"):
        os.environ[key] = "vtkOSOpenGLRenderWindow"
    else:
        raise RuntimeError(
            "off-screen rendering needs EGL or OSMesa and this machine has neither "
            "(no display either). On Debian/Ubuntu install libegl1 libegl-mesa0 "
            "libgl1-mesa-dri (or libosmesa6), or run under xvfb-run"
        )
    return os.environ[key]


def make_plotter(shape=(1, 1), window_size=(1024, 768), *, off_screen: bool = False,
                 groups=None, row_weights=None, col_weights=None, background: str = BACKGROUND):
    """A ``pv.Plotter`` on screen or off screen, with pyshadow's background.

    Parameters
    ----------
    shape : tuple of int, optional
        Subplot grid ``(rows, columns)``.
    window_size : tuple of int, optional
        ``(width, height)`` in pixels, each 16 to :data:`MAX_WINDOW_SIDE`.
    off_screen : bool, optional
        Render without a window (for :func:`finish` with a screenshot);
        :func:`configure_offscreen` is called first. ``pyvista.OFF_SCREEN``
        (``PYVISTA_OFF_SCREEN=true``) set makes every plotter off screen.
    groups, row_weights, col_weights : optional
        Passed to ``pv.Plotter`` (merged subplots and relative sizes).
    background : str, optional
        Background colour of every subplot.

    Returns
    -------
    pyvista.Plotter

    Raises
    ------
    ValueError
        A window size that is not two integers in 16..:data:`MAX_WINDOW_SIDE`.
    RuntimeError
        An on-screen plotter on Linux without a display (the message says to
        pass ``--screenshot``, or ``off_screen=True``), or no off-screen
        backend (see :func:`configure_offscreen`).
    """
    try:
        size = np.asarray(window_size, np.float64).reshape(-1)
    except (TypeError, ValueError):                 # text, objects: the message below, not NumPy's
        size = np.zeros(0)
    if len(size) != 2 or not (size == np.round(size)).all() or min(size) < 16 or max(size) > MAX_WINDOW_SIDE:
        raise ValueError(f"window_size must be (width, height) with both in 16..{MAX_WINDOW_SIDE}, "
                         f"got {window_size!r}")
    pv = _pv()
    off_screen = bool(off_screen) or bool(getattr(pv, "OFF_SCREEN", False))   # pyvista's own switch
    if off_screen:
        configure_offscreen()
    elif not _has_display():
        raise RuntimeError("no display ($DISPLAY is unset): pass --screenshot out.png to render "
                           "off screen into a file (make_plotter(off_screen=True) in Python)")
    size = tuple(int(v) for v in size)
    kw = {}
    if groups is not None:
        kw["groups"] = groups
    if row_weights is not None:
        kw["row_weights"] = row_weights
    if col_weights is not None:
        kw["col_weights"] = col_weights
    plotter = pv.Plotter(shape=tuple(shape), window_size=list(size), off_screen=off_screen,
                         border=False, **kw)
    plotter.set_background(background, all_renderers=True)
    return plotter


def finish(plotter, screenshot=None, *, title: str = "pyshadow"):
    """Save ``plotter`` to a PNG and close it, or show it interactively.

    Parameters
    ----------
    plotter : pyvista.Plotter
    screenshot : str or os.PathLike, optional
        Output PNG path; its directory must exist. ``None``: open a window.
    title : str, optional
        Window title of the interactive window.

    Returns
    -------
    str or None
        The path written.
    """
    if screenshot is None:
        plotter.show(title=title)
        return None
    path = save_screenshot(plotter, screenshot)
    plotter.close()
    return path


#: Largest window side (pixels): VTK aborts the process ("stack smashing") on a
#: window of 400 x 99,999,999.
MAX_WINDOW_SIDE = 16384
#: Image files a screenshot may be written as (VTK's writers).
SCREENSHOT_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff")


def window_side(text: str) -> int:
    """argparse type of a ``--window`` side: an integer number of pixels, 16 to :data:`MAX_WINDOW_SIDE`."""
    try:
        v = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
    if not 16 <= v <= MAX_WINDOW_SIDE:
        raise argparse.ArgumentTypeError(f"a window side must be in 16..{MAX_WINDOW_SIDE} pixels, got {v}")
    return v


def screenshot_path(text: str) -> str:
    """argparse type of ``--screenshot``: an image file (:data:`SCREENSHOT_SUFFIXES`) in a folder
    that exists, checked when the command line is read, before any work."""
    if not text or os.path.isdir(text):
        raise argparse.ArgumentTypeError(f"expected a PNG file path, got {text!r}")
    if os.path.splitext(text)[1].lower() not in SCREENSHOT_SUFFIXES:
        raise argparse.ArgumentTypeError(f"expected a .png file (or {', '.join(SCREENSHOT_SUFFIXES[1:])}), "
                                         f"got {text!r}")
    folder = os.path.dirname(os.path.abspath(text))
    if not os.path.isdir(folder):
        raise argparse.ArgumentTypeError(f"folder {folder} does not exist")
    return text


def add_window_options(parser, window=(1024, 768)) -> None:
    """Add an example script's ``--window W H`` (default ``window``) and ``--screenshot PNG`` to ``parser``."""
    parser.add_argument("--window", type=window_side, nargs=2, default=tuple(window), metavar=("W", "H"))
    parser.add_argument("--screenshot", type=screenshot_path, metavar="PNG",
                        help="render off screen into this file")


def script_plotter(parser, args, shape=(1, 1), **kw):
    """:func:`make_plotter` for a script's ``args`` (:func:`add_window_options`): off screen with
    ``--screenshot``; no display (or no off-screen backend) is the parser's error (exit status 2), and
    so is ``pyvista.OFF_SCREEN`` without ``--screenshot`` (the window would show nothing)."""
    if args.screenshot is None and getattr(_pv(), "OFF_SCREEN", False):
        parser.error("pyvista renders off screen (PYVISTA_OFF_SCREEN / pyvista.OFF_SCREEN): pass "
                     "--screenshot out.png to render into a file")
    try:
        return make_plotter(shape, args.window, off_screen=args.screenshot is not None, **kw)
    except RuntimeError as exc:
        parser.error(str(exc))


def save_screenshot(plotter, path):
    """Render ``plotter`` now and write the image to the PNG ``path`` (atomically: a temporary file
    beside it, then a rename); the plotter stays open.

    pyvista's ``Plotter.screenshot`` renders only before the first image,
    so frames of an animation must come through here. The format follows the
    suffix in any case (``.PNG`` is a PNG); a path without one gets a PNG.

    Returns
    -------
    str
        The path written.
    """
    from .._files import atomic_path

    path = os.fspath(path)
    parent = os.path.dirname(os.path.abspath(path))
    if not os.path.isdir(parent):
        raise FileNotFoundError(f"screenshot directory does not exist: {parent}")
    suffix = os.path.splitext(path)[1].lower() or ".png"     # pyvista's writers know lower-case suffixes only
    plotter.render()
    with atomic_path(path) as tmp:          # a failed write leaves the earlier image, no partial file
        shot = tmp if tmp.suffix == suffix else tmp.with_name(tmp.name + suffix)
        try:
            plotter.screenshot(str(shot))
            if shot != tmp:
                os.replace(shot, tmp)
        finally:
            if shot != tmp and os.path.exists(shot):
                os.unlink(shot)
    return path


def _viewport_pixels(plotter) -> tuple[float, float]:
    x0, y0, x1, y1 = plotter.renderer.GetViewport()
    w, h = plotter.window_size
    return (x1 - x0) * w, (y1 - y0) * h


def font_size(plotter, text: str = "", scale: float = 1.0) -> int:
    """Font size for a title line in the active subplot.

    A 16th of the subplot's height (at most 22 pixels, at most a 20th of
    its width), smaller where ``text`` would not fit on one line, at least
    4. pyvista draws viewport text at twice this size in pixels.
    """
    w, h = _viewport_pixels(plotter)
    px = scale * min(h / 16.0, w / 20.0, 22.0)
    if text:
        px = min(px, 0.94 * w / (0.55 * len(text)))     # measured: about 0.5 em per character
    return int(max(4, np.floor(px / 2.0)))


def add_title(plotter, text: str, *, scale: float = 1.0, fit: str | None = None):
    """Write ``text`` centred along the top edge of the active subplot; returns the text actor.

    ``fit``: size the font for this (longer) text instead, so that titles of
    several panels come out the same size.
    """
    actor = plotter.add_text(text, position=(0.5, 0.985), viewport=True,
                             font_size=font_size(plotter, fit or text, scale), color=TEXT_COLOR)
    actor.prop.justification_horizontal = "center"
    actor.prop.justification_vertical = "top"
    return actor


def update_title(plotter, actor, text: str, *, scale: float = 1.0):
    """Change the text of a title from :func:`add_title`, resized to fit the active subplot."""
    actor.input = text
    actor.prop.font_size = 2 * font_size(plotter, text, scale)
    return actor

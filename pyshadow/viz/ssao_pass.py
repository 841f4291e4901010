"""pyvista's own screen-space AO render pass, read back as an AO image on a pyshadow camera.

What a pyvista user gets from ``Plotter.enable_ssao`` is a darkening of the
ambient term, not a number. To measure it beside pyshadow's methods the
scene is drawn twice off screen with the same camera, every surface white,
ambient 1 and no diffuse or specular light: once plain and once with VTK's
SSAO pass. Their ratio is the pass's AO, pixel by pixel (8-bit screenshots,
so steps of 1/255).

The pixel grid is that of :class:`pyshadow.Camera` (same eye, target, up,
vertical field of view and image size; row 0 at the top), so a pixel of the
result lies over the same surface point as pyshadow's G-buffer pixel,
except along silhouettes, where the two rasterisers may choose a different
surface for a pixel.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

__all__ = ["VTKSSAO", "vtk_ssao"]


@dataclass(frozen=True)
class VTKSSAO:
    """The AO image of VTK's SSAO pass (:func:`vtk_ssao`).

    Attributes
    ----------
    ao : ndarray, shape (H, W), float64
        Ratio of the render with the SSAO pass to the one without, in
        [0, 1] on surfaces (background pixels are meaningless).
    render_s : float
        Seconds of the render with the SSAO pass (window already set up).
    plain_render_s : float
        Seconds of the render without it, for the pass's own cost.
    """

    ao: np.ndarray
    render_s: float
    plain_render_s: float


def vtk_ssao(scene, camera, radius: float, *, kernel_size: int = 256, bias: float | None = None,
             blur: bool = False) -> VTKSSAO:
    """Render ``scene`` through pyvista's SSAO pass on ``camera`` and return its AO per pixel.

    Parameters
    ----------
    scene : pyshadow.Scene
        Drawn as :meth:`pyshadow.Scene.draw_items` gives it (every instance
        with a mesh, and the ground).
    camera : pyshadow.Camera
        Eye, target, up and ``fov_y`` (degrees) in world units; the image is
        ``camera.width`` x ``camera.height``.
    radius : float
        SSAO radius, world units (> 0): VTK's hemisphere radius, the
        distance limit of the estimate.
    kernel_size : int, optional
        Samples per pixel of the pass, 1 .. 1000 (VTK's largest).
    bias : float, optional
        VTK's depth bias, world units (>= 0, as :func:`pyshadow.screen_space_ao`'s); default
        ``0.02 * radius``.
    blur : bool, optional
        VTK's blur of the AO (off by default: the raw estimate).

    Returns
    -------
    VTKSSAO

    Raises
    ------
    ValueError
        A radius that is not finite and > 0, a kernel size < 1 or above VTK's
        largest (1000), a bias that is not finite and >= 0, a camera image
        narrower or lower than 16 pixels (VTK renders in a window of its size)
        or wider or higher than 16384.
    TypeError
        A kernel size that is not an integer, a radius or bias that is no
        real number (a bool, a string), ``blur`` not True or False, a
        ``scene`` that is no :class:`pyshadow.Scene` or a ``camera`` no
        :class:`pyshadow.Camera` (such as the ``(scene, camera)`` pair of
        :func:`pyshadow.data.default_scene`).
    """
    from .._validate import check_int, flag, real_scalar
    from ..camera import check_camera
    from ..visibility import _check_scene

    _check_scene(scene)         # (a (scene, camera) pair: "'tuple' object has no attribute 'draw_items'")
    check_camera(camera)        # (a string: "'str' object has no attribute 'width'")
    for x, name in ((radius, "radius"), (bias, "bias")):    # True was 1 world unit, "0.5" half a unit
        if not (real_scalar(x) or (name == "bias" and x is None)):
            raise TypeError(f"{name} must be a real number (world units), got {x!r}")
    radius = float(radius)
    if not (np.isfinite(radius) and radius > 0):
        raise ValueError(f"radius must be finite and > 0 (world units), got {radius}")
    kernel_size = check_int(kernel_size, "kernel_size", 1)
    bias = 0.02 * radius if bias is None else float(bias)
    if not (np.isfinite(bias) and bias >= 0):       # (a negative one darkened open ground: 0.94 -> 0.5 at -0.1)
        raise ValueError(f"bias must be finite and >= 0 (world units), got {bias}")
    blur = flag(blur, "blur")           # the string "no" blurred
    from .plotter import MAX_WINDOW_SIDE, _pv, make_plotter

    if not (16 <= camera.width <= MAX_WINDOW_SIDE and 16 <= camera.height <= MAX_WINDOW_SIDE):
        # (the error was make_plotter's, about a window_size the caller never gave)
        raise ValueError(f"camera must be 16..{MAX_WINDOW_SIDE} pixels wide and high for VTK's SSAO pass "
                         f"(it renders in a window of the camera's size), got {camera.width}x{camera.height}")

    pv = _pv()
    from vtkmodules.vtkRenderingOpenGL2 import vtkSSAOPass

    most = int(vtkSSAOPass().GetKernelSizeMaxValue())
    if kernel_size > most:      # VTK clamps it: 4096 asked rendered 1000 samples, the result labelled 4096
        raise ValueError(f"kernel_size must be at most {most} (VTK's SSAO pass takes no more samples), "
                         f"got {kernel_size}")
    items, _ = scene.draw_items()
    images, seconds = [], []
    for ssao_on in (False, True):
        pl = make_plotter(window_size=(camera.width, camera.height), off_screen=True)
        try:
            for mesh, T in items:
                m = pv.wrap(mesh.copy().apply_transform(T))
                pl.add_mesh(m, color="white", ambient=1.0, diffuse=0.0, specular=0.0, lighting=True)
            pl.camera.position, pl.camera.focal_point = tuple(camera.eye), tuple(camera.target)
            pl.camera.up, pl.camera.view_angle = tuple(camera.up), float(camera.fov_y)
            if ssao_on:
                pl.enable_ssao(radius=radius, bias=bias, kernel_size=kernel_size, blur=blur)
            pl.show(auto_close=False)            # window and pipeline set up, first render
            t0 = time.perf_counter()
            pl.render()
            seconds.append(time.perf_counter() - t0)
            images.append(pl.screenshot(return_img=True).astype(np.float64)[..., :3].mean(axis=2))
        finally:
            pl.close()
    ao = np.clip(images[1] / np.maximum(images[0], 1e-9), 0.0, 1.0)
    return VTKSSAO(ao, seconds[1], seconds[0])

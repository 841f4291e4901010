"""Environment maps: distant radiance on the sphere, as a lat-long image or a cube.

Layouts
-------
``"latlong"`` (equirectangular), shape (H, W, 3) with W = 2 H
    Row i covers polar angles theta in [pi i / H, pi (i + 1) / H] (row 0 at
    the zenith +y), column j covers azimuths phi in [2 pi j / W,
    2 pi (j + 1) / W), with ``d = (sin theta cos phi, cos theta,
    sin theta sin phi)``: column 0 starts at +x, a quarter of the way across
    is +z, half way -x, three quarters -z. Texel solid angle
    ``(cos theta_i - cos theta_{i+1}) 2 pi / W`` (exact).
``"cube"``, faces of shape (6, N, N, 3)
    Read from and written to a horizontal (4 N x 3 N) or vertical
    (3 N x 4 N) cross; face frames and the crosses are drawn in
    :mod:`pyshadow.lighting.cube`. Texel solid angles are exact.

Radiance is linear, per RGB channel, in whatever unit the file or array
holds (the sky models of :mod:`pyshadow.lighting.sky` give luminance-scaled
linear Rec. 709 RGB in cd/m^2); irradiance is that unit times sr (lux for
cd/m^2). Directions point *from* the scene *towards* the sky.
"""
from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

from .._validate import check_int
from . import cube
from ._checks import radiance_array, rgb_channels, unit_rows
from .sh import SH_COUNT, _irradiance, _sh_of_moments, latlong_basis_integrals

__all__ = ["EnvironmentMap", "LAYOUTS", "latlong_directions", "latlong_solid_angles"]

#: Layouts :class:`EnvironmentMap` accepts for an (H, W, 3) image.
LAYOUTS = ("auto", "latlong", "horizontal-cross", "vertical-cross")


def _grid(height, width) -> tuple:
    """(height, width) of a lat-long grid as ints >= 1 (TypeError / ValueError naming the argument)."""
    return check_int(height, "height", 1), check_int(width, "width", 1)


def latlong_directions(height: int, width: int) -> np.ndarray:
    """Unit direction of every lat-long texel centre.

    Parameters
    ----------
    height, width : int
        Rows and columns of the map, integers >= 1 (Python or NumPy ints,
        not bools); rows and columns as in the module docstring (any W, not
        only W = 2 H).

    Returns
    -------
    ndarray, shape (height, width, 3), float64
        Unit vectors, y up.

    Raises
    ------
    TypeError
        ``height`` or ``width`` is not an integer.
    ValueError
        ``height`` or ``width`` is below 1.
    """
    height, width = _grid(height, width)
    th = (np.arange(height) + 0.5) * (math.pi / height)
    ph = (np.arange(width) + 0.5) * (2.0 * math.pi / width)
    st = np.sin(th)[:, None]
    out = np.empty((height, width, 3))                  # filled in place: a stack copied 8 M texels once more
    np.multiply(st, np.cos(ph)[None, :], out=out[:, :, 0])
    out[:, :, 1] = np.cos(th)[:, None]
    np.multiply(st, np.sin(ph)[None, :], out=out[:, :, 2])
    return out


def latlong_solid_angles(height: int, width: int) -> np.ndarray:
    """Exact solid angle of every lat-long texel.

    Parameters
    ----------
    height, width : int
        Rows and columns of the map, integers >= 1 (as for
        :func:`latlong_directions`).

    Returns
    -------
    ndarray, shape (height, width), float64
        Solid angles in sr, ``(cos theta_i - cos theta_{i+1}) 2 pi / W``;
        they sum to 4 pi.

    Raises
    ------
    TypeError, ValueError
        As :func:`latlong_directions`.
    """
    height, width = _grid(height, width)
    u = np.cos(np.linspace(0.0, math.pi, height + 1))
    u[0], u[-1] = 1.0, -1.0
    return np.repeat(((u[:-1] - u[1:]) * (2.0 * math.pi / width))[:, None], width, axis=1)


def _guess_layout(h: int, w: int, name: str) -> str:
    if w == 2 * h:
        return "latlong"
    if 3 * w == 4 * h and h % 3 == 0:
        return "horizontal-cross"
    if 4 * w == 3 * h and w % 3 == 0:
        return "vertical-cross"
    raise ValueError(f"{name}: cannot tell the layout of a {w} x {h} (W x H) image: a lat-long map "
                     f"has W = 2 H, a horizontal cross W : H = 4 : 3, a vertical cross 3 : 4")


def _cross_mask(h: int, w: int, layout: str) -> np.ndarray:
    rows, cols = cube.CROSS_CELLS_SHAPE[layout]
    n = h // rows
    mask = np.zeros((h, w), bool)
    for i, j, _ in cube.CROSS_CELLS[layout].values():
        mask[i * n:(i + 1) * n, j * n:(j + 1) * n] = True
    return mask


class EnvironmentMap:
    """Distant radiance around the scene, as a lat-long map or a cube map.

    Parameters
    ----------
    radiance : array_like, shape (H, W, 3), or (6, N, N, 3) for cube faces
        Linear RGB radiance, finite, >= 0 and at most ``MAX_RADIANCE``
        (1.76e305, so that its integrals stay finite) (see the module docstring for
        units and the frame). Copied to float64.
    layout : {"auto", "latlong", "horizontal-cross", "vertical-cross"}
        How an (H, W, 3) image maps to directions. ``"auto"`` picks by the
        aspect ratio: W = 2 H lat-long, 4 : 3 horizontal cross, 3 : 4
        vertical cross. Ignored for (6, N, N, 3) faces.
    name : str
        What error messages call the input (a file name, an argument name).

    Attributes
    ----------
    layout : str
        ``"latlong"`` or ``"cube"``.
    radiance : ndarray, float64, read-only
        (H, W, 3) for lat-long, (6, N, N, 3) for a cube (faces +X, -X, +Y,
        -Y, +Z, -Z). Read-only, so that what was checked and derived from it
        (:class:`~pyshadow.lighting.Lighting`'s SH, the "sampled" sky's
        device copy) stays true: make a changed map with
        :meth:`with_radiance`.

    Raises
    ------
    ValueError
        Wrong shape or channel count, an aspect ratio that fits no layout,
        NaN, infinite or negative texels (the message names the first one).
    """

    def __init__(self, radiance, layout: str = "auto", *, name: str = "radiance"):
        if not isinstance(layout, str) or layout not in LAYOUTS:    # (an array's `in` is no answer)
            raise ValueError(f"layout: expected one of {', '.join(LAYOUTS)} (got {layout!r})")
        try:
            a = np.asarray(radiance)
        except ValueError:                          # a ragged list
            raise ValueError(f"{name}: expected an RGB image of shape (H, W, 3) (got a ragged sequence)") from None
        if a.ndim == 4:
            if a.shape[0] != 6 or a.shape[1] != a.shape[2] or a.shape[3] != 3 or a.shape[1] < 1:
                raise ValueError(f"{name}: cube faces must have shape (6, N, N, 3) (got shape {a.shape})")
            faces = np.empty(a.shape)                   # face by face: a texel's row and column are the face's
            for f, face in enumerate(cube.FACE_NAMES):
                faces[f] = radiance_array(a[f], f"{name}: face {f} ({face})")
            self._set("cube", faces)
            return
        if a.ndim != 3 or a.shape[-1] != 3:
            hint = "; a file is read by EnvironmentMap.from_file" if isinstance(radiance, (str, os.PathLike)) else ""
            raise ValueError(f"{name}: expected an RGB image of shape (H, W, 3) or cube faces "
                             f"(6, N, N, 3) (got shape {a.shape}){hint}")
        h, w = a.shape[:2]
        kind = _guess_layout(h, w, name) if layout == "auto" else layout
        if kind == "latlong":
            if w != 2 * h:
                raise ValueError(f"{name}: a lat-long map has W = 2 H (got W = {w}, H = {h})")
            self._set("latlong", radiance_array(a, name))
            return
        rows, cols = cube.CROSS_CELLS_SHAPE[kind]
        if h % rows or w % cols or h // rows != w // cols or h == 0:
            raise ValueError(f"{name}: a {kind} is {cols} N wide and {rows} N tall "
                             f"(got W = {w}, H = {h})")
        checked = radiance_array(a, name, mask=_cross_mask(h, w, kind))
        self._set("cube", cube.faces_from_cross(checked, kind))

    def _set(self, layout: str, radiance: np.ndarray) -> None:
        """Keep ``radiance`` (an array of our own, owning its data) read-only."""
        radiance.flags.writeable = False
        self.layout, self.radiance = layout, radiance

    def __setstate__(self, state) -> None:
        """A copy's (``copy.deepcopy``, unpickling) radiance is read-only too (it came back writeable)."""
        self.__dict__.update(state)
        r = self.radiance
        if r.flags.writeable or r.base is not None:     # (copy.copy shares the read-only array: kept)
            self._set(self.layout, np.array(r, dtype=np.float64))

    # -- construction -----------------------------------------------------------------------
    @classmethod
    def from_file(cls, path, layout: str = "auto") -> "EnvironmentMap":
        """Read an HDR image with OpenImageIO (EXR, Radiance HDR, float TIFF, ...).

        Parameters
        ----------
        path : str or os.PathLike
            The file; nothing is written anywhere.
        layout : str
            As for the constructor. RGBA files lose their alpha channel; one-
            or two-channel files, and files whose channels are not named
            R, G, B (and A), such as an EXR of Z, X, depth, are refused.

        Raises
        ------
        FileNotFoundError
            No file at ``path``.
        TypeError
            ``path`` is not a str or os.PathLike.
        ValueError
            OpenImageIO cannot read it, or its contents fail the constructor's
            checks (the message names the file).
        """
        from ..io import read_image
        if not isinstance(path, (str, os.PathLike)):
            raise TypeError(f"path: expected a str or os.PathLike file name (got {type(path).__name__})")
        p = Path(os.fspath(path))
        img = read_image(p)
        if img.ndim == 2 or img.shape[2] not in (3, 4):
            ch = 1 if img.ndim == 2 else img.shape[2]
            raise ValueError(f"{p}: an environment map needs RGB or RGBA channels (got {ch})")
        rgb_channels(p)                             # not Z, X, depth or Y, RY, BY read as R, G, B
        return cls(img[:, :, :3], layout, name=str(p))

    def with_radiance(self, radiance) -> "EnvironmentMap":
        """A map of the same layout with other radiance (same shape as :attr:`radiance`)."""
        r = np.asarray(radiance)
        if r.shape != self.radiance.shape:
            raise ValueError(f"radiance: expected shape {self.radiance.shape} (got {r.shape})")
        return EnvironmentMap(r, "latlong" if self.layout == "latlong" else "auto")

    # -- geometry ---------------------------------------------------------------------------
    @property
    def grid_shape(self) -> tuple:
        """Texel grid: (H, W) or (6, N, N)."""
        return self.radiance.shape[:-1]

    @property
    def pitch(self) -> float:
        """Largest angular size of a texel in rad: pi / H, or 2 atan(1 / N) for a cube."""
        if self.layout == "latlong":
            return math.pi / self.radiance.shape[0]
        return 2.0 * math.atan(1.0 / self.radiance.shape[1])

    def directions(self) -> np.ndarray:
        """Unit direction of every texel centre, shape ``grid_shape + (3,)``, float64."""
        if self.layout == "latlong":
            return latlong_directions(*self.grid_shape)
        return cube.face_directions(self.grid_shape[1])

    def solid_angles(self) -> np.ndarray:
        """Exact solid angle of every texel in sr, shape ``grid_shape``, float64."""
        if self.layout == "latlong":
            return latlong_solid_angles(*self.grid_shape)
        return cube.face_solid_angles(self.grid_shape[1])

    def texel_index(self, directions) -> np.ndarray:
        """Flat index (into ``grid_shape``) of the texel holding each unit direction.

        Parameters
        ----------
        directions : array_like, shape (M, 3), float
            Unit vectors, y up (length 1 +- 1e-6; the texel is that of the
            direction whatever its length, at the poles too).

        Returns
        -------
        index : ndarray, shape (M,), int64
        """
        d = unit_rows(directions, "directions")
        if self.layout == "latlong":
            h, w = self.grid_shape
            # atan2, not arccos(y): the angle at any length (arccos is 1.3e-3 rad off at the zenith at 1 - 9e-7)
            th = np.arctan2(np.hypot(d[:, 0], d[:, 2]), d[:, 1])
            ph = np.mod(np.arctan2(d[:, 2], d[:, 0]), 2.0 * math.pi)
            i = np.clip(np.floor(th * (h / math.pi)), 0, h - 1).astype(np.int64)
            j = np.floor(ph * (w / (2.0 * math.pi))).astype(np.int64) % w
            return i * w + j
        n = self.grid_shape[1]
        f, i, j = cube.cube_lookup(d, n)
        return (f * n + i) * n + j

    def lookup(self, directions) -> np.ndarray:
        """Radiance of the texel holding each unit direction (nearest texel), (M, 3) float64."""
        return self.radiance.reshape(-1, 3)[self.texel_index(directions)]

    # -- integrals --------------------------------------------------------------------------
    def sh(self, order: int = 3) -> np.ndarray:
        """Spherical-harmonic coefficients of the radiance.

        Each texel is taken as constant over its extent, and the basis is
        integrated exactly over it (closed form for lat-long, 4 x 4 Gauss
        points a texel for cube faces of N >= 8, at least 32 x 32 a face
        below: 1e-10 relative at N = 8, less elsewhere), so a constant map
        has no band 1 or 2 at all.

        Parameters
        ----------
        order : int
            Number of bands; only 3 (l = 0, 1, 2: 9 coefficients) exists.

        Returns
        -------
        L : ndarray, shape (9, 3), float64
            ``L[k, c] = integral L_c(d) Y_k(d) dOmega``, basis and index k as
            in :mod:`pyshadow.lighting.sh`.
        """
        if np.ndim(order) != 0 or order != 3:          # (an array's != is no answer)
            raise ValueError(f"order: only order 3 (9 coefficients) is implemented (got {order!r})")
        if self.layout == "latlong":
            h, w = self.grid_shape
            T, P = latlong_basis_integrals(h, w)
            # rows first, one matmul on the map in place (an einsum of all three copied the whole map)
            X = (T.T @ self.radiance.reshape(h, w * 3)).reshape(SH_COUNT, w, 3)
            return np.einsum("jk,kjc->kc", P, X)
        n = self.grid_shape[1]
        # Every Y_k is a polynomial of degree <= 2 of the direction, so its texel integrals follow from
        # the texels' moments of the direction (solid angle, d, d d^T): the same on all six faces in face
        # coordinates, so the quadrature runs once for all faces and basis functions (a 4 x 3 cross of
        # 512^2 faces: 3.9-9.6 -> 0.2-0.3 s). 4 x 4 points a texel are 5e-3 off on 1 x 1 faces: at least
        # 32 points a face side.
        W = np.zeros((13, 18))                          # (moment, face x channel), moments in face coordinates
        for rows, M in cube.texel_moments(n, 4 if n >= 8 else -(-32 // n)):
            W += M.reshape(-1, 13).T @ self.radiance[:, rows].transpose(1, 2, 0, 3).reshape(-1, 18)
        W = W.reshape(13, 6, 3)
        F = cube.FACE_FRAMES                            # rows c, r, dn: world d = F^T (face coordinates)
        w0 = W[0].sum(axis=0)
        w1 = np.einsum("fai,afc->ic", F, W[1:4])
        w2 = np.einsum("fai,fbj,abfc->ijc", F, F, W[4:].reshape(3, 3, 6, 3))
        return _sh_of_moments(w0, w1, w2)

    def irradiance(self, normals) -> np.ndarray:
        """Irradiance at unit normals from the 9-coefficient SH (Ramamoorthi-Hanrahan).

        Parameters
        ----------
        normals : array_like, shape (N, 3) or (3,), float
            Unit normals, y up (length 1 +- 1e-6).

        Returns
        -------
        E : ndarray, shape (N, 3), float64
            Irradiance in radiance units times sr; see
            :func:`pyshadow.lighting.sh.irradiance_sh`.
        """
        return _irradiance(self.sh(), unit_rows(normals, "normals"))

    def integral(self) -> np.ndarray:
        """``sum_i L_i Omega_i`` per channel: the radiance integrated over the sphere, (3,)."""
        return self.radiance.reshape(-1, 3).T @ self.solid_angles().reshape(-1)

    def to_image(self, layout: str | None = None) -> np.ndarray:
        """The map as an (H, W, 3) float64 image: lat-long as is, a cube as a cross.

        ``layout`` is ``"horizontal-cross"`` (default for cubes: None) or
        ``"vertical-cross"``; unused cells are 0. Any other value, ``""``
        included, raises ValueError.
        """
        if self.layout == "latlong":
            if layout is not None and (not isinstance(layout, str) or layout != "latlong"):
                raise ValueError(f"layout: a lat-long map is written as 'latlong' (got {layout!r})")
            return self.radiance.copy()
        layout = "horizontal-cross" if layout is None else layout
        if not isinstance(layout, str) or layout not in tuple(cube.CROSS_CELLS):
            raise ValueError(f"layout: a cube is written as 'horizontal-cross' or 'vertical-cross' "
                             f"(got {layout!r})")
        return cube.cross_from_faces(self.radiance, layout)

    def __repr__(self) -> str:
        return f"EnvironmentMap(layout={self.layout!r}, grid_shape={self.grid_shape})"

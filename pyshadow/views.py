"""View sets: the directions of the orthographic depth maps and their order.

A view set discretises the sphere of light directions around an object
(thesis 000, section 5.2.1). Map ``k`` looks along ``-d_k`` at the object's
unit bounding sphere from the point ``d_k``; its camera basis is the rows
``(u_k, v_k, d_k)`` of ``bases[k]``: orthonormal and right-handed
(``u_k x v_k = d_k``). The order of the maps is the compression order of a
Coherent Shadow Map, so consecutive maps must see the object from nearby
directions with nearby bases.

Layouts
-------
``zigzag``
    The thesis grid (Listing 5.1): ``theta`` rows with
    ``theta_i = (i + row_offset)*pi/theta``, ``phi`` columns with
    ``phi_j = j*2*pi/phi``; even rows run up in phi, odd rows back down.
    The thesis's ``row_offset = 0`` puts row 0 *on* the north pole and no
    row on the south pole, which then lies a whole row step from its
    nearest maps, twice the half step of any other direction. The default
    ``row_offset = 0.5`` centres the rows in their bands: both poles lie
    half a step from a row, and no row is a pole's ``phi`` copies of one
    direction.
``hilbert``
    An equal-area octahedral map of the sphere onto a ``2^k x 2^k`` grid
    (Clarberg 2008), cells visited along one Hilbert curve (as in Ritschel
    et al. 2007); or one square per hemisphere, joined across the equator
    (``hemispheres=True``, ``D = 2 * 4^k``).

Bases (both layouts) are parallel-transported along the order: each basis is
its predecessor rotated by the smallest rotation taking ``d_{k-1}`` to
``d_k``, starting from the thesis's up-vector basis (eq. 5.4) at the first
map, written in the grid angles (``u = (sin phi, 0, -cos phi)``) so that it
is defined on a zigzag grid's pole row (``row_offset = 0``), where
``(0, 1, 0) x d`` vanishes. Consecutive bases then differ exactly as much as
their directions, no pole is special, and the maps of a pole row (one
direction) are identical.
Compared with the up-vector basis at every map, whose image turns by
``dphi * cos(theta)`` between neighbours along a row, this cuts the number
of segments of a CSM (measured in benchmarks/README.md, the compression
table).
"""
from __future__ import annotations

import numpy as np

from ._validate import check_int, check_rows
from . import _views_checks
from ._views_checks import _check_frames, _check_layout, _layout_args, _unit_rows, real_array, scaled_vectors

#: the row offsets of a zigzag grid (ViewSet.zigzag): 0.5 centred rows, 0 the thesis's grid
ZIGZAG_ROW_OFFSETS = (0.5, 0.0)

#: radians added to the angles of :meth:`ViewSet.filter_window` before they are
#: inverted (a direction on a map's own axis takes nearly all the weight)
FILTER_ANGLE_EPS = 1e-4

#: most maps of a ViewSet.zigzag (theta * phi): the largest ViewSet.hilbert set's (level 10, hemispheres)
MAX_MAPS = 2 * 4**10
#: the largest theta or phi of ViewSet.zigzag (as a CSM file's header allows)
MAX_GRID = 1 << 16
#: how far a given ViewSet's directions may be from unit length, and its bases from orthonormal and from
#: ending with d_k (1e-6; _views_checks says why); the layouts a ViewSet may name
BASIS_TOL, LAYOUTS = _views_checks.BASIS_TOL, _views_checks.LAYOUTS

__all__ = ["ViewSet", "polar_direction", "octahedral_decode", "octahedral_encode", "hilbert_d2xy"]


def polar_direction(theta, phi) -> np.ndarray:
    """Unit direction of polar angles, thesis eq. 5.1 (y up).

    ``d(theta, phi) = (sin theta cos phi, cos theta, sin theta sin phi)``; finite real angles (ValueError,
    TypeError otherwise), of shapes that broadcast.
    """
    theta = real_array(theta, "polar_direction: theta")
    phi = real_array(phi, "polar_direction: phi")
    st = np.sin(theta)
    return np.stack([st * np.cos(phi), np.cos(theta), st * np.sin(phi)], axis=-1)


# ---------------------------------------------------------------------------
# equal-area octahedral map (y is the octahedron's polar axis)
# ---------------------------------------------------------------------------
def octahedral_decode(uv) -> np.ndarray:
    """Square ``[-1, 1]^2`` to unit directions, equal-area octahedral map.

    Parameters
    ----------
    uv : array_like, shape (..., 2)
        The centre ``(0, 0)`` maps to the north pole ``(0, 1, 0)``, the
        diamond ``|u| + |v| = 1`` to the equator, the four corners to the
        south pole; ``u`` signs x, ``v`` signs z.

    Returns
    -------
    ndarray, shape (..., 3), float64

    Raises
    ------
    TypeError, ValueError
        Not real numbers; another shape, or points outside the square (or not finite).
    """
    uv = real_array(uv, "octahedral_decode: uv", 2)
    if not (np.abs(uv) <= 1.0).all():
        raise ValueError("octahedral_decode: uv must lie in the square [-1, 1]^2 (the map's domain)")
    u, v = uv[..., 0], uv[..., 1]
    a, b = np.abs(u), np.abs(v)
    sd = 1.0 - (a + b)
    r = 1.0 - np.abs(sd)
    with np.errstate(invalid="ignore", divide="ignore"):
        phi = np.where(r > 0, (np.pi / 4) * ((b - a) / r + 1.0), 0.0)
    y = np.sign(sd) * (1.0 - r * r)
    y = np.where(sd == 0, 0.0, y)
    s = r * np.sqrt(np.maximum(2.0 - r * r, 0.0))
    x = np.where(u < 0, -1.0, 1.0) * s * np.cos(phi)
    z = np.where(v < 0, -1.0, 1.0) * s * np.sin(phi)
    out = np.stack([x, y, z], axis=-1)
    return out / np.linalg.norm(out, axis=-1, keepdims=True)


def octahedral_encode(dirs) -> np.ndarray:
    """Directions (..., 3) to the square ``[-1, 1]^2``; inverse of :func:`octahedral_decode`.

    Normalised here, whatever their length (finite, non-zero, real: ValueError, TypeError otherwise)."""
    d = real_array(dirs, "octahedral_encode: dirs", 3)
    return _encode_unit(scaled_vectors(d, "octahedral_encode: dirs"))


def _encode_unit(d: np.ndarray) -> np.ndarray:
    """:func:`octahedral_encode` of finite float64 directions of a normal length (the lookups' own)."""
    d = d / np.linalg.norm(d, axis=-1, keepdims=True)
    x, y, z = d[..., 0], d[..., 1], d[..., 2]
    ay = np.abs(y)
    # 1 - |y| without cancellation near the poles
    r = np.sqrt((x * x + z * z) / (1.0 + ay))
    phi = np.arctan2(np.abs(z), np.abs(x))
    t = phi * (4.0 / np.pi) - 1.0
    upper = y >= 0
    a = np.where(upper, r * (1.0 - t) * 0.5, (2.0 - r - r * t) * 0.5)
    b = np.where(upper, r * (1.0 + t) * 0.5, (2.0 - r + r * t) * 0.5)
    u = np.where(x < 0, -a, a)
    v = np.where(z < 0, -b, b)
    return np.stack([u, v], axis=-1)


# ---------------------------------------------------------------------------
# Hilbert curve on a 2^k x 2^k grid
# ---------------------------------------------------------------------------
def hilbert_d2xy(level: int, d) -> tuple[np.ndarray, np.ndarray]:
    """Cell ``(x, y)`` of position ``d`` along the Hilbert curve of order ``level``.

    Vectorised over ``d``; consecutive ``d`` give edge-adjacent cells. ``level`` an int in 0 .. 31,
    ``d`` integers in ``0 .. 4**level - 1`` (TypeError, ValueError otherwise).
    """
    level = check_int(level, "hilbert_d2xy: level", 0, 31)
    a = np.asarray(d)
    if a.dtype.kind not in "iu" and a.size:
        raise TypeError(f"hilbert_d2xy: d must hold integers, got dtype {a.dtype}")
    d = a.astype(np.int64)
    if a.size and not ((a >= 0).all() and (a < 4**level).all()):
        raise ValueError(f"hilbert_d2xy: d must lie in 0..{4**level - 1} (the curve's cells), got values "
                         f"{int(a.min())}..{int(a.max())}")
    x = np.zeros_like(d)
    y = np.zeros_like(d)
    t = d.copy()
    s = 1
    n = 1 << level
    while s < n:
        rx = (t // 2) & 1
        ry = (t ^ rx) & 1
        # rotate the sub-square
        flip = ry == 0
        swap_x = np.where(flip & (rx == 1), s - 1 - x, x)
        swap_y = np.where(flip & (rx == 1), s - 1 - y, y)
        x, y = np.where(flip, swap_y, swap_x), np.where(flip, swap_x, swap_y)
        x = x + s * rx
        y = y + s * ry
        t //= 4
        s *= 2
    return x, y


def _transport_bases(dirs: np.ndarray, u0: np.ndarray) -> np.ndarray:
    """Bases along a path of directions by parallel transport from ``u0``.

    Step ``k`` rotates ``u`` by the smallest rotation taking ``d_{k-1}`` to
    ``d_k`` (Rodrigues; the identity where the two coincide). The rotations
    are composed by a parallel prefix product (``log2 D`` batched 3x3
    products instead of a Python loop over the maps); each ``u_k`` is then
    made exactly perpendicular to ``d_k`` and normalised.
    """
    dirs = np.asarray(dirs, dtype=np.float64)
    n = len(dirs)
    u = u0 - np.dot(u0, dirs[0]) * dirs[0]
    u = u / np.linalg.norm(u)
    # steps[k] rotates d_{k-1} onto d_k (steps[0] = identity)
    steps = np.broadcast_to(np.eye(3), (n, 3, 3)).copy()
    if n > 1:
        p, d = dirs[:-1], dirs[1:]
        axis = np.cross(p, d)
        s = np.linalg.norm(axis, axis=1)
        c = np.einsum("ij,ij->i", p, d)
        turn = s > 1e-15
        a = axis[turn] / s[turn, None]
        st, ct = s[turn, None, None], c[turn, None, None]
        skew = np.zeros((len(a), 3, 3))
        skew[:, 0, 1], skew[:, 0, 2], skew[:, 1, 2] = -a[:, 2], a[:, 1], -a[:, 0]
        skew -= skew.transpose(0, 2, 1)
        steps[1:][turn] = ct * np.eye(3) + st * skew + (1.0 - ct) * a[:, :, None] * a[:, None, :]
    # inclusive scan: prefix[k] = steps[k] @ steps[k-1] @ ... @ steps[0]
    prefix = steps
    shift = 1
    while shift < n:
        prefix[shift:] = prefix[shift:] @ prefix[:-shift]
        shift *= 2
    u = prefix @ u
    u -= np.einsum("ij,ij->i", u, dirs)[:, None] * dirs
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    return np.stack([u, np.cross(dirs, u), dirs], axis=1)


class ViewSet:
    """Directions and camera bases of the depth maps of a CSM, in order.

    Build one with :meth:`zigzag` or :meth:`hilbert`; ``views[i:j]`` gives a
    view set of the maps ``i .. j-1`` (layout ``'custom'``).

    Attributes
    ----------
    directions : ndarray, shape (D, 3), float64
        Unit vectors ``d_k`` from the object towards camera ``k``.
    bases : ndarray, shape (D, 3, 3), float64
        Rows ``(u_k, v_k, d_k)``; orthonormal, ``u_k x v_k = d_k``.
    layout : str
        ``'zigzag'``, ``'hilbert'`` or ``'custom'``.
    params : dict
        Layout parameters: ``{'theta', 'phi', 'row_offset'}`` (no
        ``row_offset``: 0) or ``{'level'}``.

    Parameters
    ----------
    directions, bases, layout, params
        As the attributes (kept as given), to :data:`BASIS_TOL` (1e-6). A ``'zigzag'`` or ``'hilbert'``
        layout (the O(1) lookups read the grid from ``params``) needs the directions of its grid; any
        bases (e.g. other cameras' on that grid).

    Raises
    ------
    TypeError, ValueError
        Non-numeric arrays; wrong shapes, non-finite values, directions or bases beyond the tolerance;
        another layout, or one whose params are missing or are not the grid of the directions.
    """

    def __init__(self, directions, bases, layout: str = "custom", params: dict | None = None):
        d, b = check_rows(directions, "ViewSet: directions"), np.asarray(bases)
        if b.ndim != 3 or b.shape[1:] != (3, 3) or len(b) != len(d):
            raise ValueError(f"ViewSet: bases must have shape (D, 3, 3) for {len(d)} directions, got {b.shape}")
        if b.dtype.kind not in "iuf":
            raise TypeError(f"ViewSet: bases must be numeric, got {b.dtype}")
        d, b = d.astype(np.float64, copy=False), b.astype(np.float64, copy=False)
        _check_frames(d, b)
        _check_layout(layout, params, d)
        self.__dict__.update(directions=d, bases=b, layout=layout, params=dict(params or {}), _tree=None)

    # -- constructors -----------------------------------------------------
    @classmethod
    def zigzag(cls, theta: int = 64, phi: int = 128, row_offset: float = 0.5) -> "ViewSet":
        """The thesis grid in zigzag order (thesis 000, Listing 5.1).

        Parameters
        ----------
        theta, phi : int
            Rows (polar angle steps of ``pi/theta``) and columns (azimuth
            steps of ``2*pi/phi``); ``D = theta*phi``. Integers (not bools),
            each in 1 .. 65536, ``D`` at most 2**21 (:data:`MAX_MAPS`, the
            largest :meth:`hilbert` set).
            The lookups (:meth:`nearest`, :meth:`filter_window`, the kernels)
            search the 2 x 2 grid points around a direction: the nearest of
            all maps when ``theta <= phi**2 / 2`` (checked on grids up to
            64 rows; met whenever ``phi >= theta``), not on thinner grids
            (``theta`` beyond about ``2 phi**2 / pi``, e.g. 64 x 8), where
            the nearest may lie rows away, through a pole.
        row_offset : {0.5, 0}, optional
            Row ``i`` lies at the polar angle ``(i + row_offset)*pi/theta``.
            0.5 (default): rows centred in their bands, each pole half a
            step from its nearest row; beyond the first (last) row the
            lookups' 2 x 2 window pairs that row's two maps on the
            direction's side with the two across the pole, which lie nearer
            than the next row's (``phi`` even). 0: the thesis's
            grid, row 0 on the north pole and the south pole a whole step
            from the last row (CSM files without the parameter).
        """
        d, ph0, params = _zigzag_grid(theta, phi, row_offset)
        # start from the thesis's basis at the first map (eq. 5.4 written in
        # the grid angles, defined on the pole), then transport it along the order
        u0 = np.array([np.sin(ph0), 0.0, -np.cos(ph0)])
        bases = _transport_bases(d, u0)
        return _built(cls, d, bases, "zigzag", params)

    @classmethod
    def hilbert(cls, level: int = 6, hemispheres: bool = False) -> "ViewSet":
        """Equal-area octahedral grid visited along a Hilbert curve.

        Parameters
        ----------
        level : int
            0 .. 10 (an integer, not a bool). One square of ``2^level x 2^level``
            cells: ``D = 4**level`` (level 5: 1024 maps, 6: 4096, 7: 16384).
        hemispheres : bool, optional
            Map each hemisphere onto its own square (the octahedral diamond
            turned by 45 degrees) and join the squares side by side into a
            ``2^(level+1) x 2^level`` rectangle, traversed by two Hilbert
            curves that meet across the equator: ``D = 2 * 4**level``
            (level 5: 2048 maps, 6: 8192), the sizes of the thesis's
            ``theta x 2 theta`` grids. A bool.
        """
        d, params = _hilbert_grid(level, hemispheres)
        # start from the basis the zigzag layout would give at d_0
        u0 = np.array([d[0, 2], 0.0, -d[0, 0]])
        if np.linalg.norm(u0) < 1e-9:
            u0 = np.array([1.0, 0.0, 0.0])
        return _built(cls, d, _transport_bases(d, u0), "hilbert", params)

    @staticmethod
    def maps_for(layout: str, params: dict) -> int:
        """The map count of a zigzag or hilbert view set, from its parameters
        alone (nothing is built: a file's header is checked with it first); ValueError as from_params."""
        a = _layout_args(layout, params, "ViewSet.maps_for")
        return int(a[0]) * int(a[1]) if layout == "zigzag" else 4 ** int(a[0]) * (2 if a[1] else 1)

    @classmethod
    def from_params(cls, layout: str, params: dict) -> "ViewSet":
        """Rebuild a zigzag or hilbert view set from its layout and parameters (ValueError: a key missing)."""
        args = _layout_args(layout, params)
        return cls.zigzag(*args) if layout == "zigzag" else cls.hilbert(*args)

    # -- container protocol ------------------------------------------------
    def __len__(self) -> int:
        return len(self.directions)

    def __getitem__(self, item) -> "ViewSet":
        if not isinstance(item, slice):
            raise TypeError("ViewSet supports slicing only: views[i:j]")
        return _built(ViewSet, self.directions[item], self.bases[item], "custom", None)

    def __repr__(self) -> str:
        p = ", ".join(f"{k}={v}" for k, v in self.params.items())
        return f"ViewSet.{self.layout}({p}) with {len(self)} maps"

    # -- nearest view ------------------------------------------------------
    def nearest(self, dirs) -> np.ndarray:
        """Index of the view whose ``d_k`` is closest to each direction.

        Parameters
        ----------
        dirs : array_like, shape (N, 3) or (3,)
            Directions (need not be unit length; must be finite and non-zero).

        Returns
        -------
        ndarray, shape (N,), int32
            For ``zigzag`` and ``hilbert`` an O(1) lookup per direction: the
            grid cell holding the direction and its neighbours are compared
            (on the pole row of a ``row_offset = 0`` zigzag grid, whose maps
            share one direction, the column of the direction's azimuth is
            taken); on zigzag grids thinner than ``theta <= phi**2 / 2`` the
            nearest of those candidates, as the kernels (see :meth:`zigzag`).
            A ``custom`` set uses a k-d tree.
        """
        if len(self) == 0:
            raise ValueError("nearest: the view set is empty")
        d = _unit_rows(dirs, "nearest")
        if self.layout == "zigzag":
            idx = self._nearest_zigzag(d)
        elif self.layout == "hilbert":
            idx = self._nearest_hilbert(d)
        else:
            if self._tree is None:
                from scipy.spatial import cKDTree

                self._tree = cKDTree(self.directions)
            idx = self._tree.query(d)[1]
        return np.asarray(idx, dtype=np.int32)

    def filter_window(self, dirs) -> tuple[np.ndarray, np.ndarray]:
        """The four maps a filtered lookup asks for each direction, and their weights.

        Parameters
        ----------
        dirs : array_like, shape (N, 3)
            Directions in the views' frame (normalised here; must be
            finite and non-zero).

        Returns
        -------
        maps : ndarray, shape (N, 4), int64
            ``zigzag``: the 2 x 2 grid points around the direction's
            ``(theta, phi)`` -- rows ``r0, r0 + 1`` (the last row repeated
            below it), columns ``c0, c0 + 1`` (cyclic), in that order; the
            candidates of :meth:`nearest`. On centred rows (``row_offset``
            0.5) with ``phi`` a multiple of 4, a direction beyond the first
            or last row (within half a row step of a pole) gets four maps of
            that row a quarter turn apart, from the one nearest it: the four
            sides of the pole (the row's neighbours lie ``2 pi / phi`` apart
            in ``phi``, nearly one direction each). ``hilbert``: the four of the 3 x 3
            cells around the direction's cell whose directions are nearest
            it, nearest first (ties: the earlier cell of the 3 x 3 scan). A
            map may appear twice (the repeated row, folded cells).
        weights : ndarray, shape (N, 4), float64
            Inverse angles, ``1 / (a + FILTER_ANGLE_EPS)`` with
            ``a = 2 asin(|w - d_k| / 2)`` the angle in radians to map ``k``
            (``FILTER_ANGLE_EPS`` = 1e-4), normalised to sum to one.
        """
        d = _unit_rows(dirs, "filter_window")
        if self.layout == "zigzag":
            maps = self._zigzag_window(d, cap=True)
        elif self.layout == "hilbert":
            cand = self._hilbert_candidates(d)
            dot = np.einsum("ijk,ik->ij", self.directions[cand], d)
            order = np.argsort(-dot, axis=1, kind="stable")[:, :4]
            maps = np.take_along_axis(cand, order, axis=1)
        else:
            raise ValueError(f"filter_window: no map grid for the {self.layout!r} layout "
                             "(zigzag and hilbert have one)")
        chord = np.linalg.norm(d[:, None, :] - self.directions[maps], axis=2)
        w = 1.0 / (2.0 * np.arcsin(np.minimum(0.5 * chord, 1.0)) + FILTER_ANGLE_EPS)
        return maps, w / w.sum(axis=1, keepdims=True)

    def _zigzag_index(self, row, col):
        P = self.params["phi"]
        return row * P + np.where(row % 2 == 0, col, P - 1 - col)

    def _zigzag_window(self, d, cap=False):
        """Map indices (N, 4) of the 2 x 2 grid points around each direction: rows r0 (the last at or
        above theta; 0 above the first) and r0 + 1 (the last repeated), or, beyond the first or last
        of centred rows (row_offset 0.5, phi even), r0 again at the opposite columns across the pole.

        ``cap`` (the vote's window, :meth:`filter_window`): beyond the first or last of centred rows
        with phi a multiple of 4, the four maps of r0 a quarter turn apart around the pole, from the
        column nearest the direction's phi (so the nearest map stays in the window): the four sides
        of the pole instead of two pairs of maps 2 pi / phi apart (at the pole itself the pairs are
        nearly one direction each, and the vote would weigh two views, not four)."""
        T, P = self.params["theta"], self.params["phi"]
        theta = np.arccos(np.clip(d[:, 1], -1.0, 1.0))
        phi = np.arctan2(d[:, 2], d[:, 0])
        phi = np.where(phi < 0, phi + 2 * np.pi, phi)
        off = self.params.get("row_offset", 0.0)
        rowf = theta / (np.pi / T) - off
        r0 = np.clip(np.floor(rowf).astype(np.int64), 0, T - 1)
        across = ((rowf < 0) | (rowf >= T - 1)) & (off == 0.5 and P % 2 == 0)
        r1 = np.where(across, r0, np.minimum(r0 + 1, T - 1))
        col = phi / (2 * np.pi / P)
        c0 = np.floor(col).astype(np.int64) % P
        shift = np.where(across, P // 2, 0)
        cols = [c0, (c0 + 1) % P, (c0 + shift) % P, (c0 + 1 + shift) % P]
        if cap and P % 4 == 0:
            # the nearer of c0, c0 + 1 (the kernel's test: the offset from c0 beyond half a column)
            cn = np.where(col - np.floor(col) > 0.5, c0 + 1, c0)
            cols = [np.where(across, (cn + q * P // 4) % P, c) for q, c in enumerate(cols)]
        return np.stack([self._zigzag_index(r, c) for r, c in zip((r0, r0, r1, r1), cols)], axis=1)

    def _nearest_zigzag(self, d):
        cand = self._zigzag_window(d)
        dot = np.einsum("ijk,ik->ij", self.directions[cand], d)
        return cand[np.arange(len(d)), np.argmax(dot, axis=1)]   # first of equals, as the kernel

    def _hilbert_cells(self):
        if not hasattr(self, "_cell_to_index"):
            level = self.params["level"]
            n = 1 << level
            split = self.params.get("hemispheres", False)
            x, y = hilbert_d2xy(level, np.arange(n * n))
            if split:
                x = np.concatenate([x, x + n])
                y = np.concatenate([y, y])
            table = np.empty((2 * n if split else n, n), dtype=np.int64)
            table[x, y] = np.arange(len(x))
            self._cell_to_index = table
        return self._cell_to_index

    def _hilbert_candidates(self, d):
        """Map indices (N, 9) of the 3 x 3 cells around each direction's cell."""
        n = 1 << self.params["level"]
        split = self.params.get("hemispheres", False)
        table = self._hilbert_cells()
        hemi, sq = _hilbert_square_coords(split, d)
        ci = np.clip(np.floor((sq[:, 0] + 1.0) * 0.5 * n).astype(np.int64), 0, n - 1)
        cj = np.clip(np.floor((sq[:, 1] + 1.0) * 0.5 * n).astype(np.int64), 0, n - 1)
        out = []
        for di in (-1, 0, 1):
            for dj in (-1, 0, 1):
                i, j, h = _hilbert_neighbour(split, n, ci + di, cj + dj, hemi)
                out.append(table[i + h * n, j])
        return np.stack(out, axis=1)

    def _nearest_hilbert(self, d):
        cand = self._hilbert_candidates(d)
        dot = np.einsum("ijk,ik->ij", self.directions[cand], d)
        return cand[np.arange(len(d)), np.argmax(dot, axis=1)]   # first of equals, as the kernel


def _zigzag_grid(theta, phi, row_offset):
    """Directions (D, 3) of ViewSet.zigzag's grid, the first map's phi and the checked params."""
    theta = check_int(theta, "ViewSet.zigzag: theta", 1, MAX_GRID)
    phi = check_int(phi, "ViewSet.zigzag: phi", 1, MAX_GRID)
    if theta * phi > MAX_MAPS:
        raise ValueError(f"ViewSet.zigzag: theta * phi must be at most {MAX_MAPS} (2**21), got {theta}x{phi}")
    if isinstance(row_offset, (bool, np.bool_)) or not isinstance(row_offset, (int, float, np.number)):
        raise TypeError(f"ViewSet.zigzag: row_offset must be a number (0 or 0.5), got {row_offset!r}")
    row_offset = float(row_offset)
    if row_offset not in ZIGZAG_ROW_OFFSETS:
        raise ValueError(f"ViewSet.zigzag needs row_offset 0 or 0.5, got {row_offset}")
    rows = np.repeat(np.arange(theta), phi)
    k = np.tile(np.arange(phi), theta)
    cols = np.where(rows % 2 == 0, k, phi - 1 - k)
    th = (rows + row_offset) * (np.pi / theta)
    ph = cols * (2.0 * np.pi / phi)
    return polar_direction(th, ph), ph[0], {"theta": theta, "phi": phi, "row_offset": row_offset}


def _hilbert_grid(level, hemispheres):
    """Directions (D, 3) of ViewSet.hilbert's cells, in curve order, and the checked params."""
    level = check_int(level, "ViewSet.hilbert: level", 0, 10)
    if not isinstance(hemispheres, (bool, np.bool_)):
        raise TypeError(f"ViewSet.hilbert: hemispheres must be a bool, got {hemispheres!r}")
    n = 1 << level
    x, y = hilbert_d2xy(level, np.arange(n * n))
    if hemispheres:
        x = np.concatenate([x, x + n])
        y = np.concatenate([y, y])
    return _hilbert_cell_directions(level, bool(hemispheres), x, y), \
        {"level": level, **({"hemispheres": True} if hemispheres else {})}


def _built(cls, directions, bases, layout, params) -> ViewSet:
    """A view set of arrays valid by construction (zigzag, hilbert, a slice): not checked again."""
    views = cls.__new__(cls)
    views.__dict__.update(directions=directions, bases=bases, layout=layout, params=params or {}, _tree=None)
    return views


def _hilbert_cell_directions(level, split, x, y):
    """Directions of the centres of cells (x, y) of a hilbert layout."""
    n = 1 << level
    h = x // n if split else np.zeros_like(x)
    s = ((x - h * n) + 0.5) / n * 2.0 - 1.0
    t = (y + 0.5) / n * 2.0 - 1.0
    if not split:
        return octahedral_decode(np.stack([s, t], axis=-1))
    s = np.where(h == 1, -s, s)          # the lower square is mirrored in s
    uv = np.stack([(s - t) * 0.5, (s + t) * 0.5], axis=-1)
    d = octahedral_decode(uv)
    d[:, 1] = np.where(h == 1, -np.abs(d[:, 1]), np.abs(d[:, 1]))
    return d


def _hilbert_square_coords(split, d):
    """(hemisphere (N,), square coordinates (N, 2) in [-1, 1]) of unit directions."""
    if not split:
        return np.zeros(len(d), np.int64), _encode_unit(d)
    lower = d[:, 1] < 0
    up = d.copy()
    up[:, 1] = np.abs(up[:, 1])
    uv = _encode_unit(up)
    s = uv[:, 0] + uv[:, 1]
    t = uv[:, 1] - uv[:, 0]
    s = np.where(lower, -s, s)
    return lower.astype(np.int64), np.stack([s, t], axis=-1)


def _hilbert_neighbour(split, n, i, j, h):
    """Fold cell indices that left the square back onto the sphere."""
    if not split:
        # octahedral wrap of the single square
        out_i = (i < 0) | (i >= n)
        i = np.where(i < 0, 0, np.where(i >= n, n - 1, i))
        j = np.where(out_i, n - 1 - j, j)
        out_j = (j < 0) | (j >= n)
        j = np.where(j < 0, 0, np.where(j >= n, n - 1, j))
        i = np.where(out_j, n - 1 - i, i)
        return i, j, h
    # leaving across an s edge: same t, other hemisphere, opposite s edge
    out_i = (i < 0) | (i >= n)
    h = np.where(out_i, 1 - h, h)
    i = np.where(i >= n, 0, np.where(i < 0, n - 1, i))
    # leaving across a t edge: same (u, v) point, other hemisphere, s mirrored
    out_j = (j < 0) | (j >= n)
    h = np.where(out_j, 1 - h, h)
    i = np.where(out_j, n - 1 - i, i)
    j = np.where(j >= n, n - 1, np.where(j < 0, 0, j))
    return i, j, h

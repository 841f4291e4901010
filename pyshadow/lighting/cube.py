"""Cube maps: face frames, per-texel directions and solid angles, the two cross layouts.

Faces
-----
Six faces of N x N texels, stored as an array of shape (6, N, N, ...) in the
order +X, -X, +Y, -Y, +Z, -Z. Each face is the image seen from the cube's
centre looking along its axis ``c``, with image-right ``r`` and image-down
``dn`` (``r x dn = c``: no face is mirrored). Texel (i, j) (row i from the
top, column j from the left) has face coordinates
``s = 2 (j + 0.5) / N - 1``, ``t = 2 (i + 0.5) / N - 1`` and direction
``normalise(c + s r + t dn)``::

    face   c          r          dn
    +X   ( 1, 0, 0) ( 0, 0, 1) ( 0,-1, 0)
    -X   (-1, 0, 0) ( 0, 0,-1) ( 0,-1, 0)
    +Y   ( 0, 1, 0) ( 1, 0, 0) ( 0, 0,-1)
    -Y   ( 0,-1, 0) ( 1, 0, 0) ( 0, 0, 1)
    +Z   ( 0, 0, 1) (-1, 0, 0) ( 0,-1, 0)
    -Z   ( 0, 0,-1) ( 1, 0, 0) ( 0,-1, 0)

Crosses
-------
The faces unfold around the front face -Z (a viewer facing -z, y up, x to the
right), in units of one face::

    horizontal (4 N wide, 3 N tall)      vertical (3 N wide, 4 N tall)
         . +Y  .  .                          . +Y  .
        -X -Z +X +Z                         -X -Z +X
         . -Y  .  .                          . -Y  .
                                             . +Z  .   (+Z turned by 180 degrees)

Neighbouring faces share their edges in both crosses. Cells marked "." are
not part of the map: they are neither read nor checked.
"""
from __future__ import annotations

import numpy as np

from .._validate import check_int, check_values, rows3

__all__ = ["FACE_NAMES", "FACE_FRAMES", "CROSS_CELLS", "face_directions", "face_solid_angles",
           "cube_lookup", "faces_from_cross", "cross_from_faces", "cube_basis_integrals", "texel_moments"]

FACE_NAMES = ("+X", "-X", "+Y", "-Y", "+Z", "-Z")
#: (c, r, dn) of each face, shape (6, 3, 3).
FACE_FRAMES = np.array([
    [[1, 0, 0], [0, 0, 1], [0, -1, 0]],
    [[-1, 0, 0], [0, 0, -1], [0, -1, 0]],
    [[0, 1, 0], [1, 0, 0], [0, 0, -1]],
    [[0, -1, 0], [1, 0, 0], [0, 0, 1]],
    [[0, 0, 1], [-1, 0, 0], [0, -1, 0]],
    [[0, 0, -1], [1, 0, 0], [0, -1, 0]],
], dtype=np.float64)
#: Face index -> (cell row, cell column, turned by 180 degrees) per cross layout.
CROSS_CELLS = {
    "horizontal-cross": {2: (0, 1, False), 1: (1, 0, False), 5: (1, 1, False),
                         0: (1, 2, False), 4: (1, 3, False), 3: (2, 1, False)},
    "vertical-cross": {2: (0, 1, False), 1: (1, 0, False), 5: (1, 1, False),
                       0: (1, 2, False), 3: (2, 1, False), 4: (3, 1, True)},
}
#: (rows, columns) of each cross in faces.
CROSS_CELLS_SHAPE = {"horizontal-cross": (3, 4), "vertical-cross": (4, 3)}


def _coords(n: int) -> np.ndarray:
    return 2.0 * (np.arange(n) + 0.5) / n - 1.0


def face_directions(n: int) -> np.ndarray:
    """Unit direction of every texel centre, shape (6, n, n, 3), float64 (``n`` an int >= 1)."""
    s = _coords(check_int(n, "n", 1))
    S, T = np.meshgrid(s, s)                      # S along columns, T along rows
    c, r, dn = FACE_FRAMES[:, 0], FACE_FRAMES[:, 1], FACE_FRAMES[:, 2]
    d = (c[:, None, None, :] + S[None, :, :, None] * r[:, None, None, :]
         + T[None, :, :, None] * dn[:, None, None, :])
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def face_solid_angles(n: int) -> np.ndarray:
    """Exact solid angle of every texel, shape (6, n, n), float64 (sr; sums to 4 pi).

    A rectangle [s0, s1] x [t0, t1] on the plane at distance 1 subtends
    ``F(s1, t1) - F(s0, t1) - F(s1, t0) + F(s0, t0)`` with
    ``F(s, t) = atan(s t / sqrt(1 + s^2 + t^2))``. ``n``: an int >= 1.
    """
    n = check_int(n, "n", 1)
    e = np.linspace(-1.0, 1.0, n + 1)
    S, T = np.meshgrid(e, e)
    F = np.arctan2(S * T, np.sqrt(1.0 + S * S + T * T))
    om = F[1:, 1:] - F[1:, :-1] - F[:-1, 1:] + F[:-1, :-1]
    return np.broadcast_to(om, (6, n, n)).copy()


def cube_lookup(directions, n: int):
    """Face, row and column of the texel that holds each direction (nearest texel).

    Parameters
    ----------
    directions : ndarray, shape (M, 3), float
        Finite, non-zero directions, y up (need not be unit).
    n : int
        Face size in texels, >= 1.

    Returns
    -------
    face, row, col : ndarray, shape (M,), int64

    Raises
    ------
    ValueError
        ``directions`` not of shape (M, 3), or holding rows that are not
        finite or zero (no face); ``n`` below 1.
    TypeError
        ``directions`` not numeric; ``n`` not an int.
    """
    n = check_int(n, "n", 1)
    d = rows3(directions, "directions")
    check_values(d, "directions", nonzero=True)
    a = np.abs(d)
    axis = np.argmax(a, axis=1)
    neg = d[np.arange(len(d)), axis] < 0
    face = 2 * axis + neg
    fr = FACE_FRAMES[face]
    depth = np.einsum("mi,mi->m", d, fr[:, 0])
    s = np.einsum("mi,mi->m", d, fr[:, 1]) / depth
    t = np.einsum("mi,mi->m", d, fr[:, 2]) / depth
    col = np.clip(np.floor((s + 1.0) * 0.5 * n), 0, n - 1).astype(np.int64)
    row = np.clip(np.floor((t + 1.0) * 0.5 * n), 0, n - 1).astype(np.int64)
    return face, row, col


def _cross_shape(layout) -> tuple:
    """(rows, columns) of a cross ``layout``; ValueError naming it for any other value."""
    if not isinstance(layout, str) or layout not in CROSS_CELLS_SHAPE:
        raise ValueError(f"layout: expected 'horizontal-cross' or 'vertical-cross' (got {layout!r})")
    return CROSS_CELLS_SHAPE[layout]


def faces_from_cross(image: np.ndarray, layout: str) -> np.ndarray:
    """Cut the six faces out of a cross image (H, W, C) -> (6, N, N, C) (a copy).

    ``image`` (H, W) or (H, W, C) is ``4 N x 3 N`` (W x H) for
    ``"horizontal-cross"``, ``3 N x 4 N`` for ``"vertical-cross"``, N >= 1;
    ValueError otherwise, or for another ``layout``.
    """
    rows, cols = _cross_shape(layout)
    image = np.asarray(image)
    h, w = image.shape[:2] if image.ndim >= 2 else (0, 0)
    if h < rows or h % rows or w % cols or h // rows != w // cols:
        raise ValueError(f"image: a {layout} is {cols} N wide and {rows} N tall, N >= 1 (got shape {image.shape})")
    n = image.shape[0] // rows
    faces = np.empty((6, n, n) + image.shape[2:], dtype=image.dtype)
    for f, (i, j, turned) in CROSS_CELLS[layout].items():
        block = image[i * n:(i + 1) * n, j * n:(j + 1) * n]
        faces[f] = block[::-1, ::-1] if turned else block
    return faces


def cross_from_faces(faces: np.ndarray, layout: str, fill: float = 0.0) -> np.ndarray:
    """Lay six faces (6, N, N, C) out as a cross image; unused cells hold ``fill``.

    ``faces`` (6, N, N) or (6, N, N, C), N >= 1, and ``layout`` one of
    :data:`CROSS_CELLS` (ValueError otherwise).
    """
    rows, cols = _cross_shape(layout)
    faces = np.asarray(faces)
    if faces.ndim < 3 or faces.shape[0] != 6 or faces.shape[1] != faces.shape[2] or faces.shape[1] < 1:
        raise ValueError(f"faces: expected shape (6, N, N) or (6, N, N, C), N >= 1 (got shape {faces.shape})")
    n = faces.shape[1]
    image = np.full((rows * n, cols * n) + faces.shape[3:], fill, dtype=faces.dtype)
    for f, (i, j, turned) in CROSS_CELLS[layout].items():
        image[i * n:(i + 1) * n, j * n:(j + 1) * n] = faces[f][::-1, ::-1] if turned else faces[f]
    return image


def _texel_weights(n: int, order: int, r0: int, r1: int, exact: np.ndarray):
    """Gauss points (S, T) of texel rows r0..r1 of a face, weights scaled per texel to ``exact`` (n, n) Omega."""
    g, w = np.polynomial.legendre.leggauss(order)
    h = 1.0 / n                                     # half a texel in face units
    q = (_coords(n)[:, None] + h * g[None, :]).reshape(-1)          # (n * order,)
    wq = np.tile(h * w, n)
    S, T = np.meshgrid(q, q[r0 * order:r1 * order])
    W = wq[None, :] * wq[r0 * order:r1 * order, None] / (1.0 + S * S + T * T) ** 1.5
    W = W.reshape(r1 - r0, order, n, order)
    return S, T, (W * (exact[r0:r1] / W.sum(axis=(1, 3)))[:, None, :, None]).reshape(S.shape)


def texel_moments(n: int, order: int = 4, *, block: int = 64):
    """Solid angle, first and second moments of the direction over the texels of a face.

    In a face's own frame (c, r, dn) a texel's unit directions are
    ``v / |v|`` with ``v = (1, s, t)``: the same on all six faces. Integrated
    by ``order`` x ``order`` Gauss-Legendre points a texel, weights scaled to
    the texel's exact solid angle (as :func:`cube_basis_integrals`). A face
    with frame rows ``F = (c, r, dn)`` has world moments ``m1 @ F`` and
    ``F^T m2 F``.

    Parameters
    ----------
    n : int
        Face size in texels, >= 1.
    order : int
        Gauss points a texel side, >= 1.
    block : int
        Texel rows per yielded block (memory O(block n order^2)), >= 1.

    Yields
    ------
    rows : slice
        The texel rows of the block.
    M : ndarray, shape (len(rows), n, 13), float64
        Per texel: ``M[..., 0]`` = m0 = ``integral dOmega`` (sr);
        ``M[..., 1:4]`` = m1 = ``integral d dOmega``; ``M[..., 4:]`` = m2 =
        ``integral d d^T dOmega`` flattened row-major (symmetric, trace m0);
        d in face coordinates (components along c, r, dn).
    """
    n, order, block = check_int(n, "n", 1), check_int(order, "order", 1), check_int(block, "block", 1)
    exact, ones = face_solid_angles(n)[0], np.ones(order)
    for r0 in range(0, n, block):
        r1 = min(n, r0 + block)
        S, T, W = _texel_weights(n, order, r0, r1, exact)
        inv = 1.0 / (1.0 + S * S + T * T)         # 1 / |v|^2
        W1, W2, v = W * np.sqrt(inv), W * inv, (1.0, S, T)

        def texels(a):                            # sum over each texel's order x order points (a matmul sums
            return a.reshape(r1 - r0, order, n * order).sum(axis=1).reshape(r1 - r0, n, order) @ ones  # fast)
        M = np.empty((r1 - r0, n, 13))
        M[..., 0] = texels(W)
        for a in range(3):
            M[..., 1 + a] = texels(W1 * v[a])
            for b in range(a, 3):
                M[..., 4 + 3 * a + b] = M[..., 4 + 3 * b + a] = texels(W2 * v[a] * v[b])
        yield slice(r0, r1), M


def cube_basis_integrals(n: int, basis, order: int = 4, *, block: int = 64):
    """Integrals of ``basis`` over texels, by ``order`` x ``order`` Gauss-Legendre points.

    ``dOmega = ds dt / (1 + s^2 + t^2)^(3/2)`` on a face; the basis is a
    polynomial of the unit direction, smooth over a texel, so 4 x 4 points are
    accurate to about 1e-11 relative at N = 16 and better above; the weights
    of each texel are then scaled to sum to its exact solid angle, so that
    ``B[..., 0] = Y_0 Omega`` holds to rounding. ``n``, ``order`` and ``block``
    are ints >= 1 (TypeError or ValueError naming the argument otherwise: a
    ``block`` of 0 or below yielded no texel at all, so a caller's sums stayed 0).

    Yields
    ------
    face, rows, B : int, slice, ndarray of shape (len(rows), n, K), float64
        Blocks of at most ``block`` texel rows, so that memory stays
        O(block n order^2) for any face size.
    """
    n, order, block = check_int(n, "n", 1), check_int(order, "order", 1), check_int(block, "block", 1)
    exact = face_solid_angles(n)[0]
    for r0 in range(0, n, block):
        r1 = min(n, r0 + block)
        S, T, W = _texel_weights(n, order, r0, r1, exact)
        for f in range(6):
            c, r, dn = FACE_FRAMES[f]
            d = c + S[..., None] * r + T[..., None] * dn
            d /= np.linalg.norm(d, axis=-1, keepdims=True)
            vals = basis(d) * W[..., None]
            K = vals.shape[-1]
            yield f, slice(r0, r1), vals.reshape(r1 - r0, order, n, order, K).sum(axis=(1, 3))

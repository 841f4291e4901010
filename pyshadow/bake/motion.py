"""Rigid motion files: per-frame 4x4 transforms of a scene's bodies, as NPZ or JSON.

NPZ: an array ``transforms`` of shape (F, N, 4, 4), float (frames, bodies,
row-major 4x4 object-to-world matrices, column vectors: ``x_world = T @
[x, 1]``), and optionally ``names``, N strings. JSON: ``{"names": [N
strings], "frames": [F lists of N 4x4 nested lists]}``. Every transform is
a rotation, a translation and a uniform positive scale (the motion of a
rigid body), checked on reading.
"""
from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np

from .._files import write_bytes_atomic
from .._validate import check_transform

__all__ = ["read_motion", "write_motion", "default_motion"]


def _check(transforms, names, label) -> tuple[np.ndarray, list | None]:
    T = np.asarray(transforms, dtype=np.float64)
    if T.ndim != 4 or T.shape[2:] != (4, 4) or T.shape[0] < 1 or T.shape[1] < 1:
        raise ValueError(f"{label}: transforms must have shape (frames, bodies, 4, 4), got {T.shape}")
    for f in range(T.shape[0]):
        for b in range(T.shape[1]):
            check_transform(T[f, b], rigid=True, name=f"{label}: frame {f}, body {b}")
    if names is not None:
        names = [str(n) for n in names]
        if len(names) != T.shape[1]:
            raise ValueError(f"{label}: {len(names)} names for {T.shape[1]} bodies")
    return T, names


def read_motion(path) -> tuple[np.ndarray, list | None]:
    """Read a motion file.

    Parameters
    ----------
    path : str or path-like
        ``.npz`` or ``.json`` (layout in :mod:`pyshadow.bake.motion`).

    Returns
    -------
    transforms : ndarray, float64, shape (F, N, 4, 4)
        Object-to-world transforms of N bodies in F frames.
    names : list of str or None

    Raises
    ------
    ValueError
        Unknown extension, unreadable file, wrong shape, or a transform that
        is not rigid (the message names the frame and body).
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == ".npz":
        try:
            with np.load(path, allow_pickle=False) as z:
                T = np.array(z["transforms"])
                names = [str(n) for n in z["names"]] if "names" in z.files else None
        except (OSError, ValueError, KeyError) as e:
            raise ValueError(f"{path}: not a motion NPZ with an array 'transforms' ({e})") from None
    elif suffix == ".json":
        try:
            d = json.loads(path.read_text())
            T = np.array(d["frames"], dtype=np.float64)
            names = d.get("names")
        except (OSError, ValueError, KeyError, TypeError) as e:
            raise ValueError(f"{path}: not a motion JSON with a list 'frames' ({e})") from None
    else:
        raise ValueError(f"{path}: a motion file ends in .npz or .json, not {path.suffix!r}")
    return _check(T, names, str(path))


def write_motion(path, transforms, names=None) -> Path:
    """Write a motion file (``.npz`` or ``.json``) atomically; the inverse of :func:`read_motion`."""
    path = Path(path)
    T, names = _check(transforms, names, str(path))
    if path.suffix.lower() == ".npz":
        buf = io.BytesIO()
        arrays = {"transforms": T}
        if names is not None:
            arrays["names"] = np.array(names, dtype=str)
        np.savez_compressed(buf, **arrays)
        write_bytes_atomic(path, buf.getvalue())
    elif path.suffix.lower() == ".json":
        write_bytes_atomic(path, json.dumps({"names": names, "frames": T.tolist()}).encode())
    else:
        raise ValueError(f"{path}: a motion file ends in .npz or .json, not {path.suffix!r}")
    return path


def _turn(T, angle, centre):
    """``T`` followed by a rotation of ``angle`` radians about the vertical axis through world ``centre``."""
    c, s = np.cos(angle), np.sin(angle)
    R = np.eye(4)
    R[0, 0], R[0, 2], R[2, 0], R[2, 2] = c, s, -s, c
    A, B = np.eye(4), np.eye(4)
    A[:3, 3], B[:3, 3] = -centre, centre
    return B @ R @ A @ T


def default_motion(frames: int = 60) -> tuple[np.ndarray, list]:
    """A motion of the bundled scene (:func:`pyshadow.data.default_scene`).

    Over ``frames`` frames the bunny turns once about the vertical axis
    through its bounding sphere's centre and the torus turns once the other
    way about its own; both keep their footing on the ground (a turn about
    a vertical axis keeps every height) and never meet (each sweeps a
    cylinder of its bounding radius, and the two cylinders are apart). The
    walls stay put.

    Returns
    -------
    transforms : ndarray, float64, shape (frames, 4, 4, 4)
        In the order of :data:`pyshadow.data.DEFAULT_PARTS`; frame 0 is the
        bundled scene's own placement.
    names : list of str
    """
    from ..data import default_parts
    from ..mesh import bounding_sphere

    if isinstance(frames, bool) or int(frames) < 1:
        raise ValueError(f"frames must be a positive int, got {frames!r}")
    parts = default_parts()
    out = np.empty((int(frames), len(parts), 4, 4))
    for b, (name, mesh, T, casts) in enumerate(parts):
        c, _ = bounding_sphere(mesh)
        centre = T[:3, :3] @ c + T[:3, 3]
        turns = {"bunny": 1.0, "torus": -1.0}.get(name, 0.0)
        for f in range(int(frames)):
            out[f, b] = _turn(T, 2.0 * np.pi * turns * f / frames, centre) if turns else T
    return out, [p[0] for p in parts]

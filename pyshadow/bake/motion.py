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
import zipfile
import zlib
from pathlib import Path

import numpy as np

from .._files import write_bytes_atomic
from .._validate import check_int, check_transforms

__all__ = ["read_motion", "write_motion", "default_motion"]


def _names(names, label) -> list | None:
    """``names`` as a list of str (None stays None); TypeError unless a sequence of strings."""
    if names is None:
        return None
    if isinstance(names, np.ndarray):
        if names.ndim != 1 or names.dtype.kind != "U":
            raise TypeError(f"{label}: names must be a 1-D array of strings, got dtype {names.dtype}, "
                            f"shape {names.shape}")
        return [str(n) for n in names]
    if not isinstance(names, (list, tuple)):        # a str would be split into its characters
        raise TypeError(f"{label}: names must be a list of strings, got {type(names).__name__}")
    bad = [n for n in names if not isinstance(n, str)]
    if bad:
        raise TypeError(f"{label}: names must be strings, got {bad[0]!r}")
    return [str(n) for n in names]


def _check(transforms, names, label) -> tuple[np.ndarray, list | None]:
    T = np.asarray(transforms)
    if T.dtype.kind not in "iuf":       # no strings, bools, complex or objects read as numbers
        raise TypeError(f"{label}: transforms must hold real numbers, got dtype {T.dtype}")
    T = T.astype(np.float64)
    if T.ndim != 4 or T.shape[2:] != (4, 4) or T.shape[0] < 1 or T.shape[1] < 1:
        raise ValueError(f"{label}: transforms must have shape (frames, bodies, 4, 4), got {T.shape}")
    check_transforms(T, rigid=True, label=lambda k: f"{label}: frame {k[0]}, body {k[1]}")
    names = _names(names, label)
    if names is not None:
        if len(names) != T.shape[1]:
            raise ValueError(f"{label}: {len(names)} names for {T.shape[1]} bodies")
    return T, names


def read_motion(path) -> tuple[np.ndarray, list | None]:
    """Read a motion file.

    Parameters
    ----------
    path : str or path-like
        ``.npz`` or ``.json`` (layout in :mod:`pyshadow.bake.motion`); ``~`` expanded.

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
    path = Path(path).expanduser()      # as the bake's other paths (--mesh, -o): "--motion=~/m.npz" was not found
    suffix = path.suffix.lower()
    if suffix == ".npz":
        try:
            with open(path, "rb") as f:     # ours to close: np.load leaks its own on a damaged archive
                z = np.load(f, allow_pickle=False)
                if not isinstance(z, np.lib.npyio.NpzFile):
                    raise ValueError("a single .npy array, not an NPZ archive")
                with z:
                    T = np.array(z["transforms"])
                    names = np.array(z["names"]) if "names" in z.files else None
        except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile, zlib.error) as e:
            raise ValueError(f"{path}: not a motion NPZ with an array 'transforms' ({e})") from None
    elif suffix == ".json":
        try:
            d = json.loads(path.read_text())
            A = np.array(d["frames"], dtype=object)
            names = d.get("names")
            bad = {type(x).__name__ for x in A.ravel() if type(x) not in (int, float)}
            if bad:                         # strings and booleans are not numbers; nor are ragged lists
                raise ValueError(f"'frames' must be nested lists of numbers, found {', '.join(sorted(bad))}")
            T = A.astype(np.float64)
        except OverflowError:
            raise ValueError(f"{path}: 'frames' holds a number too large for float64") from None
        except (OSError, ValueError, KeyError, TypeError, RecursionError) as e:
            raise ValueError(f"{path}: not a motion JSON with a list 'frames' ({e})") from None
    else:
        raise ValueError(f"{path}: a motion file ends in .npz or .json, not {path.suffix!r}")
    try:
        return _check(T, names, str(path))
    except TypeError as e:              # a file's content: ValueError, as documented
        raise ValueError(str(e)) from None


def write_motion(path, transforms, names=None) -> Path:
    """Write a motion file (``.npz`` or ``.json``, ``~`` expanded) atomically; the inverse of :func:`read_motion`."""
    path = Path(path).expanduser()
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

    frames = check_int(frames, "frames", 1)     # a float such as 2.5 made 2 frames of a partial turn
    parts = default_parts()
    out = np.empty((int(frames), len(parts), 4, 4))
    for b, (name, mesh, T, casts) in enumerate(parts):
        c, _ = bounding_sphere(mesh)
        centre = T[:3, :3] @ c + T[:3, 3]
        turns = {"bunny": 1.0, "torus": -1.0}.get(name, 0.0)
        for f in range(int(frames)):
            out[f, b] = _turn(T, 2.0 * np.pi * turns * f / frames, centre) if turns else T
    return out, [p[0] for p in parts]

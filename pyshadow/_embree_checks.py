"""Checks of what :mod:`pyshadow.embree` hands to Embree: float32 rays, lengths, thread counts; and the split of a
batch of rays over threads (:func:`traced_in_chunks`).

Embree reads each ray from float32 arrays without looking at them: a
direction array shorter than the origins is read past its end, a NaN or an
overflowed coordinate makes a ray silently miss, and a negative ``tfar``
is answered "occluded". Everything is refused here, named, before a ray is
traced; valid rays are passed on unchanged (the same float32 values).
"""
from __future__ import annotations

import numpy as np

from ._validate import check_int, check_values

_F32_MAX = float(np.finfo(np.float32).max)


def _rows32(a, name, unit=1.0):
    """``a`` (any shape ending in 3) as C-contiguous float32 (n, 3), scaled by ``unit`` (float64 first)."""
    a = np.asarray(a)
    if a.ndim == 0 or a.shape[-1] != 3:
        raise ValueError(f"{name} must have shape (N, 3), got {a.shape}")
    if not (np.issubdtype(a.dtype, np.floating) or np.issubdtype(a.dtype, np.integer)):
        raise TypeError(f"{name} must be real numbers, got dtype {a.dtype}")
    with np.errstate(over="ignore", invalid="ignore"):       # beyond float32: inf, refused below
        if unit != 1.0:
            a = np.asarray(a, dtype=np.float64) * unit
        out = np.ascontiguousarray(a, dtype=np.float32).reshape(-1, 3)
    return out


def float32_rays(origins, directions, tfar, unit):
    """Origins, directions (float32, (n, 3)) and embreex's keywords for rays in Embree's units.

    ``origins`` and ``tfar`` are scaled by ``unit`` (the scene's power of two);
    ``directions`` may have one row for all origins (embreex repeats it).
    Raises ValueError for mismatched shapes, coordinates that are not finite
    in float32, zero directions, and ``tfar`` that is NaN or negative; a
    ``tfar`` beyond float32's range is unbounded (inf).
    """
    o = _rows32(origins, "origins", unit)
    d = _rows32(directions, "directions")
    n = len(o)
    if len(d) != n and not (len(d) == 1 and n > 0):
        raise ValueError(f"directions has {len(d)} rows but origins has {n} (give one direction per origin, "
                         "or a single direction for all)")
    for a, name in ((o, "origins"), (d, "directions")):
        try:
            check_values(a, name)
        except ValueError as e:         # "<name>: <k> rows are not finite", of the float32 rows
            raise ValueError(f"{e} as float32 (NaN, inf, or beyond float32's range once scaled by the "
                             f"scene's unit {unit:g})") from None
    if not d.all():                     # some zero entries: is a row all zeros? (cheap where none is)
        check_values(d, "directions", nonzero=True)
    kw = {}
    if tfar is not None:
        t = np.asarray(tfar)
        if t.ndim > 1 or (t.ndim == 1 and len(t) != n):
            raise ValueError(f"tfar must be a number or have shape ({n},), got shape {t.shape}")
        if not (np.issubdtype(t.dtype, np.floating) or np.issubdtype(t.dtype, np.integer)):
            raise TypeError(f"tfar must be real numbers, got dtype {t.dtype}")
        with np.errstate(over="ignore"):
            t = np.asarray(t, dtype=np.float64) * unit if unit != 1.0 else t
            t32 = np.array(np.broadcast_to(t, (n,)), dtype=np.float32)     # a writable copy; beyond float32: inf
        if not (t32 >= 0).all():
            bad = ~(t32 >= 0)
            i = int(np.argmax(bad))
            raise ValueError(f"tfar must be >= 0 (inf: unbounded), got {np.broadcast_to(tfar, (n,))[i]} "
                             f"for ray {i} ({int(bad.sum())} bad)")
        kw["dists"] = t32
    return o, d, kw


def check_threads(threads) -> int:
    """``threads`` of :class:`pyshadow.embree.EmbreeTracer`: an int >= 1."""
    return check_int(threads, "EmbreeTracer: threads", 1)


def prepare_inputs(tracer, points, normals, dirs32, samples):
    """:meth:`pyshadow.embree.EmbreeTracer.prepare`'s arguments, checked: ``(points, normals, dirs32, samples)``,
    points (n, 3) float64 and finite, normals (n, 3) float64 normalised as
    :func:`pyshadow.embree.ambient_occlusion` normalises them (:func:`pyshadow._validate.unit_normals`: zero and
    non-finite rows refused), ``dirs32`` an array of ``(n * samples, 3)`` finite non-zero rows (its dtype
    kept), ``samples`` an int >= 1. The normals were taken as given: a normal of length 0.01 lifted its origin
    a hundredth of :func:`pyshadow.embree.surface_epsilon` (its rays met the surface they leave, unlike those
    of ``ambient_occlusion``), a zero one not at all; a NaN direction was traced as open."""
    from ._validate import rows3, unit_normals

    S = check_int(samples, "EmbreeTracer.prepare: samples", 1)
    check_unchanged(tracer)
    points = rows3(points, "points")
    normals = unit_normals(normals, len(points))
    dirs = np.asarray(dirs32)
    if dirs.shape != (len(points) * S, 3):
        raise ValueError(f"EmbreeTracer.prepare: dirs32 must have shape ({len(points) * S}, 3) (samples "
                         f"directions per point), got {dirs.shape}")
    if not (np.issubdtype(dirs.dtype, np.floating) or np.issubdtype(dirs.dtype, np.integer)):
        raise TypeError(f"EmbreeTracer.prepare: dirs32 must be real numbers, got dtype {dirs.dtype}")
    check_values(dirs, "dirs32", nonzero=True)
    return points, normals, dirs, S


def check_frame(frame, name="frame"):
    """``(centre, radius)`` of a normalised frame: centre (3,) finite, radius finite and > 0."""
    try:
        centre, radius = frame
        centre = np.asarray(centre, dtype=np.float64)
        radius = float(radius)
    except (TypeError, ValueError):
        raise TypeError(f"{name} must be (centre (3,), radius), got {frame!r}") from None
    if centre.shape != (3,) or not np.isfinite(centre).all():
        raise ValueError(f"{name}: centre must be 3 finite numbers, got {centre.tolist()}")
    if not (np.isfinite(radius) and radius > 0):
        raise ValueError(f"{name}: radius must be finite and > 0, got {radius}")
    return centre, radius


def check_item(item, oid):
    """A ``(mesh, transform)`` item of :func:`pyshadow.embree.gbuffer`, its mesh loaded or checked as
    :func:`pyshadow.render_gbuffer` does (the transform is checked by the caller)."""
    import trimesh

    from .mesh import check_mesh, load_mesh

    try:
        mesh, T = item
    except (TypeError, ValueError):
        raise ValueError(f"item {oid} must be a (mesh, 4x4 transform) pair") from None
    if not isinstance(mesh, trimesh.Trimesh):
        return load_mesh(mesh), T
    check_mesh(mesh, f"item {oid}")
    return mesh, T


def scene_state(scene) -> tuple:
    """What an :class:`pyshadow.embree.EmbreeTracer` was built from: the scene's version (advanced by
    ``Scene.add``, ``Scene.set_transform`` and ``Scene.remove``) and ground height."""
    return getattr(scene, "_version", None), scene.ground


def check_unchanged(tracer) -> None:
    """ValueError where ``tracer``'s scene changed since it was built: its triangles and anchor are those of
    the scene as it was, while the ground, the anchors of the points and the lift follow the scene now (a
    tracer half the old scene and half the new)."""
    if scene_state(tracer.scene) != tracer._state:
        raise ValueError("EmbreeTracer: the scene changed since the tracer was built (a body moved, added or "
                         "removed, or the ground); build a new EmbreeTracer for it")


def traced_in_chunks(pool, threads: int, n: int, trace) -> np.ndarray:
    """bool (n,): ``trace(s, e)`` (bool (e - s,), rays ``s:e``) over contiguous chunks of ``n`` rays, about four
    a thread and each at least 4096 rays, traced concurrently on ``pool`` (a ThreadPoolExecutor of ``threads``;
    None: one call here). embreex releases the GIL while it traces, and traces each ray alone: the split
    changes no answer."""
    step = max(4096, -(-n // (4 * threads)))
    if pool is None or n <= step:
        return trace(0, n) if n else np.empty(0, bool)
    out = np.empty(n, bool)

    def work(s):
        out[s:s + step] = trace(s, min(n, s + step))

    list(pool.map(work, range(0, n, step)))
    return out

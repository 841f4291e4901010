"""Per-ray visibility and per-texel AO from a :class:`~pyshadow.cubemap.CubeProbe`.

Two estimators (seed 002, section 4.3), both distance-limited: occluders
count only within ``max_distance`` ``D`` of the point (world units), the
step function of seed 002's section 4.3.1 in place of its ``rho(L)``.

``"raymarch"`` (the improved form)
    Each AO sample direction ``w`` of a point ``p`` -- pyshadow's own
    cosine-weighted directions, :func:`pyshadow.sample_directions` -- is
    marched through the probe: ``q_k = p + t_k w``, ``t_{k+1} = min(D, t_k +
    max(step * 2 r_k / R, D / max_steps))`` with ``r_k = |q_k - c|`` (about
    ``step`` texels per step: a texel spans ``2 r / R`` world units at
    distance ``r`` near a face centre). Each ``q_k`` is looked up in its
    texel (nearest, :func:`~pyshadow.cubemap.probe.direction_texels`); the
    texel's surface depth along the exact direction ``u`` of ``q_k`` is that
    of the texel's plane (position, normal), ``z(u) = n.(P - c) / n.u``
    (``P - c`` from the centre depth, :meth:`CubeProbe.texel_offsets`); the
    previous march point's direction, which may lie outside the texel, takes
    the stored centre depth where the plane is grazing (``|n.u| < 0.1``).
    (That fallback for ``q_k``'s own direction made flat casters seen at a
    grazing angle occlude themselves: 13-17 % of rays leaving a plate 8-15
    from the probe along it read occluded, against none within 8.)

    **Occlusion rule.** ``q_k`` is occluded when its texel shows a caster and

    * ``q_k`` lies behind the surface: ``r_k > z_k(u_k) + bias r_k``, and
    * the segment crossed that surface -- the previous march point was in
      front of the same texel's plane, ``r_{k-1} <= z_k(u_{k-1}) + bias
      r_k`` -- or ``q_k`` lies at most ``thickness`` behind it
      (``r_k - z_k(u_k) <= thickness``).

    Defaults (:func:`march_defaults`): ``step = 1`` texel, ``bias = 1e-3``,
    ``thickness = 0.25 D``, ``max_steps = 512`` (so at most 513 lookups
    per ray). The thickness is a guess about the scene, chosen where false
    "open" and false "occluded" rays balance on the bundled scene
    (benchmarks/cubemap.py sweeps it).

    The crossing test catches thin occluders (a quad wall) whatever the step;
    the thickness test stands for the unseen depth of a body behind its
    silhouette: a ray passing farther behind a silhouette than
    ``thickness`` is taken as missing it. The ground plane is not marched:
    it blocks a ray exactly as in every other backend
    (:func:`pyshadow.embree.ground_occludes` with the ray length ``D``).
    AO is the unoccluded fraction of the point's samples
    (:func:`pyshadow.sampling.ao_from_samples`). The probe must see the
    point's side of the surface (normals facing the probe).

``"horizon"`` (the thesis's estimator, faithful)
    Seed 002 eq. (4.4) and Listing 4.14, per texel of one face: for
    ``directions`` image directions ``theta_i = 2 pi i / N_d`` the texels
    ``uv + theta (1/R) + theta s j``, ``j = 0 .. steps-1``, are read (the
    march stops at the face's border, as the listing's break does); each
    occluder texel ``e`` (a caster or the ground quad) facing the receiver
    (``-v . n_e >= 0``, ``v`` the unit vector from the receiver to ``e``)
    within ``D`` of it gives ``h = n . v``; ``H_i = max(0, max h)`` and
    ``AO = 1 - mean_i H_i^2`` (eq. 4.4 gives the occluded fraction
    ``mean H^2``). The image step ``s`` follows section 4.3.2: the world
    step ``D / steps`` taken on the receiver's tangent plane along the
    direction that projects onto ``theta``, projected into the face; so the
    march reaches ``D`` on the plane. Ours, not the thesis's: the world step
    comes from ``D`` (the thesis derives it from the scene's bounding box)
    and emitters farther than ``D`` are skipped (Listing 4.14 has no such
    test), so that both estimators answer the same distance-limited AO.
    NumPy only (no kernel).
"""
from __future__ import annotations

import numpy as np

from .._validate import FLOAT32_MAX, flag, unit_normals
from ..lighting._checks import _number
from ..sampling import Sampling, ao_from_samples, sample_directions
from .probe import CubeProbe, _FRAMES, _direction_texels

__all__ = ["ESTIMATORS", "GRAZING", "texel_ao", "raymarch_visible", "raymarch_visible_reference",
           "horizon_ao_reference", "horizon_defaults", "march_defaults"]

ESTIMATORS = ("raymarch", "horizon")

#: Below this |n.u| a texel's plane is grazing and its centre depth is used for a direction outside it.
GRAZING = 0.1

#: About how many rays :func:`texel_ao` marches per call (bounds its memory, ~140 bytes a ray).
TEXEL_RAYS = 1 << 20


def march_defaults(max_distance: float, thickness=None, step=1.0, bias=1e-3, max_steps=512) -> dict:
    """Validated march parameters (see the module docstring), as a dict.

    ``thickness`` None means ``0.25 * max_distance`` (world units); ``step``
    in texels (0, 4]; ``bias`` relative to the distance from the probe,
    [0, 0.1); ``max_steps`` 1 .. 65536.

    Raises
    ------
    TypeError
        ``max_distance``, ``thickness``, ``step`` or ``bias`` is no real
        number (a bool, a complex number, an array, None, a string of no number).
    ValueError
        A value out of its range.
    """
    D = _number(max_distance, "max_distance")
    if not (np.isfinite(D) and D > 0):
        raise ValueError(f"max_distance must be a finite distance > 0 (world units), got {max_distance!r}")
    if D > FLOAT32_MAX:
        raise ValueError(f"max_distance must be at most {FLOAT32_MAX:.6g} (the march runs in float32 on the "
                         f"device), got {max_distance!r}")
    tau = 0.25 * D if thickness is None else _number(thickness, "thickness")
    if not (tau >= 0 and np.isfinite(tau)):
        raise ValueError(f"thickness must be >= 0 and finite, got {thickness!r}")
    if tau > FLOAT32_MAX:
        raise ValueError(f"thickness must be at most {FLOAT32_MAX:.6g} (the march runs in float32 on the "
                         f"device), got {thickness!r}")
    step = _number(step, "step")
    if not 0 < step <= 4:
        raise ValueError(f"step must be in (0, 4] texels, got {step!r}")
    bias = _number(bias, "bias")
    if not 0 <= bias < 0.1:
        raise ValueError(f"bias must be in [0, 0.1), got {bias!r}")
    if isinstance(max_steps, bool) or not isinstance(max_steps, (int, np.integer)) or not 1 <= max_steps <= 65536:
        raise ValueError(f"max_steps must be an int in 1..65536, got {max_steps!r}")
    return dict(max_distance=D, thickness=tau, step=step, bias=bias, max_steps=int(max_steps))


def _check_probe(probe):
    if not isinstance(probe, CubeProbe):
        raise TypeError(f"probe must be a pyshadow.cubemap.CubeProbe, got {type(probe).__name__}")


def _rays(probe, points, directions):
    """Points (N, 3) float64 and unit directions of rays: one 3-vector each or (N, 3) arrays of equal shape
    (another shape is not flattened into rows); any finite non-zero direction length is normalised."""
    p, w = np.asarray(points), np.asarray(directions)
    p, w = (a.reshape(1, 3) if a.shape == (3,) else a for a in (p, w))
    if p.ndim != 2 or p.shape[1:] != (3,) or p.shape != w.shape:
        raise ValueError(f"points and directions must both be (N, 3), got {p.shape} and {w.shape}")
    for a, name in ((p, "points"), (w, "directions")):
        if not (np.issubdtype(a.dtype, np.floating) or np.issubdtype(a.dtype, np.integer)):
            raise TypeError(f"{name} must be numeric, got {a.dtype}")
    p, w = p.astype(np.float64, copy=False), w.astype(np.float64, copy=False)
    if not (np.isfinite(p).all() and np.isfinite(w).all()):
        raise ValueError("points and directions must be finite")
    if not np.abs(w).max(axis=1, initial=0.0).all():
        raise ValueError("directions must be non-zero")
    far = ~(np.abs(p - probe.centre).max(axis=1, initial=0.0) <= FLOAT32_MAX)
    if far.any():
        i = int(np.argmax(far))
        raise ValueError(f"points: {int(far.sum())} rows lie beyond float32's range from the probe's centre "
                         f"{probe.centre.tolist()} (row {i}: {p[i].tolist()}; the march reads them relative to "
                         f"it in float32, at most {FLOAT32_MAX:.6g})")
    return p, unit_normals(w, len(w), "directions")


def _plane_offset(probe):
    """``n . (P - c)`` per texel, (6 R^2,) float64 (NaN where nothing is seen; ``P - c`` from the depth,
    :meth:`CubeProbe.texel_offsets`)."""
    return np.einsum("ij,ij->i", probe.normal.reshape(-1, 3).astype(np.float64), probe.texel_offsets())


def _surface_depth(probe, h, flat, u, grazing=GRAZING):
    """Depth of texels ``flat`` along unit directions ``u`` (K, 3): plane depth, else centre depth (where the
    plane depth is not > 0, or ``|n.u| < grazing``)."""
    n = probe.normal.reshape(-1, 3)[flat].astype(np.float64)
    den = np.einsum("ij,ij->i", n, u)
    zc = probe.depth.reshape(-1)[flat].astype(np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        zp = h[flat] / den
    return np.where((np.abs(den) >= grazing) & (zp > 0) & np.isfinite(zc) & np.isfinite(zp), zp, zc)


def raymarch_visible_reference(probe, points, directions, max_distance, **options) -> np.ndarray:
    """NumPy (float64) march of rays through a probe: the ``"raymarch"`` rule, cube map only.

    Parameters
    ----------
    probe : CubeProbe
    points : ndarray, shape (N, 3), float
        World ray origins, on surfaces the probe sees.
    directions : ndarray, shape (N, 3), float
        World ray directions (normalised here).
    max_distance : float
        ``D``, world units, > 0.
    **options
        ``thickness``, ``step``, ``bias``, ``max_steps`` (:func:`march_defaults`).

    Returns
    -------
    ndarray, shape (N,), bool
        True where no caster seen by the probe occludes the ray within ``D``
        (the ground plane is not tested here; see :func:`raymarch_visible`).
    """
    _check_probe(probe)
    opt = march_defaults(max_distance, **options)
    p, w = _rays(probe, points, directions)
    D, tau, R = opt["max_distance"], opt["thickness"], probe.resolution
    h = _plane_offset(probe)
    occ_flag = probe.occluder.reshape(-1)
    c = probe.centre
    M = len(p)
    occluded = np.zeros(M, bool)
    u = p - c
    r = np.linalg.norm(u, axis=1)
    uh = u / np.maximum(r, 1e-300)[:, None]
    t = np.zeros(M)
    alive = np.arange(M)
    min_step = D / opt["max_steps"]
    for _ in range(opt["max_steps"] + 1):
        if len(alive) == 0:
            break
        dt = np.maximum(opt["step"] * 2.0 * r[alive] / R, min_step)
        tn = np.minimum(t[alive] + dt, D)
        q = p[alive] + tn[:, None] * w[alive] - c
        rn = np.linalg.norm(q, axis=1)
        un = q / np.maximum(rn, 1e-300)[:, None]
        face, row, col, _x, _y = _direction_texels(un, R)
        flat = (face * R + row) * R + col
        z = _surface_depth(probe, h, flat, un, 0.0)        # un lies in the texel: its plane
        zprev = _surface_depth(probe, h, flat, uh[alive])
        b = opt["bias"] * rn
        behind = rn > z + b
        crossed = r[alive] <= zprev + b
        hit = occ_flag[flat] & behind & (crossed | (rn - z <= tau))
        occluded[alive[hit]] = True
        t[alive], r[alive], uh[alive] = tn, rn, un
        alive = alive[~(hit | (tn >= D))]
    return ~occluded


def raymarch_visible(probe, points, directions, max_distance, *, device: bool = True, **options) -> np.ndarray:
    """Rays through a probe by the ``"raymarch"`` rule, with the scene's ground plane.

    Parameters
    ----------
    probe : CubeProbe
    points, directions : ndarray, shape (N, 3), float
        World ray origins (on surfaces the probe sees) and directions.
    max_distance : float
        ``D``, world units, > 0.
    device : bool, optional
        March with the OpenCL kernel (``kernels/cubemap.cl``, float32);
        False: :func:`raymarch_visible_reference` (float64).
    **options
        ``thickness``, ``step``, ``bias``, ``max_steps`` (:func:`march_defaults`).

    Returns
    -------
    ndarray, shape (N,), bool
        True where the ray is unoccluded within ``D``: no caster in the
        probe's maps and not the ground plane (:func:`pyshadow.embree.ground_occludes`).
    """
    from ..embree import ground_occludes

    _check_probe(probe)
    device = flag(device, "device")         # ("no" was true: the device ran)
    opt = march_defaults(max_distance, **options)
    p, w = _rays(probe, points, directions)
    ground = ground_occludes(probe.scene, p, w, tmax=np.full(len(p), opt["max_distance"]))
    vis = np.zeros(len(p), bool)
    todo = np.flatnonzero(~ground)
    if len(todo):
        if device:
            from .device import raymarch_device
            vis[todo] = raymarch_device(probe, p[todo], w[todo], opt)
        else:
            vis[todo] = raymarch_visible_reference(probe, p[todo], w[todo], **opt)
    return vis


def texel_ao(probe, max_distance, *, estimator: str = "raymarch", sampling: Sampling | None = None,
             device: bool = True, directions: int = 12, steps: int = 16, **options) -> np.ndarray:
    """AO of every covered texel of a probe, (6, R, R) float32 (NaN where nothing is seen).

    Parameters
    ----------
    probe : CubeProbe
    max_distance : float
        ``D``, world units, > 0: occluders farther from the point do not count.
    estimator : {'raymarch', 'horizon'}
        See the module docstring.
    sampling : pyshadow.Sampling, optional
        ``"raymarch"``: the sample directions (default ``Sampling()``); texel
        ``(f, row, col)`` uses pattern index ``(f * R + row) * R + col``.
    device : bool, optional
        ``"raymarch"``: march on the OpenCL device (else NumPy).
    directions, steps : int, optional
        ``"horizon"``: image directions ``N_d`` (1..64) and steps per
        direction (1..256); defaults 12 and 16 (seed 002, 5.1.1 and Listing 4.14).
    **options
        ``"raymarch"``: ``thickness``, ``step``, ``bias``, ``max_steps``.

    Returns
    -------
    ndarray, shape (6, R, R), float32
        AO in [0, 1] (1 = open) of each texel's surface point (the probe's
        frame of faces, :mod:`pyshadow.cubemap.probe`); NaN where the texel
        sees nothing.

    Raises
    ------
    ValueError
        An unknown estimator or an invalid option (before any launch).
    """
    _check_probe(probe)
    if estimator not in ESTIMATORS:
        raise ValueError(f"estimator must be one of {ESTIMATORS}, got {estimator!r}")
    device = flag(device, "device")
    R = probe.resolution
    out = np.full(6 * R * R, np.nan, np.float32)
    if estimator == "horizon":
        horizon_defaults(**options)
        return horizon_ao_reference(probe, max_distance, directions=directions, steps=steps)
    sampling = Sampling() if sampling is None else sampling
    index, pts, nrm = probe.texel_points()
    # texels by batches of about TEXEL_RAYS rays: the rays of all at once took ~140 bytes each (1.4 GB at R = 256
    # with 36 samples, ~23 GB at R = 1024); each texel's answer is its own (pattern = texel index), the same
    step = max(1, TEXEL_RAYS // max(int(getattr(sampling, "samples", 1)), 1))
    for s in range(0, len(index), step):
        i, p, n = index[s:s + step], pts[s:s + step], nrm[s:s + step]
        dirs = sample_directions(n, sampling=sampling, indices=i).astype(np.float64)
        S = dirs.shape[1]
        vis = raymarch_visible(probe, np.repeat(p, S, axis=0), dirs.reshape(-1, 3), max_distance,
                               device=device, **options).reshape(-1, S)
        out[i] = ao_from_samples(dirs, vis, n)
    return out.reshape(6, R, R)


# ---------------------------------------------------------------------------
# the thesis's horizon estimator (eq. 4.4, Listing 4.14, section 4.3.2)
# ---------------------------------------------------------------------------
def _project_uv(frame, v):
    """Face-image uv in [0, 1] (u right, v down) of world vectors ``v`` from the centre; NaN behind."""
    fwd = v @ frame[2]
    with np.errstate(divide="ignore", invalid="ignore"):
        x = (v @ frame[0]) / fwd
        y = (v @ frame[1]) / fwd
    bad = ~(fwd > 0)
    return np.where(bad, np.nan, 0.5 * (x + 1.0)), np.where(bad, np.nan, 0.5 * (1.0 - y))


def horizon_defaults(directions=12, steps=16, **others) -> dict:
    """Validated options of the horizon estimator, as a dict: ``directions`` 1..64, ``steps`` 1..256
    (ValueError otherwise); any other option is a TypeError (the march's, e.g. ``thickness``)."""
    if others:
        raise TypeError(f"the horizon estimator takes no {', '.join(others)}")
    for name, val, hi in (("directions", directions, 64), ("steps", steps, 256)):
        if isinstance(val, bool) or not isinstance(val, (int, np.integer)) or not 1 <= val <= hi:
            raise ValueError(f"{name} must be an int in 1..{hi}, got {val!r}")
    return dict(directions=int(directions), steps=int(steps))


def horizon_ao_reference(probe, max_distance, *, directions: int = 12, steps: int = 16) -> np.ndarray:
    """The ``"horizon"`` estimator (module docstring) for every covered texel, (6, R, R) float32."""
    _check_probe(probe)
    D = march_defaults(max_distance)["max_distance"]
    horizon_defaults(directions, steps)
    R = probe.resolution
    out = np.full((6, R, R), np.nan, np.float32)
    theta = 2.0 * np.pi * np.arange(directions) / directions
    dirs2 = np.stack([np.cos(theta), np.sin(theta)], axis=1)            # (Nd, 2): +u right, +v down
    dw = D / steps
    for f in range(6):
        fr = _FRAMES[f]
        rows, cols = np.nonzero(np.isfinite(probe.depth[f]))
        if len(rows) == 0:
            continue
        off = probe.texel_offsets(np.arange(f * R * R, (f + 1) * R * R)).reshape(R, R, 3)  # from the depths
        P = off[rows, cols]                                             # relative to the centre
        n = probe.normal[f, rows, cols].astype(np.float64)
        n /= np.linalg.norm(n, axis=1, keepdims=True)
        uv = np.stack([(cols + 0.5) / R, (rows + 0.5) / R], axis=1)     # (K, 2)
        hmax = np.zeros((len(rows), directions))
        for i, d2 in enumerate(dirs2):
            # 4.3.2: the tangent-plane direction whose image runs along theta, one world step projected
            uv2 = uv + d2 / R
            ray = fr[2] + (2 * uv2[:, :1] - 1) * fr[0] + (1 - 2 * uv2[:, 1:]) * fr[1]
            with np.errstate(divide="ignore", invalid="ignore"):
                s = np.einsum("ij,ij->i", n, P) / np.einsum("ij,ij->i", n, ray)
                tang = s[:, None] * ray - P
                tang /= np.linalg.norm(tang, axis=1, keepdims=True)
            u1, v1 = _project_uv(fr, P + dw * tang)
            step_uv = np.hypot(u1 - uv[:, 0], v1 - uv[:, 1])
            ok = np.isfinite(step_uv) & (s > 0)
            for j in range(steps):
                e = uv + d2 * (1.0 / R + np.where(ok, step_uv, 0.0) * j)[:, None]
                inside = ok & (e >= 0).all(1) & (e <= 1).all(1)
                ok = inside                                             # Listing 4.14: break at the border
                er = np.clip(np.floor(e[:, 1] * R), 0, R - 1).astype(int)
                ec = np.clip(np.floor(e[:, 0] * R), 0, R - 1).astype(int)
                E = off[er, ec]
                En = probe.normal[f, er, ec].astype(np.float64)
                v = E - P
                dist = np.linalg.norm(v, axis=1)
                with np.errstate(divide="ignore", invalid="ignore"):
                    v /= dist[:, None]
                emit = probe.occluder[f, er, ec] | (probe.object_id[f, er, ec] == -2)
                use = inside & emit & (dist > 0) & (dist <= D) & (np.einsum("ij,ij->i", -v, En) >= 0)
                hd = np.where(use, np.einsum("ij,ij->i", n, np.nan_to_num(v)), 0.0)
                hmax[:, i] = np.maximum(hmax[:, i], hd)
        out[f, rows, cols] = 1.0 - np.mean(hmax ** 2, axis=1)
    return out

"""Parameters from the accuracy asked for: the cheapest CSM the error model says meets it, verified.

Cost is the CSM's size, the lasting price (build time grows with maps times
texels, query time barely depends on either): :func:`size_model` predicts
the bytes of every candidate from three small pilot builds (segments grow
as a power of the resolution and of the map count, both exponents measured
on the body). :func:`choose_csm` walks :data:`~pyshadow.csm.error_model.CANDIDATES`
from the smallest predicted size up, predicts each candidate's
disagreement with Embree (:func:`pyshadow.csm.error_model.predict`: the
body's own AO rays and the rays of bodies around it, the larger counts),
and builds the first predicted to meet the target (where none is, the
smallest of those predicted about as near as the one predicted nearest it,
announced first where its build is long; ``max_bytes`` caps the sizes
looked at). With ``verify`` (the default) the
built CSM is measured on rays drawn independently of the model's; where
it misses, the model's miss on this body (measured over predicted) is
carried to the remaining candidates and the walk goes on. Without it,
the prediction must meet the target widened by the model's
measured range (:data:`~pyshadow.csm.error_model.MODEL_RATIO`). Everything predicted, built and measured is returned
for ``csm.stats["choice"]``.
"""
from __future__ import annotations

import math
import numbers
import time
import warnings

import numpy as np

from .._progress import Steps
from .._validate import check_int
from ..mesh import check_mesh
from .core import _iend_dtype, _offsets_dtype
from .error_model import CANDIDATES, LARGE_WORK, MODEL_RATIO, _count, predict, rays_for
from .room import left_out_note, within_memory

__all__ = ["build_chosen", "choose_csm", "choose_within", "measure", "size_model", "PILOTS"]

#: the pilot builds of :func:`size_model`: (theta, phi, resolution)
PILOTS = ((16, 32, 64), (32, 64, 64), (16, 32, 128))

#: (seconds, bytes): a build for a target no candidate is predicted to meet, predicted to take either or more,
#: is announced before it starts (:func:`choose_csm`)
LONG_BUILD = (30.0, 2 ** 30)

#: where no candidate is predicted to meet the target, a smaller one is built in place of the one predicted nearest
#: it if predicted within this factor of it (and within its 95 % interval): the predictions of two candidates on the
#: same rays differ by less than their intervals say, so the interval alone kept candidates plainly worse
NEAR_ENOUGH = 1.1


def _work(cand) -> int:
    """Build work of candidate ``(theta, phi, resolution)``: maps times texels."""
    return cand[0] * cand[1] * cand[2] ** 2


def _keep(built, needed):
    """Let go of the CSMs in ``built`` that no candidate still to be looked at needs (the pilots, the misses):
    otherwise every rejected CSM stays held while the next, larger one is built."""
    for k in [k for k in built if k not in needed]:
        del built[k]


def _max_error(v) -> float:
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, numbers.Real):
        raise TypeError(f"max_error must be a float, got {v!r}")
    f = math.nan if isinstance(v, numbers.Integral) else float(v)       # no integer lies in (0, 1)
    if not 0.0 < f < 1.0:
        raise ValueError(f"max_error must lie in (0, 1), got {v!r}")
    return f


def _check_seed(seed) -> int:
    """The verification's seed: ``seed + 1`` as a Python int (a NumPy int32 at its top overflowed), past
    :data:`pyshadow.sampling.MAX_SEED` wrapping to 0 (``seed`` itself was a valid seed, refused as seed + 1)."""
    from ..sampling import MAX_SEED

    return (int(seed) + 1) % (MAX_SEED + 1)


def _max_bytes(v) -> int:
    if isinstance(v, (bool, np.bool_)) or not isinstance(v, numbers.Real):
        raise TypeError(f"max_bytes must be a number of bytes, got {v!r}")
    if not isinstance(v, numbers.Integral) and not math.isfinite(float(v)):
        raise ValueError(f"max_bytes must be finite, got {v!r}")
    n = int(v) if isinstance(v, numbers.Integral) else math.floor(float(v))
    if n < 1:
        raise ValueError(f"max_bytes must be positive (at least 1 byte), got {v!r}")
    return n


def _candidates(candidates, name):
    """``candidates`` as a tuple of ``(theta, phi, resolution)`` tuples of ints, checked before any ray is
    drawn or pilot built; ValueError naming ``name`` for none at all."""
    from ..raster import MAX_RESOLUTION

    out = []
    for c in candidates:
        try:
            triple = not isinstance(c, (str, bytes)) and len(c) == 3
        except TypeError:                       # no length: a number
            triple = False
        if not triple:
            raise ValueError(f"candidates must hold (theta, phi, resolution) triples, got {c!r}")
        out.append((check_int(c[0], "candidate theta", 1, 65536), check_int(c[1], "candidate phi", 1, 65536),
                    check_int(c[2], "candidate resolution", 1, MAX_RESOLUTION)))
    if not out:
        raise ValueError(f"{name} needs at least one candidate")
    return tuple(out)


def _upper(p) -> float:
    """The upper end of the 95 % interval of prediction ``p``'s disagreement (of the ray set that gives it); the
    disagreement itself where ``p`` has no interval."""
    sets = [v for v in p.values() if isinstance(v, dict) and "interval" in v and "disagreement" in v]
    top = max(sets, key=lambda v: v["disagreement"], default=None)
    return p["disagreement"] if top is None else max(p["disagreement"], float(top["interval"][1]))


def _announce(max_error, tried, entry, verify, fits, left_out):
    """Warn, before it starts, of a build for a target no candidate is predicted to meet that is predicted to take
    :data:`LONG_BUILD` seconds or bytes or more: what it is predicted to reach, what it costs, the most accurate
    prediction (and its cost) where that is another candidate that ``fits`` (the cap on bytes), the candidates
    ``left_out`` for memory."""
    sec, nbytes = entry["predicted_seconds"], entry["predicted_bytes"]
    if sec < LONG_BUILD[0] and nbytes < LONG_BUILD[1]:
        return
    p = entry["predicted"]
    warnings.warn(f"no candidate CSM is predicted to meet max_error={max_error:g}: building {p['layout']} "
                  f"({p['lookup']}), predicted {p['disagreement']:.4f}, about {_mb(nbytes)} and "
                  f"{sec:.0f} s{' before its check' if verify else ''}{_most_accurate(tried, entry, fits)}"
                  f"{_most_accurate(tried, entry, fits, 0.25, 'a quarter of the size or less')}"
                  f"{left_out_note(left_out)}; pyshadow.csm.choose_csm(..., max_bytes=) caps the size",
                  UserWarning, stacklevel=4)


def _most_accurate(tried, entry, fits, share=None, within="") -> str:
    """'; the most accurate predicted, ...': the candidate of ``tried`` not measured that ``fits`` the cap on bytes
    (one built past it does not: none predicted as large does), with the least predicted disagreement and its
    estimated cost, where that is less than ``entry``'s (with ``share``: of those at most ``share`` times its
    predicted bytes, where there is one); '' otherwise."""
    cap = math.inf if share is None else share * entry["predicted_bytes"]
    best = min((t for t in tried if "measured" not in t and fits(t) and t["predicted_bytes"] <= cap),
               key=lambda t: t["predicted"]["disagreement"], default=None)
    if best is None or (share is None and best["predicted"]["disagreement"] >= entry["predicted"]["disagreement"]):
        return ""
    b = best["predicted"]
    return (f"; the most accurate predicted{' at ' + within if within else ''}, {b['disagreement']:.4f}, is "
            f"{b['layout']} ({b['lookup']}, about {_mb(best['predicted_bytes'])} and "
            f"{best.get('predicted_seconds', 0.0):.0f} s to build)")


def _mb(nbytes) -> str:
    return f"{nbytes / 1e6:.0f} MB" if nbytes >= 1e7 else f"{nbytes / 1e6:.2g} MB"


def _nearest_target(tried, need, fits) -> int | None:
    """Index in ``tried`` of the candidate to build where none not built yet is predicted to meet the target:
    of those predicted as near as the one nearest the target (the least disagreement over ``need`` of its
    lookup, the target the walk still asks, narrowed by the misses measured), within :data:`NEAR_ENOUGH` times
    its disagreement and the upper end of its 95 % interval, the smallest by predicted bytes; the later of
    equals; None where no candidate not built yet ``fits`` (the cap on bytes)."""
    def shortfall(j, value=lambda p: p["disagreement"]):
        p = tried[j]["predicted"]
        # a target narrowed to 0 (the model predicted 0 and missed): ranked still by the disagreement, not all inf
        return value(p) / max(need[p["lookup"]], np.finfo(np.float64).tiny)
    todo = [j for j, t in enumerate(tried) if "bytes" not in t and fits(t)]
    if not todo:
        return None
    best = min(todo, key=lambda j: (shortfall(j), -j))
    reach = min(shortfall(best, _upper), NEAR_ENOUGH * shortfall(best))
    return min((j for j in todo if shortfall(j) <= reach or j == best),
               key=lambda j: (tried[j]["predicted_bytes"], -j))


def _layout(cand) -> str:
    """A candidate ``(theta, phi, resolution)`` as the error model names it: ``'16x32 r64'``."""
    return f"{cand[0]}x{cand[1]} r{cand[2]}"


def _build(mesh, cand, depth_bits, layers, progress, built):
    """The CSM of candidate ``(theta, phi, resolution)``, built once (``built`` keeps them)."""
    from ..views import ViewSet
    from .core import CoherentShadowMap

    if cand not in built:
        t0 = time.perf_counter()
        csm = CoherentShadowMap.build(mesh, ViewSet.zigzag(cand[0], cand[1]), resolution=cand[2],
                                      depth_bits=depth_bits, layers=layers, progress=progress)
        built[cand] = (csm, time.perf_counter() - t0)
    return built[cand]


def size_model(mesh, depth_bits: int = 16, layers="auto", built: dict | None = None):
    """Predicted bytes of a CSM of ``mesh`` for any (theta, phi, resolution), from :data:`PILOTS`.

    Segments ``S = S0 (R / 64)^a (D / 512)^g``, with ``a`` and ``g`` measured
    from the pilots (resolution doubled, maps quadrupled); bytes are the
    segments times their stored size (the depth, and the map index: 2 bytes,
    4 beyond 65,536 maps) plus the offset table (``R^2 + 1`` entries of 4
    bytes, 8 from 2^32 segments on).

    Returns
    -------
    predict : callable
        ``predict(theta, phi, resolution) -> bytes`` (float).
    info : dict
        ``a``, ``g``, ``segments0``, the pilots' build seconds and
        ``seconds_per_work``: the least of theirs per map x texel, what a
        candidate's build time is estimated from (``predicted_seconds`` in a
        choice's ``tried``; within a factor 2-3 where other work shares the
        device).
    """
    built = {} if built is None else built
    pil = [_build(mesh, c, depth_bits, layers, False, built) for c in PILOTS]
    s0, s_maps, s_res = (max(c.segments, 1) for c, _ in pil)
    a = float(np.log2(s_res / s0))
    g = float(np.log(s_maps / s0) / np.log(4.0))
    depth = pil[0][0].depth.itemsize

    def predict(theta, phi, resolution):
        seg = s0 * (resolution / 64.0) ** a * (theta * phi / 512.0) ** g
        # as the candidate stores them, not as the pilots (<= 2048 maps) do: a segment's map index takes
        # 32 bits beyond 65,536 maps, an offset 64 bits from 2^32 segments on
        return float(seg * (depth + _iend_dtype(theta * phi).itemsize)
                     + (resolution * resolution + 1) * _offsets_dtype(seg).itemsize)
    # the pilot with the least fixed cost (the first build's compiling, small ones' launches) per unit of work
    return predict, {"a": a, "g": g, "segments0": int(s0), "pilot_seconds": sum(t for _, t in pil),
                     "seconds_per_work": min(t / _work(c) for c, (_, t) in zip(PILOTS, pil))}


def measure(csm, mesh, rays: dict, lookup: str = "nearest") -> dict:
    """Disagreement of a built CSM with Embree on :func:`~pyshadow.csm.error_model.rays_for` rays.

    The CSM alone in a scene (identity transform, no ground), queried by
    :meth:`pyshadow.Scene.visible` (the kernel): own AO rays as rays from
    its surface with their normals, near rays as rays from elsewhere.

    Returns
    -------
    dict
        Per ray set ``disagreement``, ``interval``, ``rays``; ``disagreement``
        at the top: the larger.
    """
    from ..scene import GROUND_ID, Scene

    scene = Scene()
    scene.add(csm, np.eye(4), mesh=mesh)
    out = {}
    for name, r in rays.items():
        own = r["n"] is not None
        ids = np.full(len(r["p"]), 0 if own else GROUND_ID, np.int64)
        ours = scene.visible(r["p"], r["d"], surface_ids=ids, normals=r["n"] if own else None, lookup=lookup)
        out[name] = _count(r["truth"], ours, r["w"], r.get("group", 1))
    out["disagreement"] = max(out[name]["disagreement"] for name in rays)
    return out


def choose_csm(mesh, max_error: float, *, lookup: str = "nearest", depth_bits: int = 16, layers="auto",
               verify: bool = True, points: int = 2000, samples: int = 16, near: int = 16000, seed: int = 7,
               progress: bool = False, candidates=CANDIDATES, max_bytes: int | None = None):
    """The cheapest CSM of ``mesh`` predicted (and, with ``verify``, measured) to meet ``max_error``.

    Parameters
    ----------
    mesh : trimesh.Trimesh
    max_error : float
        Largest share of rays, in (0, 1), the CSM may answer unlike Embree:
        on the body's own AO rays and on rays of bodies around it.
    lookup : {'nearest', 'vote', 'auto'}
        The lookup the CSM will be queried with; ``'auto'``: the one-texel
        lookup where a candidate meets the target with it, else the vote
        (4 maps x 4 texels, about 3.5x the query time): every one-texel
        candidate is looked at first. ``choice["lookup"]`` says which to
        query with.
    depth_bits : {16, 32}
    layers : {'auto', 2, 3}
        As :meth:`CoherentShadowMap.build`.
    verify : bool
        Measure the built CSM against Embree on independent rays and go on
        up the candidates where it misses.
    points, samples, near, seed : int
        The rays of :func:`~pyshadow.csm.error_model.rays_for` (the model's
        with ``seed``, the verification's with ``seed + 1``, 0 past the largest seed).
    progress : bool
    candidates : sequence of (theta, phi, resolution)
        Tried by increasing predicted size (:func:`size_model`); those above
        :data:`~pyshadow.csm.error_model.LARGE_WORK` maps x texels only after
        every other candidate has missed with every lookup.
    max_bytes : int, optional
        A cap on the CSM's size, bytes: candidates predicted
        (:func:`size_model`, within about 15 %) above it are never built,
        and one built larger is not kept: the walk goes on among those
        predicted smaller than it. Whatever the cap, candidates predicted to
        need more memory than is free are not tried (:mod:`pyshadow.csm.room`).

    Returns
    -------
    csm : CoherentShadowMap
        The choice; when none meets the target, the last built (within ``max_bytes``), with a ``UserWarning``: where no
        candidate left is predicted to meet it, the smallest of those predicted as near as the one
        predicted nearest it (its disagreement over the target, narrowed by the misses measured;
        within :data:`NEAR_ENOUGH` times that one's and its 95 % interval), not the last by predicted
        size. A build predicted to take :data:`LONG_BUILD` seconds or bytes or more for a target no
        candidate is predicted to meet is announced before it starts (a ``UserWarning``: the accuracy
        predicted, the estimated cost, the most accurate candidate a quarter its size or less).
    choice : dict
        ``target``, ``lookup`` (the one chosen), ``met``, ``verified``, ``maps``,
        ``resolution``, ``depth_bits``, ``predicted`` (the model's record),
        ``measured`` (or None), ``tried`` (every candidate looked at:
        prediction, predicted bytes and build seconds (estimated from the
        pilots), and bytes, build seconds and measurement where built;
        ``over_budget`` True where built past ``max_bytes``),
        ``size_model``, ``seconds`` (model, pilots, builds and checks
        together), ``left_out_for_memory`` (:func:`~pyshadow.csm.room.within_memory`).

    Raises
    ------
    ValueError
        ``max_error`` outside (0, 1) or NaN; no candidate predicted within ``max_bytes`` (the message gives
        the smallest predicted size), or none built within it; a mesh :func:`pyshadow.mesh.check_mesh`
        refuses (no triangles, a vertex not finite, a face index outside the vertices).
    MemoryError
        No candidate predicted to fit in the memory free.
    """
    with Steps(progress, "CSM choice") as note:
        return _choose_csm(note, mesh, max_error, lookup=lookup, depth_bits=depth_bits, layers=layers,
                           verify=verify, points=points, samples=samples, near=near, seed=seed,
                           progress=progress, candidates=candidates, max_bytes=max_bytes)


def _choose_csm(note, mesh, max_error, *, lookup, depth_bits, layers, verify, points, samples, near, seed,
                progress, candidates, max_bytes):
    """:func:`choose_csm`, each step named by ``note``."""
    check_mesh(mesh, "choose_csm")       # before the rays are drawn: a face past the vertices was IndexError
    max_error = _max_error(max_error)
    if lookup not in ("nearest", "vote", "auto"):
        raise ValueError(f"lookup must be 'nearest', 'vote' or 'auto', got {lookup!r}")
    candidates = _candidates(candidates, "choose_csm")
    max_bytes = None if max_bytes is None else _max_bytes(max_bytes)
    t0 = time.perf_counter()
    draw = dict(points=points, samples=samples, near=near)
    note("rays of the error model")
    rays = rays_for(mesh, seed=seed, **draw)
    check = rays_for(mesh, seed=_check_seed(seed), **draw) if verify else None
    built = {}
    note("pilot builds")
    size, size_info = size_model(mesh, depth_bits, layers, built)
    if max_bytes is not None:
        small = min(size(*c) for c in candidates)
        candidates = [c for c in candidates if size(*c) <= max_bytes]
        if not candidates:
            raise ValueError(f"no candidate CSM fits in max_bytes={max_bytes} (the smallest is predicted at "
                             f"{small:.0f} bytes)")
    candidates, left_out = within_memory(candidates, size, verify, "choose_csm", _layout)
    lookups = ("nearest", "vote") if lookup == "auto" else (lookup,)
    # by predicted size, every lookup's; a layout above LARGE_WORK only after every smaller one of every lookup
    ranked = sorted(candidates, key=lambda c: (size(*c), c[0] * c[1] * c[2] ** 2))
    tiers = ([c for c in ranked if _work(c) <= LARGE_WORK], [c for c in ranked if _work(c) > LARGE_WORK])
    order = [(c, lk) for tier in tiers for lk in lookups for c in tier]
    # with the check, the central prediction decides what to build first (a miss costs a build, the
    # check catches it); without, the prediction widened by the model's measured range
    need = dict.fromkeys(lookups, max_error / (1.0 if verify else MODEL_RATIO[1]))
    tried, csm, entry, kept, i = [], None, None, None, 0
    over = math.inf             # the least predicted size of those built past max_bytes: none predicted larger fits
    fits = (lambda t: True) if max_bytes is None else (lambda t: t["predicted_bytes"] < over)
    while True:
        if i < len(order):
            (cand, lk), i = order[i], i + 1
            note(f"predict {_layout(cand)} ({lk})")
            pred = predict(mesh, cand[:2], cand[2], depth_bits, lk, rays=rays)
            entry = {"predicted": pred, "predicted_bytes": size(*cand), "candidate": (cand, lk),
                     "predicted_seconds": size_info.get("seconds_per_work", 0.0) * _work(cand)}
            tried.append(entry)
            if pred["disagreement"] > need[lk] or not fits(entry):
                if i < len(order):
                    continue
                entry = None
        if entry is None:
            # the last misses too: the smallest predicted about as near as the one predicted nearest the target
            j = _nearest_target(tried, need, fits)
            if j is None:
                break
            entry = tried[j]
            cand, lk = entry["candidate"]
            if cand not in built:
                _announce(max_error, tried, entry, verify, fits, left_out)
        _keep(built, {c for c, _ in order[i - 1:]} | {cand})
        if max_bytes is None:
            csm = None                 # the last miss: not held while the next one is built
        # (with a cap, the last CSM within it is held, at most max_bytes, in case every later one is built past it)
        note(f"build {_layout(cand)}")
        new, seconds = _build(mesh, cand, depth_bits, layers, progress, built)     # one CSM serves both lookups
        entry.update(bytes=new.stats["bytes"], build_seconds=seconds)
        if max_bytes is not None and entry["bytes"] > max_bytes:       # the size model under-predicted this body
            over, entry["over_budget"] = min(over, entry["predicted_bytes"]), True
            del new, built[cand]
            entry = None                # the next candidate, or where none is left the nearest within the cap
            continue
        csm, kept = new, entry
        del new                         # csm alone holds it
        if not verify:
            break
        note(f"verify {_layout(cand)} ({lk})")
        entry["measured"] = measure(csm, mesh, check, lk)
        got = entry["measured"]["disagreement"]
        if got <= max_error:
            break
        if entry["predicted"]["disagreement"] > 0:  # the model missed by got / predicted here: ask that much more
            need[lk] = min(need[lk], max_error * entry["predicted"]["disagreement"] / got)
        else:
            need[lk] = 0.0
        if i == len(order):
            break
    for t in tried:
        t.pop("candidate")
    if csm is None:             # every candidate predicted within max_bytes was built larger
        least = min((t for t in tried if "bytes" in t), key=lambda t: t["bytes"])
        raise ValueError(f"no candidate CSM fits in max_bytes={max_bytes}: each one built came out larger (none "
                         f"predicted as large as one that did is built); the smallest built, "
                         f"{least['predicted']['layout']}, takes {least['bytes']} bytes")
    entry = kept
    p = entry["predicted"]
    # unverified: met by the walk's own test (the prediction against the target narrowed by the model's range)
    met = entry["measured"]["disagreement"] <= max_error if verify else p["disagreement"] <= need[p["lookup"]]
    if not met:
        if verify:
            got = f"measured {entry['measured']['disagreement']:.4f}"
            best = min((t for t in tried if "measured" in t), key=lambda t: t["measured"]["disagreement"])
            if best is not entry:
                got += (f"; the lowest measured, {best['measured']['disagreement']:.4f}, was "
                        f"{best['predicted']['layout']} ({best['predicted']['lookup']})")
        else:
            got = (f"predicted {p['disagreement']:.4f}, up to {p['disagreement'] * MODEL_RATIO[1]:.4f} "
                   "with the model's range")
        warnings.warn(f"no candidate CSM meets max_error={max_error:g}; keeping the last built, {p['layout']} "
                      f"({p['lookup']}): {got}{_most_accurate(tried, entry, fits)}{left_out_note(left_out)}",
                      UserWarning, stacklevel=4)
    return csm, {"target": max_error, "lookup": p["lookup"], "met": bool(met), "verified": bool(verify),
                 "maps": p["maps"], "resolution": p["resolution"], "depth_bits": p["depth_bits"],
                 "predicted": p, "measured": entry.get("measured"), "tried": tried, "size_model": size_info,
                 "seconds": time.perf_counter() - t0, "left_out_for_memory": left_out}


def choose_within(mesh, max_bytes: int, *, lookup: str = "nearest", depth_bits: int = 16, layers="auto",
                  verify: bool = True, points: int = 2000, samples: int = 16, near: int = 16000, seed: int = 7,
                  progress: bool = False, candidates=CANDIDATES):
    """The other direction: the most accurate CSM of ``mesh`` that fits in ``max_bytes``.

    Every candidate's disagreement is predicted (the error model) and its
    size too (:func:`size_model`); the candidates that fit are built from
    the most accurate prediction down until one's actual size fits.

    Parameters
    ----------
    mesh : trimesh.Trimesh
    max_bytes : int
        Largest ``csm.stats["bytes"]`` allowed.
    lookup : {'nearest', 'vote', 'auto'}
        As :func:`choose_csm`; ``'auto'``: every candidate predicted with both lookups, and the most accurate
        (candidate, lookup) pair that fits taken (one-texel on a tie); ``choice["lookup"]`` says which.
    depth_bits, layers, verify, points, samples, near, seed, progress, candidates :
        As :func:`choose_csm`; ``verify`` measures the result (reported only).

    Returns
    -------
    csm : CoherentShadowMap
    choice : dict
        As :func:`choose_csm`, with ``budget_bytes`` instead of ``target``.

    Raises
    ------
    ValueError
        If no candidate fits (the message gives the smallest predicted size, or, where those predicted to
        fit were built larger, the smallest built); ``max_bytes`` below 1 or not finite.
    MemoryError
        No candidate predicted to fit in the memory free (:mod:`pyshadow.csm.room`).
    TypeError
        ``max_bytes`` not a real number (a bool or a string).
    """
    with Steps(progress, "CSM choice") as note:
        return _choose_within(note, mesh, max_bytes, lookup=lookup, depth_bits=depth_bits, layers=layers,
                              verify=verify, points=points, samples=samples, near=near, seed=seed,
                              progress=progress, candidates=candidates)


def _choose_within(note, mesh, max_bytes, *, lookup, depth_bits, layers, verify, points, samples, near, seed,
                   progress, candidates):
    """:func:`choose_within`, each step named by ``note``."""
    check_mesh(mesh, "choose_within")
    max_bytes = _max_bytes(max_bytes)
    if lookup not in ("nearest", "vote", "auto"):
        raise ValueError(f"lookup must be 'nearest', 'vote' or 'auto', got {lookup!r}")
    candidates = _candidates(candidates, "choose_within")
    lookups = ("nearest", "vote") if lookup == "auto" else (lookup,)
    t0 = time.perf_counter()
    draw = dict(points=points, samples=samples, near=near)
    note("rays of the error model")
    rays = rays_for(mesh, seed=seed, **draw)
    built = {}
    note("pilot builds")
    size, size_info = size_model(mesh, depth_bits, layers, built)
    candidates, left_out = within_memory(candidates, size, verify, "choose_within", _layout)
    tried = []
    for c in candidates:
        for lk in lookups:
            note(f"predict {_layout(c)} ({lk})")
            tried.append({"candidate": c, "predicted": predict(mesh, c[:2], c[2], depth_bits, lk, rays=rays),
                          "predicted_bytes": size(*c)})
    # the most accurate first; of equals the smaller, then the one-texel lookup (the faster query)
    fits = sorted((t for t in tried if t["predicted_bytes"] <= max_bytes),
                  key=lambda t: (t["predicted"]["disagreement"], t["predicted_bytes"],
                                 t["predicted"]["lookup"] != "nearest"))
    csm = entry = None
    past = {}                   # candidate -> its bytes, built past max_bytes: its other lookup is not built again
    for j, entry in enumerate(fits):
        if entry["candidate"] in past:
            entry["bytes"] = past[entry["candidate"]]
            continue
        _keep(built, {t["candidate"] for t in fits[j:]} - set(past))
        c = None
        note(f"build {_layout(entry['candidate'])}")
        c, seconds = _build(mesh, entry["candidate"], depth_bits, layers, progress, built)
        entry.update(bytes=c.stats["bytes"], build_seconds=seconds)
        if c.stats["bytes"] <= max_bytes:
            csm = c
            break
        past[entry["candidate"]] = c.stats["bytes"]
    if csm is None:
        small = min(t["predicted_bytes"] for t in tried)
        why = f"the smallest is predicted at {small:.0f} bytes"
        if fits:        # predicted to fit (the prediction is within about 15 %), built larger: not 'predicted above'
            least = min(fits, key=lambda t: t["bytes"])
            why = (f"{len(fits)} candidate{'s' if len(fits) > 1 else ''} predicted to fit "
                   f"{'were' if len(fits) > 1 else 'was'} built larger; the smallest built, "
                   f"{least['predicted']['layout']}, takes {least['bytes']} bytes")
        raise ValueError(f"no candidate CSM fits in {max_bytes} bytes ({why})")
    p = entry["predicted"]
    if verify:
        note(f"verify {_layout(entry['candidate'])} ({p['lookup']})")
        entry["measured"] = measure(csm, mesh, rays_for(mesh, seed=_check_seed(seed), **draw), p["lookup"])
    for t in tried:
        t.pop("candidate")
    return csm, {"budget_bytes": max_bytes, "lookup": p["lookup"], "verified": bool(verify),
                 "maps": p["maps"], "resolution": p["resolution"], "depth_bits": p["depth_bits"],
                 "predicted": p, "measured": entry.get("measured"), "tried": tried, "size_model": size_info,
                 "seconds": time.perf_counter() - t0, "left_out_for_memory": left_out}


def build_chosen(mesh, views, resolution, frame, footprint, two_sided, *, max_error, max_bytes, lookup, depth_bits,
                 layers, verify, progress):
    """:meth:`CoherentShadowMap.build` with ``max_error``, ``max_bytes`` or both (the cheapest meeting ``max_error``
    within ``max_bytes``: :func:`choose_csm`'s cap): the chosen CSM, ``choice`` set."""
    from ..mesh import load_mesh
    from .exposure import is_auto

    if views is not None or resolution is not None or frame is not None or footprint or not is_auto(two_sided):
        raise TypeError("CoherentShadowMap.build: max_error and max_bytes choose views and resolution; "
                        "leave out views, resolution, frame, footprint and two_sided")
    mesh = mesh if hasattr(mesh, "faces") else load_mesh(mesh)
    check_mesh(mesh, "CoherentShadowMap.build")     # as the build without max_error names what is wrong
    kw = dict(lookup=lookup, depth_bits=depth_bits, layers=layers, verify=verify, progress=progress)
    csm, choice = (choose_csm(mesh, max_error, max_bytes=max_bytes, **kw) if max_error is not None
                   else choose_within(mesh, max_bytes, **kw))
    csm.choice = choice
    return csm


def warn_unchosen_lookup(scene, lookup: str) -> None:
    """A UserWarning where a caster's CSM was chosen for an accuracy (``max_error``, or the most accurate within
    ``max_bytes``) with the other lookup than ``lookup``, the one a query asks (``lookup="auto"`` may choose the vote;
    queries ask ``"nearest"`` unless told): the accuracy chosen holds for its own lookup only. Asked once
    per scene change and lookup (:class:`pyshadow.visibility.CSMVisibility`)."""
    for csm in scene.caster_types()[0]:
        choice = getattr(csm, "choice", None) or {}
        if ("target" in choice or "budget_bytes" in choice) and choice.get("lookup", lookup) != lookup:
            why = (f"max_error={choice['target']:g}" if "target" in choice
                   else f"its accuracy within max_bytes={choice['budget_bytes']}")
            warnings.warn(f"a CSM of this scene was chosen for {why} with "
                          f"lookup={choice['lookup']!r}; this query asks lookup={lookup!r}, whose error the choice "
                          f"did not measure: pass lookup={choice['lookup']!r} to the query", UserWarning, stacklevel=2)
            return

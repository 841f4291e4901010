"""``pyshadow-bench --light``: one light's hard shadows, the CSM against the classic shadow map.

The light (:func:`parse_light`):

``sun``
    A directional light from the direction of ``--sky clear``'s sun
    (:data:`pyshadow.bench.lit.CLEAR_SUN`: 57.5 deg above the horizon).
``sun:AZIMUTH,ELEVATION``
    A directional light from that azimuth and elevation, degrees
    (azimuth 0 along +x, 90 along +z; elevation above the ``y = 0`` plane).
``point``
    A point light placed from the scene's geometry: at ``c + 1.5 R u`` with
    ``(c, R)`` the sphere holding every caster's world bounding sphere and
    ``u`` the ``sun`` direction, so it lies outside every caster's sphere
    (the case a CSM answers exactly) whatever the meshes.
``point:X,Y,Z``
    A point light at that world position (refused when it lies inside a
    caster's bounding sphere: :mod:`pyshadow.visibility.finite`).

The pass (:func:`light_pass`) takes the covered pixels whose normal faces the
light (``n . l >= 0.1``: :data:`MIN_COSINE`) and asks each method for the
visibility of the light from every one of them, on identical rays (to the
light's position for a point light: ``max_distance`` = the distance):

* ``csm`` and ``csm-vote``: the visibility kernel (one-texel and vote lookups);
* ``shadow-map R`` at equal memory: the classic scene shadow map
  (:class:`pyshadow.lighting.ShadowMapVisibility`, hard lookup, its bias
  rule) whose float32 texels take as many bytes as the scene's CSMs (one
  R x R map for a sun, six R x R faces for a point light; R at most
  8192, the largest a shadow map takes), and the common 1024 x 1024 (per
  face) beside it.

Each is compared with Embree on the same rays (agreement, and the share of
rays wrongly shadowed and wrongly lit). Time per frame (medians of
``--repeats`` interleaved rounds, each a few frames): *moving*, one
:meth:`Scene.set_transform` of the first caster (a turn about its own
vertical axis) before every query, so the shadow map renders again while the
CSM redoes nothing (a shadow map's kept maps are forgotten, untimed, before
each moving frame: the turn revisits its poses); *static*, the query alone.
The G-buffer stays the first frame's (the same points for every method: only
the light's part is timed).
``shadow.png`` shows the pixels: lit (grey by n.l), shadowed (dark blue), and
where the one-texel CSM disagrees with Embree (red: wrongly shadowed; yellow:
wrongly lit); covered pixels facing away from the light are dark grey.
"""
from __future__ import annotations

import math
import statistics
import time
from pathlib import Path

import numpy as np

from .common import _bar, _fig, _num

#: Pixels whose normal has at least this cosine towards the light are measured.
MIN_COSINE = 0.1
#: Shadow-map resolution shown beside the equal-memory one.
COMMON_RESOLUTION = 1024
#: The moving caster turns by this angle (deg) a frame about its vertical axis.
TURN_DEG = 3.0
#: Frames a timing round.
FRAMES_PER_ROUND = 4


def _numbers(text, n, what):
    parts = text.split(",")
    try:
        vals = [float(x) for x in parts]
    except ValueError:
        vals = []
    if len(vals) != n or not all(math.isfinite(v) for v in vals):
        raise ValueError(f"--light {what}: expected {n} comma-separated finite numbers (got {text!r})")
    return vals


def parse_light(spec: str) -> dict:
    """The ``--light`` value as ``{"kind": "sun"|"point", "direction"|"position": ..., "spec": spec}``.

    ``position`` is None for ``point`` alone (placed by :func:`place_light` once the scene exists).

    Raises
    ------
    ValueError
        Not one of the forms in the module docstring, or an elevation outside (0, 90].
    """
    from .lit import CLEAR_SUN

    kind, _, rest = str(spec).partition(":")
    if kind == "sun":
        if not rest:
            from ..lighting import sun_position

            d = np.asarray(sun_position(**CLEAR_SUN), np.float64)
        else:
            az, el = _numbers(rest, 2, "sun:AZIMUTH,ELEVATION")
            if not 0.0 < el <= 90.0:
                raise ValueError(f"--light sun: elevation must lie in (0, 90] degrees (got {el})")
            a, e = math.radians(az), math.radians(el)
            d = np.array([math.cos(e) * math.cos(a), math.sin(e), math.cos(e) * math.sin(a)])
        return {"kind": "sun", "direction": d / np.linalg.norm(d), "spec": spec}
    if kind == "point":
        pos = None if not rest else np.asarray(_numbers(rest, 3, "point:X,Y,Z"), np.float64)
        return {"kind": "point", "position": pos, "spec": spec}
    raise ValueError(f"--light: expected sun, sun:AZIMUTH,ELEVATION, point or point:X,Y,Z (got {spec!r})")


def place_light(light: dict, scene) -> dict:
    """``light`` with a point light's default position filled in (module docstring); checks it is outside
    every caster's bounding sphere."""
    if light["kind"] != "point":
        return light
    spheres = [scene.instances[i].world_sphere() for i in scene.casters]
    if light["position"] is None:
        from .lit import CLEAR_SUN
        from ..lighting import sun_position

        if spheres:
            c = np.mean([s[0] for s in spheres], axis=0)
            R = max(np.linalg.norm(s[0] - c) + s[1] for s in spheres)
        else:
            c, R = np.zeros(3), 1.0
        light = {**light, "position": c + 1.5 * R * np.asarray(sun_position(**CLEAR_SUN), np.float64)}
    for i, (c, r) in zip(scene.casters, spheres):
        if np.linalg.norm(light["position"] - c) <= r:
            raise ValueError(f"--light {light['spec']}: the light lies inside caster {i}'s bounding sphere "
                             f"(centre {np.round(c, 3).tolist()}, radius {r:.3f}), where a CSM cannot answer")
    return light


def _facing(light, sp):
    """Rays, distances (None for a sun), unit normals and the mask of ``sp``'s pixels facing the light."""
    n = np.asarray(sp.normals, np.float64)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    w, t = _rays(light, sp.points, n)
    nl = np.einsum("ij,ij->i", n, w)
    return w, t, n, nl, nl >= MIN_COSINE


def check_light(light: dict, scene, camera) -> dict:
    """``light`` placed (:func:`place_light`) once it is known to be measurable on this scene and camera.

    Called before the benchmark's other work, so that a light it cannot
    measure ends the run before any output is written.

    Raises
    ------
    ValueError
        The light lies inside a caster's bounding sphere, or no covered pixel
        faces it (``n . l >=`` :data:`MIN_COSINE`); the message names ``--light``.
    """
    import pyshadow

    with np.errstate(all="ignore"):             # a far light: distances may overflow (no pixel faces it then)
        light = place_light(light, scene)
        sel = _facing(light, pyshadow.render.surface_points(scene, camera))[4]
    if not sel.any():
        raise ValueError(f"--light {light['spec']}: no covered pixel faces the light (n.l >= {MIN_COSINE})")
    return light


def _rays(light, points, normals):
    if light["kind"] == "sun":
        w = np.broadcast_to(light["direction"], points.shape)
        return np.ascontiguousarray(w), None
    d = light["position"] - points
    t = np.linalg.norm(d, axis=1)
    return d / t[:, None], t


def _turned(T, centre, deg):
    R = np.eye(4)
    a = math.radians(deg)
    R[0, 0], R[0, 2], R[2, 0], R[2, 2] = math.cos(a), math.sin(a), -math.sin(a), math.cos(a)
    M = np.eye(4)
    M[:3, 3] = centre
    Mi = np.eye(4)
    Mi[:3, 3] = -centre
    return M @ R @ Mi @ T


def shadow_image(camera, covered_index, sel_index, nl, lit, truth) -> np.ndarray:
    """``shadow.png``: (H, W, 3) uint8 (module docstring; covered pixels facing away: dark grey)."""
    img = np.zeros((camera.height * camera.width, 3), np.uint8)
    img[covered_index] = 45
    g = np.clip(60 + 180 * nl, 0, 255).astype(np.uint8)
    img[sel_index] = np.where(truth[:, None], np.stack([g, g, g], axis=1), np.array([20, 30, 90], np.uint8))
    img[sel_index[~lit & truth]] = (230, 30, 30)
    img[sel_index[lit & ~truth]] = (240, 220, 30)
    return img.reshape(camera.height, camera.width, 3)


def light_pass(args, scene, camera, csm_bytes: int, light: dict, out_dir: Path, log) -> tuple:
    """Measure the light's shadows by every method (module docstring).

    Returns
    -------
    record : dict
        The ``"light"`` entry of ``results.json``.
    files : dict
        ``shadow.png`` and its path.
    """
    import pyshadow
    from .. import embree, visibility
    from ..lighting import ShadowMapVisibility
    from ..lighting.shadow_map import MAX_RESOLUTION, MIN_RESOLUTION

    light = place_light(light, scene)
    sp = pyshadow.render.surface_points(scene, camera)
    w, t, n, nl, sel = _facing(light, sp)
    P, W, N, ids = sp.points[sel], w[sel], n[sel], sp.surface_ids[sel]
    T = None if t is None else t[sel]
    if not len(P):
        raise RuntimeError(f"--light {light['spec']}: no covered pixel faces the light (n.l >= {MIN_COSINE})")
    truth = embree.visible(scene, P, W, max_distance=T)
    faces = 1 if light["kind"] == "sun" else 6
    equal = min(MAX_RESOLUTION, max(MIN_RESOLUTION, int(math.sqrt(csm_bytes / (4 * faces)))))
    methods = {"csm": "csm", "csm-vote": "csm-vote",
               f"shadow-map {equal}": ShadowMapVisibility(equal),
               f"shadow-map {COMMON_RESOLUTION}": ShadowMapVisibility(COMMON_RESOLUTION)}
    log(f"light: {light['kind']} ({light['spec']}), {len(P)} pixels facing it; methods {', '.join(methods)}")

    def ask(backend):
        return visibility.visible(scene, P, W, max_distance=T, backend=backend, surface_ids=ids, normals=N)

    answers = {m: ask(b) for m, b in methods.items()}        # also the warm-up (kernel builds, first renders)
    mover = scene.casters[0] if scene.casters else None
    T0 = None if mover is None else scene.instances[mover].transform.copy()
    centre = None if mover is None else scene.instances[mover].world_sphere()[0]
    moving = {m: [] for m in methods}
    static = {m: [] for m in methods}
    repeats = max(1, int(args.repeats))
    bar = _bar(repeats, "timing light queries", "round")
    frame = 0
    try:
        for _ in range(repeats):
            if mover is not None:
                scene.set_transform(mover, T0)
            for m, b in methods.items():
                ask(b)                      # untimed: a shadow map renders for the unmoved scene
                t0 = time.perf_counter()
                ask(b)
                static[m].append(time.perf_counter() - t0)
            for m, b in methods.items():
                if mover is None:
                    continue
                for _ in range(FRAMES_PER_ROUND):
                    frame += 1
                    if not isinstance(b, str):      # the turn revisits its poses: a map kept from an earlier
                        b.clear()                   # one would answer without rendering (cleared untimed)
                    t0 = time.perf_counter()
                    scene.set_transform(mover, _turned(T0, centre, TURN_DEG * (frame % 7 - 3)))
                    ask(b)
                    moving[m].append(time.perf_counter() - t0)
            bar.update(1)
    finally:
        bar.close()
        if mover is not None:
            scene.set_transform(mover, T0)
    rows = {}
    for m, b in methods.items():
        v = answers[m]
        nbytes = csm_bytes if isinstance(b, str) else int(
            b.shadow_map(scene, **({"direction": light["direction"]} if light["kind"] == "sun"
                                   else {"position": light["position"]})).nbytes)
        rows[m] = {
            "agreement": _fig(float(np.mean(v == truth)), "fraction", "rays on which the method and Embree agree"),
            "false_shadow": _fig(float(np.mean(~v & truth)), "fraction", "rays wrongly shadowed"),
            "false_lit": _fig(float(np.mean(v & ~truth)), "fraction", "rays wrongly lit"),
            "bytes": _fig(nbytes, "B", "memory the method keeps (CSMs of the caster types; the depth map)"),
            "frame_time_moving": _fig(statistics.median(moving[m]) if moving[m] else None, "s",
                                      "set_transform of one caster + the light query of every pixel (median)"),
            "frame_time_static": _fig(statistics.median(static[m]), "s", "the light query alone (median)"),
        }
    img = shadow_image(camera, sp.index, sp.index[sel], nl[sel], answers["csm"], truth)
    pyshadow.write_image(out_dir / "shadow.png", img)
    where = ({"direction": [float(x) for x in light["direction"]]} if light["kind"] == "sun"
             else {"position": [float(x) for x in light["position"]]})
    record = {"kind": light["kind"], "spec": light["spec"], **where, "pixels": int(len(P)),
              "shadowed": _fig(float(1 - truth.mean()), "fraction", "Embree: rays that do not reach the light"),
              "equal_memory_resolution": equal, "moving_instance": mover, "methods": rows}
    return record, {"shadow.png": str(out_dir / "shadow.png")}


def format_light(rec: dict) -> list:
    """Rows (label, text) of the result table for a ``results.json`` ``"light"`` record.

    A missing figure (``null``) prints as "n/a"; a missing moving time (no caster moved) is left out.
    """
    num = _num
    where = rec.get("direction", rec.get("position"))
    rows = [("light", f"{rec['kind']} {tuple(round(x, 3) for x in where)}: {rec['pixels']} pixels facing it, "
                      f"{num(rec['shadowed']['value'], '.1f', 100)} % shadowed (Embree)")]
    for m, f in rec["methods"].items():
        mv = f["frame_time_moving"]["value"]
        rows.append((f"  {m}", f"agreement {num(f['agreement']['value'], '.2f', 100)} %; "
                               f"{num(f['bytes']['value'], '.1f', 2**-20)} MiB; "
                               + (f"moving {mv * 1e3:.0f} ms, " if mv is not None else "")
                               + f"static {num(f['frame_time_static']['value'], '.0f', 1e3)} ms a frame"))
    return rows

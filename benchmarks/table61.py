"""Benchmark: Table 6.1 of thesis 000 ("Darstellungszeiten getesteter Szenen") on pyshadow.

Four one-occluder scenes, as in the thesis's section 6.1: one caster with a
CSM of 64 x 128 maps of 128^2 texels (16-bit depth; the cache of
``pyshadow.cache``), and three background planes -- a floor and two walls
meeting in a corner behind the body -- added as receivers
(``Scene.add(mesh, casts=False)``: drawn and shaded, no CSM, they cast
nothing, as the thesis's walls did not). The camera looks into the corner,
so every pixel of the frame sees a surface and gets AO. Frames are rendered
by ``Scene.render`` with the main job's default sampling (``pyshadow-bench``:
36 Hammersley samples, 256 patterns, no denoising, one-texel lookup) at
320x240, 640x480 and 1024x768, in interleaved rounds (each round renders
every scene at every size once; medians).

Per scene: faces; the CSM's compression ratio and size; the load time
(reading and checking the .csm file, the scene, and the first 320x240 frame,
which uploads the tables and builds or loads the kernels); the run-time
memory per resolution (the CSM's device tables plus the frame's buffers,
computed from the arrays' sizes) and the process's resident memory; frames
per second and AO samples per second (covered pixels x 36 / frame time;
the thesis's from its frame rates, every pixel covered there too). The thesis's figures for its four scenes (Head, Bunny, Chevy,
Venus; GeForce 8800 GTX) are printed beside them. ``--ground`` uses the
scene's analytic ground plane as the floor instead of a floor mesh.

    python benchmarks/table61.py [--rounds 5] [--ground] [--json]
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time

import numpy as np

#: Our scene -> (bundled mesh, the thesis scene it stands beside): the bunny
#: beside the bunny; a head (suzanne) beside Head; a figure (homer) beside the
#: statue Venus; a body of several parts (teapot) beside the many-part Chevy.
SCENES = {"suzanne": ("suzanne.ply", "Head"), "bunny": ("stanford-bunny.obj", "Bunny"),
          "teapot": ("teapot.obj", "Chevy"), "homer": ("homer.obj", "Venus")}
SIZES = ((320, 240), (640, 480), (1024, 768))

#: Thesis 000, section 6.1, Table 6.1 (p. 83): Intel Core 2 Duo 6400, 1 GB RAM,
#: NVIDIA GeForce 8800 GTX; AO with 36 samples a fragment, 64 x 128 compressed
#: depth maps of 128 x 128 texels. Polygons, compression ratio, CSM file (MB),
#: load time (s), then per resolution (MB at run time, frames per second).
THESIS = {
    "Head": (20782, 35.59, 134, 65, ((56.5, 9.7), (57.4, 4.3), (59.3, 1.9))),
    "Bunny": (69664, 30.50, 170, 89, ((55.6, 8.4), (56.5, 3.9), (58.4, 2.6))),
    "Chevy": (29304, 16.55, 254, 123, ((64.1, 14.5), (65.0, 4.0), (66.9, 1.8))),
    "Venus": (43357, 67.56, 71.5, 38, ((45.3, 19.6), (46.2, 6.7), (48.1, 3.5))),
}
WALL = -1.3          # the walls' planes x = WALL and z = WALL (the body's radius is 1)


def plane(corner, u, v):
    """A quad receiver ``corner + s u + t v`` (s, t in [0, 1]) as two triangles."""
    import trimesh

    c, u, v = (np.asarray(a, np.float64) for a in (corner, u, v))
    return trimesh.Trimesh([c, c + u, c + u + v, c + v], [[0, 1, 2], [0, 2, 3]], process=False)


def corner_planes(size=40.0, floor=True):
    """The floor ``y = 0`` and the walls ``x = WALL``, ``z = WALL``, ``size`` world units long."""
    walls = [plane([WALL, 0, WALL], [0, 0, size], [0, size, 0]),
             plane([WALL, 0, WALL], [0, size, 0], [size, 0, 0])]
    return ([plane([WALL, 0, WALL], [size, 0, 0], [0, 0, size])] if floor else []) + walls


def resident_bytes() -> int:
    """The process's resident set, bytes (psutil, else /proc/self/statm; 0 where neither works)."""
    try:
        import psutil

        return int(psutil.Process().memory_info().rss)
    except ImportError:
        pass
    try:
        import os

        with open("/proc/self/statm") as f:
            return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return 0


def build_scene(name, cache, ground):
    """(scene, csm info, seconds to read the .csm file, clock at the start of loading) of one row."""
    import pyshadow
    from _common import load_mesh

    mesh = load_mesh(SCENES[name][0])
    views = pyshadow.ViewSet.zigzag(64, 128)
    built, info = cache.csm(name, mesh, views, 128, 16)      # built and stored once, if missing
    t0 = time.perf_counter()
    csm = pyshadow.CoherentShadowMap.load(info["file"], mmap=False) if info["file"] else built
    t_file = time.perf_counter() - t0
    scene = pyshadow.Scene(ground=0.0 if ground else None, views=views)
    scene.add(csm, pyshadow.stand_on_ground(mesh), mesh=mesh)
    for p in corner_planes(floor=not ground):
        scene.add(p, casts=False)
    return scene, info, t_file, t0


def camera(width, height):
    """Looking into the corner from the front right, above the body: every pixel sees a plane."""
    import pyshadow

    return pyshadow.Camera([3.4, 2.4, 3.4], [-0.2, 0.7, -0.2], fov_y=50.0, width=width, height=height)


def device_table_bytes(csm) -> int:
    """Bytes of the device tables of one CSM (offsets, block offsets, summaries, pairs)."""
    a = csm.search_arrays()
    return int(sum(a[k].nbytes for k in ("offsets", "soff", "summary", "pairs")))


def print_table(result):
    """The table of :func:`main`'s result, ours beside the thesis's rows."""
    out_rows = result["rows"]
    print(f"pyshadow on {result['device']} ({result['compute_units']} compute units, {result['lanes']} lanes); "
          f"CSMs 64x128 maps @ 128^2, 16-bit; {result['samples']} {result['strategy']} samples, no denoising; "
          f"floor: {result['floor']}; medians of {result['rounds']} interleaved rounds")
    print("Memory: CSM device tables + frame buffers (MB = 10^6 B); thesis: run-time MB of its application.")
    print(f"{'scene':8s} {'faces':>6s} {'ratio':>7s} {'CSM MB':>7s} {'load s':>7s} {'size':>10s} {'MB':>6s} "
          f"{'fps':>6s} {'Msamp/s':>8s} | {'thesis':6s} {'polys':>6s} {'ratio':>7s} {'CSM MB':>7s} "
          f"{'load s':>6s} {'MB':>5s} {'fps':>5s} {'Msamp/s':>8s}")
    for r in out_rows:
        t = THESIS[r["thesis_scene"]]
        for i, x in enumerate(r["resolutions"]):
            head = (f"{r['scene']:8s} {r['faces']:6d} {r['ratio']:6.2f}:1 {r['csm_bytes'] / 1e6:7.2f} "
                    f"{r['load_s']:7.2f}" if i == 0 else " " * 40)
            thead = (f"{r['thesis_scene']:6s} {t[0]:6d} {t[1]:6.2f}:1 {t[2]:7.1f} {t[3]:6d}" if i == 0
                     else " " * 36)
            print(f"{head} {x['width']:>4d}x{x['height']:<5d} {x['memory_bytes'] / 1e6:6.1f} {x['fps']:6.2f} "
                  f"{x['Msamples_per_s']:8.1f} | {thead} {t[4][i][0]:5.1f} {t[4][i][1]:5.1f} "
                  f"{x['width'] * x['height'] * 36 * t[4][i][1] / 1e6:8.1f}")
    print("load s: CSM file read and checked + scene + first 320x240 frame (device upload, kernels); "
          "CSM build (once, cached): " + ", ".join(f"{r['scene']} {r['csm_build_s']:.1f} s" if r["csm_build_s"]
                                                  else f"{r['scene']} ?" for r in out_rows))
    print(f"process resident memory {result['rss_bytes'] / 1e6:.0f} MB; wall {result['wall_s']:.0f} s")


def main(argv=None) -> int:
    import pyshadow
    from _common import emit, environment
    from pyshadow.cache import CSMCache, default_cache_dir

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=5, help="interleaved timed rounds (default %(default)s)")
    ap.add_argument("--ground", action="store_true", help="the analytic ground plane as the floor")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    if args.rounds < 1:
        ap.error("--rounds must be >= 1")

    def log(msg):
        print(msg, file=sys.stderr, flush=True)

    cache = CSMCache(default_cache_dir(), log=log)
    sampling = pyshadow.Sampling()                   # 36 Hammersley samples, 256 patterns: the bench default
    cams = {s: camera(*s) for s in SIZES}
    kw = dict(sampling=sampling, ground_size=80.0 if args.ground else None)
    t_start = time.perf_counter()
    rows, scenes = {}, {}
    for name in SCENES:
        rss0 = resident_bytes()
        scene, info, t_file, t0 = build_scene(name, cache, args.ground)
        first = scene.render(cams[SIZES[0]], **kw)
        load_s = time.perf_counter() - t0
        csm = scene.instances[0].csm
        table = device_table_bytes(csm)
        frames = {}
        for s in SIZES:
            f = first if s == SIZES[0] else scene.render(cams[s], **kw)      # warm-up of each size
            covered = float(np.mean(f["object_id"] != -1))
            buffers = sum(v.nbytes for v in f.values() if isinstance(v, np.ndarray))
            frames[s] = {"covered": covered, "buffer_bytes": int(buffers), "times_s": []}
        scenes[name] = scene
        st = csm.stats
        rows[name] = {"scene": name, "mesh": SCENES[name][0], "thesis_scene": SCENES[name][1],
                      "faces": int(len(scene.instances[0].mesh.faces)), "ratio": st["ratio"],
                      "csm_bytes": st["bytes"], "device_table_bytes": table,
                      "csm_source": info["source"], "csm_build_s": info["build_seconds"],
                      "csm_file_load_s": t_file, "load_s": load_s,
                      "rss_added_bytes": resident_bytes() - rss0, "frames": frames}
        log(f"{name}: loaded in {load_s:.2f} s (CSM file {t_file:.2f} s, {info['source']})")
    log(f"timing: {args.rounds} rounds of {len(SCENES)} scenes x {len(SIZES)} sizes")
    for _ in range(args.rounds):
        for s in SIZES:
            for name, scene in scenes.items():
                t0 = time.perf_counter()
                scene.render(cams[s], **kw)
                rows[name]["frames"][s]["times_s"].append(time.perf_counter() - t0)
    out_rows = []
    for name, r in rows.items():
        res = []
        for (w, h), f in r["frames"].items():
            med = statistics.median(f["times_s"])
            res.append({"width": w, "height": h, "frame_s": med, "fps": 1.0 / med, "covered": f["covered"],
                        "Msamples_per_s": w * h * f["covered"] * sampling.samples / med / 1e6,
                        "memory_bytes": r["device_table_bytes"] + f["buffer_bytes"], "times_s": f["times_s"]})
        out_rows.append({**{k: v for k, v in r.items() if k != "frames"}, "resolutions": res})
    result = {"benchmark": "table61", **environment(), "rounds": args.rounds, "floor": "ground plane"
              if args.ground else "receiver mesh", "samples": sampling.samples, "strategy": sampling.strategy,
              "maps": "64x128", "resolution": 128, "depth_bits": 16, "rss_bytes": resident_bytes(),
              "wall_s": time.perf_counter() - t_start, "rows": out_rows,
              "thesis": {k: {"polygons": v[0], "ratio": v[1], "csm_file_MB": v[2], "load_s": v[3],
                             "resolutions": [{"width": w, "height": h, "MB": mb, "fps": fps,
                                              "Msamples_per_s": w * h * 36 * fps / 1e6}
                                             for (w, h), (mb, fps) in zip(SIZES, v[4])]}
                         for k, v in THESIS.items()},
               "thesis_source": "thesis 000, section 6.1, Table 6.1 (GeForce 8800 GTX, Core 2 Duo 6400)"}
    if args.json:
        emit(result, True)
        return 0
    print_table(result)
    return 0


if __name__ == "__main__":
    sys.exit(main())

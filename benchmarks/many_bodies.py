"""The G-buffer of a frame of many bodies: the host's share of ``Scene.render``.

``--bodies`` bunnies (0.5 m, 70k triangles each, random orientations) resting
on a 10 m x 10 m ground, drawn as receivers (no CSM to build; the G-buffer
does not depend on it), seen whole from a camera at (0, 9, 13) m, 640x480.
Timed: ``render_gbuffer`` of the scene's draw items and ``Scene.render``
(16 samples), medians of ``--rounds`` after a warm-up; and the triangles
drawn. With ``--json``, one JSON object (for ``side_by_side.py``).

    python benchmarks/many_bodies.py [--bodies 25 100] [--rounds 5] [--json]
"""
from __future__ import annotations

import argparse
import statistics
import sys
import time

import numpy as np

from _common import check_counts, emit, environment


def scene_of(n, mesh, seed=0):
    """``n`` copies of ``mesh`` scaled to 0.5 m, turned at random, resting on the ground y = 0 within 5 m of (0, 0)."""
    import pyshadow
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(seed)
    scale = 0.5 / float(np.ptp(mesh.bounds, axis=0).max())
    T = np.repeat(np.eye(4)[None], n, axis=0)
    T[:, :3, :3] = Rotation.random(n, random_state=seed).as_matrix() * scale
    T[:, 0, 3], T[:, 2, 3] = rng.uniform(-5, 5, n), rng.uniform(-5, 5, n)
    T[:, 1, 3] = -np.einsum("vj,nij->nvi", mesh.vertices, T[:, :3, :3])[:, :, 1].min(axis=1)
    s = pyshadow.Scene(ground=0.0)
    s.add(mesh, T, casts=False)
    return s


def main(argv=None) -> int:
    import pyshadow
    from pyshadow.gbuffer import render_gbuffer

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--bodies", type=int, nargs="+", default=[25, 100])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    check_counts(ap, args, "rounds")
    if min(args.bodies) < 1:
        ap.error(f"every --bodies must be >= 1, got {args.bodies}")
    mesh = pyshadow.data.bunny()
    cam = pyshadow.Camera((0.0, 9.0, 13.0), (0.0, 0.0, 0.0), fov_y=55.0, width=640, height=480)
    sampling = pyshadow.Sampling(16)
    rows = {}
    for n in args.bodies:
        s = scene_of(n, mesh)
        items = s.draw_items()[0]
        g = render_gbuffer(items, cam)                  # warm: kernels built
        s.render(cam, sampling=sampling)
        tg, tr = [], []
        for _ in range(args.rounds):
            t0 = time.perf_counter()
            render_gbuffer(items, cam)
            t1 = time.perf_counter()
            s.render(cam, sampling=sampling)
            tr.append(time.perf_counter() - t1)
            tg.append(t1 - t0)
        rows[str(n)] = {"triangles": int(sum(len(m.faces) for m, _ in items)),
                        "covered_pixels": int((g["object_id"] >= 0).sum()),
                        "render_gbuffer_s": statistics.median(tg), "render_s": statistics.median(tr)}
        print(f"{n} bodies done", file=sys.stderr, flush=True)
    if args.json:
        emit({"benchmark": "many_bodies", **environment(), "bodies": rows}, True)
        return 0
    print(f"{'bodies':>7} {'triangles':>10} {'covered px':>11} {'render_gbuffer s':>17} {'Scene.render s':>15}")
    for n, r in rows.items():
        print(f"{n:>7} {r['triangles']:>10} {r['covered_pixels']:>11} {r['render_gbuffer_s']:>17.3f} "
              f"{r['render_s']:>15.3f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""The cases of ``benchmarks/second_device.py``: small CSM builds and queries, run on one device.

:func:`run_cases` runs them in the current process on the device pyshadow
opened (``PYSHADOW_DEVICE``) and returns ``{"case/array": ndarray}``; it prints
``=== CASE name`` to stderr before each case, so that what an OpenCL
implementation writes there (Oclgrind's findings) can be told by case.
Build cases return the saved CSM file's bytes (``csm``, uint8) and the
visibility of 40 rays through it; query cases use three CSMs (box, bunny,
plate) read from ``csm_dir`` where a first run left them, so that every device
queries the same maps.
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np
import trimesh

import pyshadow
from pyshadow import Sampling
from pyshadow.scene import GROUND_ID

T = trimesh.transformations.translation_matrix


# ---------------------------------------------------------------- build cases
def _tri():
    return trimesh.Trimesh([[0, 0, 0], [1, 0, 0], [0, 1, 0.0]], [[0, 1, 2]], process=False)


def _flat():
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0.0]])
    return trimesh.Trimesh(v, [[0, 1, 2], [0, 2, 3]], process=False)


def _box():
    return trimesh.creation.box((1, 1, 1))


def _open_box():
    m = trimesh.creation.box((1, 1, 1))
    return trimesh.Trimesh(m.vertices, m.faces[m.face_normals[:, 2] < 0.5], process=False)


def _far_box():
    m = trimesh.creation.box((1, 2, 3))
    m.apply_translation([1e4, -3e3, 5e3])
    return m


def _bundled(name):
    return lambda: pyshadow.data.mesh(name)


def _zz(a, b, **kw):
    return lambda: pyshadow.ViewSet.zigzag(a, b, **kw)


def _hb(level, **kw):
    return lambda: pyshadow.ViewSet.hilbert(level, **kw)


# name: (mesh, views, resolution, build keywords); resolutions mostly not powers of two
BUILDS = {
    "tri": (_tri, _zz(3, 5), 7, dict(depth_bits=16, layers=2)),
    "tri32_footprint": (_tri, _hb(1), 9, dict(depth_bits=32, layers=2, footprint=True)),
    "flat_two_sided": (_flat, _zz(2, 3), 12, dict(depth_bits=16, layers=2, two_sided=True)),
    "box": (_box, _zz(4, 8), 16, dict(depth_bits=16)),
    "box_3layers_footprint": (_box, _zz(4, 6), 15, dict(depth_bits=32, layers=3, footprint=True)),
    "open_box_auto": (_open_box, _hb(1), 11, dict(depth_bits=16, layers=2, two_sided="auto", footprint=True)),
    "open_box_hemispheres": (_open_box, _hb(1, hemispheres=True), 9, dict(depth_bits=32, two_sided=True)),
    "far_box": (_far_box, _zz(3, 7), 17, dict(depth_bits=32)),
    "res1": (_box, _zz(2, 3), 1, dict(depth_bits=16)),
    "res2": (_tri, _zz(2, 3), 2, dict(depth_bits=32, footprint=True)),
    "suzanne": (_bundled("suzanne"), _zz(3, 6), 20, dict(depth_bits=16, layers=2, footprint=True)),
    "torus_row_offset": (_bundled("torus"), _zz(3, 6, row_offset=0.5), 33,
                         dict(depth_bits=32, layers=3, footprint=True, block=4)),
    "spot_layers_auto": (_bundled("spot"), _zz(3, 5), 19, dict(depth_bits=16, layers="auto", block=4)),
    "fandisk": (_bundled("fandisk"), _hb(1), 16, dict(depth_bits=32, footprint=True, block=3)),
    "featuretype_block1": (_bundled("featuretype"), _zz(3, 3), 10, dict(depth_bits=16, block=1, footprint=True)),
    "bunny": (_bundled("stanford-bunny"), _zz(2, 4), 16, dict(depth_bits=16, block=3)),
    "cow": (_bundled("cow"), _zz(5, 3), 23, dict(depth_bits=32, layers=2, two_sided=False, block=7)),
}
QUICK_BUILDS = ("tri", "box", "res2", "suzanne")


def _build(name, work: Path):
    mk, views, R, kw = BUILDS[name]

    def run():
        mesh = mk()
        path = pyshadow.CoherentShadowMap.build(mesh, views(), resolution=R, progress=False, **kw).save(
            work / f"build_{name}.csm", reproducible=True)
        csm = pyshadow.CoherentShadowMap.load(path)
        s = pyshadow.Scene()
        s.add(csm, mesh=mesh)
        rng = np.random.default_rng(1)
        p = np.asarray(csm.centre, float) + 0.9 * float(csm.radius) * rng.normal(size=(40, 3))
        w = rng.normal(size=(40, 3))
        return {"csm": np.frombuffer(Path(path).read_bytes(), np.uint8), "v": s.visible(p, w / np.linalg.norm(
            w, axis=1, keepdims=True))}
    return run


# ---------------------------------------------------------------- query cases
class _Maps:
    """The query cases' CSMs (box, bunny, plate), built once and shared through ``csm_dir``."""

    def __init__(self, csm_dir: Path):
        self.dir = Path(csm_dir)
        self.dir.mkdir(parents=True, exist_ok=True)
        self.box, self.bunny, self.plate = _box(), pyshadow.data.mesh("stanford-bunny"), trimesh.creation.box(
            (6.0, 0.2, 6.0))
        self.csm = {}
        for name, mesh in (("box", self.box), ("bunny", self.bunny), ("plate", self.plate)):
            path = self.dir / f"{name}.csm"
            if not path.is_file():
                pyshadow.CoherentShadowMap.build(mesh, pyshadow.ViewSet.zigzag(4, 8), resolution=16,
                                                 progress=False).save(path, reproducible=True)
            self.csm[name] = pyshadow.CoherentShadowMap.load(path)

    def box_scene(self, far=0.0):
        s = pyshadow.Scene(ground=far)
        s.add(self.csm["box"], T([far, 0.5 + far, far]), mesh=self.box)
        return s

    def two_scene(self):
        s = self.box_scene()
        b = self.csm["bunny"]
        sc = 0.6 / b.radius
        M = T([1.3, 0.0, 0.2]) @ np.diag([sc, sc, sc, 1.0])
        M[1, 3] = 0.6 - b.centre[1] * sc
        s.add(b, M, mesh=self.bunny)
        return s

    def many_scene(self, big):
        s = pyshadow.Scene(ground=0.0)
        rng = np.random.default_rng(0)
        for i in range(20):
            M = np.diag([0.4, 0.4, 0.4, 1.0])
            M[:3, 3] = [i % 5 - 2 + rng.uniform(-0.2, 0.2), 0.2, i // 5 - 2 + rng.uniform(-0.2, 0.2)]
            s.add(self.csm["box"], M, mesh=self.box)
        if big:
            s.add(self.csm["plate"], T([0.0, 2.5, 0.0]), mesh=self.plate)
        return s


def _rays(n, seed=0, lo=(-2, 0, -2), hi=(2, 1.5, 2)):
    rng = np.random.default_rng(seed)
    p, w = rng.uniform(lo, hi, (n, 3)), rng.normal(size=(n, 3))
    w[:, 1] = np.abs(w[:, 1]) + 0.1
    return p, w / np.linalg.norm(w, axis=1, keepdims=True)


def _ground(n, seed=1, half=2.0):
    rng = np.random.default_rng(seed)
    p = np.column_stack([rng.uniform(-half, half, n), np.zeros(n), rng.uniform(-half, half, n)])
    return p, np.tile([0.0, 1.0, 0.0], (n, 1)), np.full(n, GROUND_ID, np.int32)


def _box_surface(n, seed=2):
    """Points on the box's top and +x faces (surface id 0), with their normals."""
    rng = np.random.default_rng(seed)
    h = n // 2
    top = np.column_stack([rng.uniform(-0.45, 0.45, h), np.ones(h), rng.uniform(-0.45, 0.45, h)])
    side = np.column_stack([np.full(n - h, 0.5), rng.uniform(0.05, 0.95, n - h), rng.uniform(-0.45, 0.45, n - h)])
    nrm = np.vstack([np.tile([0, 1.0, 0], (h, 1)), np.tile([1.0, 0, 0], (n - h, 1))])
    return np.vstack([top, side]), nrm, np.zeros(n, np.int32)


def _visibility_cases(m: _Maps):
    s, (p, w) = m.box_scene(), _rays(97)
    gp, gn, gid = _ground(37)
    gw = _rays(37, 5)[1]
    bp, bn, bid = _box_surface(34)
    bw = _rays(34, 6)[1]
    fp, fw = _rays(97, 7, lo=(-1.5, 1.6, -1.5), hi=(1.5, 2.5, 1.5))
    tmax = np.random.default_rng(3).uniform(0.1, 1.2, 97)
    yield "vis_nearest", lambda: {"v": s.visible(p, w)}
    yield "vis_vote", lambda: {"v": s.visible(p, w, lookup="vote")}
    yield "vis_normals_ids", lambda: {"v": s.visible(gp, gw, normals=gn, surface_ids=gid),
                                      "vv": s.visible(gp, gw, normals=gn, surface_ids=gid, lookup="vote")}
    yield "vis_surface_ids_box", lambda: {"v": s.visible(bp + 1e-4 * bn, bw, surface_ids=bid, normals=bn)}
    yield "vis_finite", lambda: {"v": s.visible(fp, -fw, max_distance=tmax, straddle="embree"),
                                 "v2": s.visible(gp, gw, max_distance=0.5, normals=gn, surface_ids=gid,
                                                 straddle="embree")}
    yield "vis_one_and_empty", lambda: {"v": s.visible(p[:1], w[:1]),
                                        "e": s.visible(np.zeros((0, 3)), np.zeros((0, 3)))}
    sf = m.box_scene(far=1e4)
    yield "vis_far", lambda: {"v": sf.visible(p + 1e4, w), "vv": sf.visible(p + 1e4, w, lookup="vote")}
    s0 = pyshadow.Scene(ground=0.0)
    yield "vis_no_casters", lambda: {"v": s0.visible(p, w)}
    sr = pyshadow.Scene(ground=0.0)
    sr.add(m.box, T([0, 0.5, 0]), casts=False)
    yield "vis_receivers_only", lambda: {"v": sr.visible(p, w), "ao": sr.ambient_occlusion(
        bp, bn, sampling=Sampling(8), surface_ids=bid)}
    st = m.two_scene()
    yield "vis_two_bodies", lambda: {"v": st.visible(p, w), "vv": st.visible(p, w, lookup="vote")}


def _instance_cases(m: _Maps):
    from pyshadow.visibility import csm as vcsm
    p, w = _rays(133, 11, lo=(-3, 0, -3), hi=(3, 1, 3))
    gp, gn, gid = _ground(45, 12, 2.5)

    def run(big, accel):
        def f():
            before = vcsm.USE_GRID
            vcsm.USE_GRID = accel == "grid"
            try:
                s = m.many_scene(big)
                got = vcsm.instance_accel(s)
                ao, bent = s.ambient_occlusion(gp, gn, sampling=Sampling(16), surface_ids=gid,
                                               return_bent_normals=True)
                return {"accel": np.frombuffer(got.encode(), np.uint8), "v": s.visible(p, w),
                        "vv": s.visible(p, w, lookup="vote"), "ao": ao, "bent": bent}
            finally:
                vcsm.USE_GRID = before
        return f
    for big in (False, True):
        for accel in ("grid", "tree"):
            yield f"instances_{accel}{'_big' if big else ''}", run(big, accel)


def _ao_cases(m: _Maps):
    s = m.box_scene()
    gp, gn, gid = _ground(61, 21, 1.5)
    bp, bn, bid = _box_surface(30)

    def ao(p, n, ids, samples, **kw):
        return lambda: dict(zip(("ao", "bent"), s.ambient_occlusion(
            p, n, sampling=Sampling(samples), surface_ids=ids, return_bent_normals=True, **kw)))
    yield "ao_16", ao(gp, gn, gid, 16)
    yield "ao_16_vote", ao(gp, gn, gid, 16, lookup="vote")
    yield "ao_box_faces", ao(bp, bn, bid, 12)
    yield "ao_1", ao(gp, gn, gid, 1)
    yield "ao_130", ao(gp[:5], gn[:5], gid[:5], 130)
    VA = pyshadow.visibility.ambient_occlusion
    yield "ao_max_distance", lambda: {
        "ao": VA(s, gp, gn, sampling=Sampling(16), surface_ids=gid, max_distance=0.8, straddle="embree"),
        "obs": VA(s, gp, gn, sampling=Sampling(16), surface_ids=gid, max_distance=0.8, obscurance=2.0,
                  straddle="embree")}
    sf = m.box_scene(far=1e4)
    yield "ao_far", lambda: {"ao": sf.ambient_occlusion(gp + 1e4, gn, sampling=Sampling(16), surface_ids=gid)}


def _render_cases(m: _Maps):
    from pyshadow import render as R
    from pyshadow.lighting import DirectionalLight, EnvironmentMap, Lighting, PointLight
    s = m.two_scene()
    cam = pyshadow.Camera([2.5, 1.8, 3.5], [0.6, 0.3, 0.0], width=24, height=16)
    env = EnvironmentMap(np.abs(np.random.default_rng(5).normal(1.0, 0.3, (8, 16, 3))))
    sun = DirectionalLight(np.array([0.3, 0.8, 0.4]) / np.linalg.norm([0.3, 0.8, 0.4]), [3.0, 2.0, 1.0])

    def frame(**kw):
        def f():
            fr = R.render(s, cam, sampling=Sampling(8), **kw)
            return {k: np.asarray(v) for k, v in fr.items() if isinstance(v, np.ndarray)}
        return f

    def gbuffer():
        items, _ids = R.draw_items(s)
        return {k: np.asarray(v) for k, v in pyshadow.render_gbuffer(items, cam).items()}
    yield "gbuffer", gbuffer
    yield "render_plain", frame()
    yield "render_vote_bilateral", frame(visibility="csm-vote", denoise="bilateral")
    yield "render_bent_sun", frame(lighting=Lighting(env, sun=sun, mode="bent"))
    yield "render_point_light", frame(lighting=Lighting(env, lights=(PointLight([0.5, 2.0, 1.5], [4.0, 4.0, 4.0]),),
                                                        straddle="embree"))


def _other_cases(m: _Maps):
    from pyshadow import filters, ssao
    from pyshadow.cubemap import CubeMapAO, CubeMapVisibility
    from pyshadow.lighting import ShadowMapVisibility
    from pyshadow.render import draw_items
    s = m.two_scene()
    gp, gn, gid = _ground(40, 31, 1.5)
    L = np.tile([0.3, 0.8, 0.4], (40, 1)) / np.linalg.norm([0.3, 0.8, 0.4])
    yield "shadow_map", lambda: {"v": ShadowMapVisibility(32).visible(s, gp, L, normals=gn, surface_ids=gid),
                                 "f": ShadowMapVisibility(32, pcf=3).lit_fraction(s, gp, L, normals=gn,
                                                                                  surface_ids=gid)}

    def cube():
        maps = CubeMapAO(s, 1.0, resolution=16, estimator=None)
        maps.add_probe((0.5, 0.6, 1.2))
        p = np.array([(0.5, 0.6, 1.2)]) + np.random.default_rng(4).uniform(-0.1, 0.1, (23, 3))
        return {"v": pyshadow.visibility.visible(s, p, _rays(23, 9)[1],
                                                 backend=CubeMapVisibility(maps, unseen="open"))}
    yield "cube_map_ao", cube
    cam = pyshadow.Camera([2.5, 1.8, 3.5], [0.6, 0.3, 0.0], width=24, height=16)

    def screen_space():
        g = pyshadow.render_gbuffer(draw_items(s)[0], cam)
        return {"a": ssao.screen_space_ao(g, cam, 0.5, samples=8),
                "b": ssao.screen_space_ao(g, cam, 0.5, samples=1, range_check=False)}
    yield "ssao", screen_space
    rng = np.random.default_rng(8)
    ao, depth = rng.random((13, 11)).astype(np.float32), (3 + rng.random((13, 11))).astype(np.float32)
    depth[0, :4] = np.inf
    nrm = np.zeros((13, 11, 3), np.float32)
    nrm[..., 2] = 1
    nrm[5:] = [0, 1, 0]
    low = rng.random((7, 6)).astype(np.float32)
    yield "filters", lambda: {"bilateral": filters.bilateral(ao, depth, nrm),
                              "separable": filters.bilateral(ao, depth, nrm, separable=True),
                              "box": filters.edge_aware_box(ao, depth, nrm, size=5),
                              "upsample": filters.upsample(low, depth, nrm, scale=2)}


QUERY_GROUPS = (_visibility_cases, _instance_cases, _ao_cases, _render_cases, _other_cases)
QUICK_QUERIES = ("vis_nearest", "vis_finite", "vis_receivers_only", "instances_tree", "ao_16", "ao_130", "filters",
                 "shadow_map")


def run_cases(work, quick=False, only=(), csm_dir=None, log=sys.stderr):
    """Run the cases on the current device; returns (arrays ``{"case/name": ndarray}``, ``{case: seconds}``,
    ``{case: error text}``). ``work``: folder for the build cases' CSM files; ``csm_dir``: the query cases'
    CSMs, read where there, else built and written (default ``work/query_csm``); ``only``: these cases."""
    work = Path(work)
    work.mkdir(parents=True, exist_ok=True)

    def wanted(name, quick_set):
        return (name in only) if only else (not quick or name in quick_set)
    cases = [(f"build_{n}", _build(n, work)) for n in BUILDS if wanted(f"build_{n}", {f"build_{q}" for q in
                                                                                         QUICK_BUILDS})]
    maps = None
    arrays, seconds, errors = {}, {}, {}
    for name, fn in cases:
        _one(name, fn, arrays, seconds, errors, log)
    for group in QUERY_GROUPS:
        if maps is None:
            maps = _Maps(Path(csm_dir) if csm_dir else work / "query_csm")
        for name, fn in group(maps):
            if wanted(name, QUICK_QUERIES):
                _one(name, fn, arrays, seconds, errors, log)
    return arrays, seconds, errors


def _one(name, fn, arrays, seconds, errors, log):
    print(f"=== CASE {name}", file=log, flush=True)
    t = time.perf_counter()
    try:
        for k, v in fn().items():
            arrays[f"{name}/{k}"] = np.asarray(v)
    except Exception as exc:      # reported per case; the other cases still run
        errors[name] = f"{type(exc).__name__}: {exc}"[:300]
    seconds[name] = time.perf_counter() - t

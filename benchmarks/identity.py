"""Bit-identity of pyshadow's answers across a refactor.

Records, for every bundled mesh and the bundled default scene, the answers
of every public query and every build:

- CSM builds (zigzag, hilbert, 32-bit depth, footprint intervals): the
  segment lists (offsets, i_end, depth), their byte count, and the SHA-256
  of the saved ``.csm`` file (all of it but the build time in its header);
- ``Scene.visible`` with both lookups, on rays from the bodies' surfaces
  (AO rays and uniform ones) and from random points;
- ``Scene.ambient_occlusion`` with bent normals, and ``Scene.vertex_ao``;
- ``Scene.render`` with both lookups, with a denoiser and at half-res AO;
- the Embree ground truth: ``visible``, ``ambient_occlusion``, ``render``.

Run it on the old code with ``--save before.npz`` and on the new code with
``--compare before.npz``: it prints one line per array and exits 1 unless
every array is bit-identical. Only API names that exist before and after
are called (old names may warn with a DeprecationWarning after a move).

    python benchmarks/identity.py --save /tmp/before.npz      # old tree
    python benchmarks/identity.py --compare /tmp/before.npz   # new tree
"""
from __future__ import annotations

import argparse
import hashlib
import json
import sys
import tempfile
import warnings
import zlib
from pathlib import Path

import numpy as np
import trimesh


def _csm_arrays(tag, csm, out, tmp):
    out[f"{tag}/offsets"] = np.asarray(csm.offsets)
    out[f"{tag}/iend"] = np.asarray(csm.iend)
    out[f"{tag}/depth"] = np.asarray(csm.depth)
    out[f"{tag}/bytes"] = np.array([csm.stats["bytes"]])
    path = Path(tmp) / f"{tag.replace('/', '_')}.csm"
    csm.save(path)
    out[f"{tag}/file_sha256"] = np.frombuffer(_file_digest(path.read_bytes()), np.uint8)


def _file_digest(data: bytes) -> bytes:
    """SHA-256 of a .csm file but for its ``build_seconds`` (a timing: never the same twice).

    The digest covers the magic and version, the JSON header without
    ``build_seconds``, and every byte from the first array (64-byte aligned)
    to the checksum (which covers the header too); that checksum is verified first.
    """
    assert hashlib.sha256(data[:-32]).digest() == data[-32:], "bad file checksum"
    n = int(np.frombuffer(data[12:16], "<u4")[0])
    head = json.loads(data[16:16 + n])
    head.pop("build_seconds", None)
    first = -(-(16 + n) // 64) * 64
    return hashlib.sha256(data[:12] + json.dumps(head, sort_keys=True).encode() + data[first:-32]).digest()


def _queries(tag, scene, out, camera=None):
    import pyshadow

    rng = np.random.default_rng(zlib.crc32(tag.encode()))     # the same draws in any subset

    ids = scene.casters
    pts, nrm, own = [], [], []
    for i in ids:
        p, n = scene.vertex_points(i)
        take = rng.choice(len(p), min(len(p), 400), replace=False)
        pts.append(p[take]), nrm.append(n[take]), own.append(np.full(len(take), i, np.int32))
    p, n, own = np.concatenate(pts), np.concatenate(nrm), np.concatenate(own)
    ok = np.linalg.norm(n, axis=1) > 0
    p, n, own = p[ok], n[ok], own[ok]
    d = pyshadow.sample_directions(n, 8, "hammersley", 256, 0)          # (N, 8, 3)
    P = np.repeat(p, 8, axis=0)
    D = d.reshape(-1, 3)
    O = np.repeat(own, 8)
    U = rng.normal(size=(len(P), 3))
    lo, hi = p.min(axis=0), p.max(axis=0)
    R = lo + (hi - lo) * rng.random((len(P), 3))
    for filtered in (False, True):
        k = f"{tag}/visible/{'vote' if filtered else 'nearest'}"
        out[k + "/ao_rays"] = scene.visible(P, D, surface_ids=O, filtered=filtered)
        out[k + "/uniform"] = scene.visible(P, U, surface_ids=O, filtered=filtered)
        out[k + "/free"] = scene.visible(R, U, filtered=filtered)
        out[k + "/float32"] = scene.visible(P.astype(np.float32), U.astype(np.float32),
                                            surface_ids=O, filtered=filtered)
        ao, bent = scene.ambient_occlusion(p, n, 36, "hammersley", 256, 0, True, surface_ids=own,
                                           filtered=filtered)
        out[k + "/ao"], out[k + "/bent"] = ao, bent
    out[f"{tag}/ao_random_unknown"] = scene.ambient_occlusion(p, n, 16, "random", 64, 3)
    out[f"{tag}/vertex_ao"] = scene.vertex_ao(ids[0], 16)
    from pyshadow import reference as embree          # the old name of pyshadow.embree works in both
    a, b = embree.ambient_occlusion(scene, p[:300], n[:300], 16, "halton", 5, 64, True)
    out[f"{tag}/embree/ao"], out[f"{tag}/embree/bent"] = a, b
    out[f"{tag}/embree/visible"] = embree.visible(scene, P[:2000], U[:2000])
    if camera is not None:
        for filtered in (False, True):
            r = scene.render(camera, 16, filtered=filtered)
            for key in ("ao", "bent_normal", "depth", "normal", "object_id", "position"):
                out[f"{tag}/render/{'vote' if filtered else 'nearest'}/{key}"] = np.asarray(r[key])
        r = scene.render(camera, 9, "halton", 2, 64, filter="bilateral", ao_scale=2)
        out[f"{tag}/render/denoised"] = np.asarray(r["ao"])
        r = scene.render(camera, 9, filter="box")
        out[f"{tag}/render/box"] = np.asarray(r["ao"])
        r = embree.render(scene, camera, 9, "hammersley", 3, 64)
        for key in ("ao", "bent_normal", "depth", "normal", "object_id", "position"):
            out[f"{tag}/embree/render/{key}"] = np.asarray(r[key])


def record(meshes=None, quick=False) -> dict:
    import pyshadow
    from pyshadow.data import default_scene

    out = {}
    names = meshes or list(pyshadow.data.MESHES)
    with tempfile.TemporaryDirectory() as tmp:
        for name in names:
            mesh = pyshadow.data.mesh(name)
            tag = name.split(".")[0]
            builds = {
                "zigzag": dict(views=pyshadow.ViewSet.zigzag(16, 32), resolution=48),
                "hilbert": dict(views=pyshadow.ViewSet.hilbert(3), resolution=40),
                "depth32": dict(views=pyshadow.ViewSet.zigzag(8, 16), resolution=32, depth_bits=32),
                "footprint": dict(views=pyshadow.ViewSet.zigzag(8, 16), resolution=32, footprint=True),
            }
            csms = {}
            for b, kw in builds.items():
                kw = dict(kw)
                views, res = kw.pop("views"), kw.pop("resolution")
                csms[b] = pyshadow.CoherentShadowMap.build(mesh, views, res, progress=False, **kw)
                _csm_arrays(f"{tag}/csm/{b}", csms[b], out, tmp)
            for b in ("zigzag", "hilbert", "depth32"):
                scene = pyshadow.Scene(ground=float(mesh.bounds[0, 1]))
                scene.add(csms[b], mesh=mesh)
                T = trimesh.transformations.rotation_matrix(0.7, [0.3, 1.0, 0.2])
                T[:3, 3] = [1.3 * mesh.scale, 0.1 * mesh.scale, 0.2 * mesh.scale]
                scene.add(csms[b], T, mesh=mesh)
                cam = None
                if b == "zigzag":
                    c = mesh.bounding_sphere.primitive.center
                    cam = pyshadow.Camera(eye=c + mesh.scale * np.array([0.6, 0.9, 2.0]),
                                          target=c + [0.6 * mesh.scale, 0.0, 0.0], width=64, height=48)
                _queries(f"{tag}/scene/{b}", scene, out, cam)
        if not quick:
            scene, camera = default_scene(views=pyshadow.ViewSet.zigzag(64, 128), resolution=128,
                                          width=160, height=120)
            for i, c in enumerate({id(scene.instances[k].csm): scene.instances[k].csm
                                   for k in scene.casters}.values()):
                _csm_arrays(f"default/csm/{i}", c, out, tmp)
            _queries("default/scene", scene, out, camera)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    g = ap.add_mutually_exclusive_group(required=True)
    g.add_argument("--save", type=Path, help="record the answers into this .npz")
    g.add_argument("--compare", type=Path, help="compare the answers with this .npz")
    ap.add_argument("--mesh", action="append", help="only these bundled meshes (default: all)")
    ap.add_argument("--quick", action="store_true", help="skip the default scene")
    args = ap.parse_args(argv)
    from _common import check_file, check_meshes, check_out_file

    check_meshes(ap, "--mesh", args.mesh or (), files=False)
    if args.save:
        check_out_file(ap, "--save", args.save)
    else:
        check_file(ap, "--compare", args.compare)
        try:                        # before the minute of work: a file that is no .npz
            before = np.load(args.compare)
        except Exception as e:
            ap.error(f"--compare {args.compare}: not a .npz written by --save ({type(e).__name__})")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        out = record(args.mesh, args.quick)
    if args.save:
        from pyshadow._files import atomic_path

        with atomic_path(args.save) as tmp, open(tmp, "wb") as fh:     # the name as given (savez adds .npz)
            np.savez_compressed(fh, **out)
        print(f"recorded {len(out)} arrays ({sum(a.nbytes for a in out.values()) / 1e6:.1f} MB) "
              f"into {args.save}")
        return 0
    bad = 0
    subset = bool(args.mesh or args.quick)      # then only what was recorded now is compared
    for k in sorted((set() if subset else set(before.files)) | set(out)):
        if k not in out or k not in before.files:
            print(f"MISSING  {k} ({'after' if k not in out else 'before'})")
            bad += 1
            continue
        a, b = before[k], out[k]
        same = a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()
        if not same:
            bad += 1
            n = int(np.sum(a != b)) if a.shape == b.shape else -1
            print(f"DIFFERS  {k}: {n} of {a.size} elements")
    print(f"{len(out)} arrays, {sum(a.size for a in out.values())} values: "
          f"{'all bit-identical' if not bad else f'{bad} differ'}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())

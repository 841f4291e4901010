"""Numerical stability at the extremes: the broken-mesh rows, measured against Embree.

Imported by ``benchmarks/extremes.py`` (:data:`ROWS`, group ``mesh``); runs
on its own too. Open meshes, a single triangle, degenerate and duplicate
triangles, a non-manifold edge, inverted and inconsistent winding, coplanar
overlapping faces, each built raw and after ``load_mesh``; points on both
sides of the mesh and on the ground around it, AO rays against Embree
(``extremes_geometry.agreement``). Each defect is held to its clean
counterpart under the same construction plus ``SAME_POINTS``: the closed box
for the defects of the box's own surfaces, and for the fin the same surfaces
with the fin's edge on vertices of its own (:func:`counterparts`: the fin adds
surface, which the edge alone must not cost); the open box and the single
triangle, which have no clean counterpart, to ``DISAGREE_BOUND``.

    python benchmarks/extremes_meshes.py [--maps 64x128] [--resolution 128]
"""
from __future__ import annotations

import sys
import warnings

import numpy as np
import trimesh

import pyshadow
from extremes_geometry import DISAGREE_BOUND, SAME_POINTS, _box_at, _build, _row, agreement, ground_grid


def _box_raw():
    return _box_at((1, 1, 1), (0, 0.5, 0))


def broken_meshes():
    """``{name: (raw mesh, outward face normals of the raw faces or None)}`` of the mesh rows."""
    out = {}
    box = _box_raw()
    f, v = np.asarray(box.faces), np.asarray(box.vertices)
    up = box.face_normals[:, 1] > 0.5
    out["open box (no top)"] = (trimesh.Trimesh(v, f[~up], process=False), None)
    tri = trimesh.Trimesh([[-0.5, 0.6, -0.5], [0.6, 0.8, -0.4], [-0.3, 0.7, 0.6]], [[0, 2, 1]], process=False)
    out["single triangle"] = (tri, None)
    # zero-area faces: a repeated index and three collinear vertices on an edge
    v2 = np.vstack([v, 0.5 * (v[f[0, 0]] + v[f[0, 1]])])
    degen = np.vstack([f, [[f[0, 0], f[0, 0], f[0, 1]], [f[0, 0], len(v), f[0, 1]]]])
    out["degenerate triangles"] = (trimesh.Trimesh(v2, degen, process=False), None)
    out["duplicate triangles"] = (trimesh.Trimesh(v, np.vstack([f, f[:4], f[4:6, ::-1]]), process=False), None)
    # a fin: a quad sharing the box's top edge at z = +0.5 (that edge has three faces)
    top = v[:, 1] > 0.9
    e = np.flatnonzero(top & (v[:, 2] > 0.4))
    a, b = e[np.argsort(v[e, 0])]
    fin_v = np.vstack([v, v[[a, b]] + [0.0, 0.5, 0.5]])
    fin_f = np.vstack([f, [[a, b, len(v) + 1], [a, len(v) + 1, len(v)]]])
    out["non-manifold edge (fin)"] = (trimesh.Trimesh(fin_v, fin_f, process=False), None)
    out["inverted winding"] = (trimesh.Trimesh(v, f[:, ::-1], process=False), box.face_normals)
    mixed = f.copy()
    mixed[::2] = mixed[::2, ::-1]
    out["inconsistent winding"] = (trimesh.Trimesh(v, mixed, process=False), box.face_normals)
    # a second quad over part of the top face, in its plane
    q = np.array([[-0.3, 1.0, -0.3], [0.45, 1.0, -0.3], [0.45, 1.0, 0.45], [-0.3, 1.0, 0.45]])
    ov = np.vstack([v, q])
    of = np.vstack([f, np.array([[0, 2, 1], [0, 3, 2]]) + len(v)])
    out["coplanar overlapping faces"] = (trimesh.Trimesh(ov, of, process=False), None)
    return out


def detach_fin(mesh):
    """The fin mesh of :func:`broken_meshes` with the fin's two triangles on their own copies of the
    shared edge's vertices: the same surfaces, every edge manifold."""
    v, f = np.asarray(mesh.vertices), np.asarray(mesh.faces)
    box, fin = f[:-2], f[-2:]
    shared = np.intersect1d(fin, box)
    remap = np.arange(len(v))
    remap[shared] = len(v) + np.arange(len(shared))
    return trimesh.Trimesh(np.vstack([v, v[shared]]), np.vstack([box, remap[fin]]), process=False)


def counterparts(meshes):
    """``{name: clean mesh}`` where a defect's clean counterpart is not the closed box."""
    return {"non-manifold edge (fin)": detach_fin(meshes["non-manifold edge (fin)"][0])}


def mesh_case(name, raw, normals, views, resolution, n=2000, seed=16, load=False):
    """Build (raw, or after load_mesh), then agreement on the mesh's two sides and the ground."""
    info = {"mesh": name, "load": load}
    mesh = raw
    if load:
        with warnings.catch_warnings(record=True) as w:
            warnings.simplefilter("always")
            try:
                mesh = pyshadow.load_mesh(raw)
            except Exception as exc:       # a refusal is an answer too
                info["error"] = f"{type(exc).__name__}: {exc}"
                return info
        info["warnings"] = [str(x.message) for x in w]
    try:
        csm = _build(mesh, views, resolution)
    except Exception as exc:
        info["error"] = f"{type(exc).__name__}: {exc}"
        return info
    info["layer_rule"] = csm.layer_rule
    scene = pyshadow.Scene(ground=0.0)
    scene.add(csm, mesh=mesh)
    fn = mesh.face_normals if normals is None or len(mesh.faces) != len(raw.faces) else normals
    local, face = trimesh.sample.sample_surface(mesh, n, seed=seed)
    nn = fn[face]
    # an open sheet is seen from both sides: sample both
    if name in ("single triangle", "open box (no top)"):
        flip = np.random.default_rng(seed).random(n) < 0.5
        nn = np.where(flip[:, None], -nn, nn)
    g, gn = ground_grid(np.zeros(3), 1.2, n, seed=seed)
    P = np.concatenate([local, g])
    N = np.concatenate([nn, gn])
    S = np.concatenate([np.zeros(n, int), np.full(n, -2)])
    a = agreement(scene, P, N, S)
    info.update({k: a[k] for k in ("disagree", "false_shadow", "false_light", "rays")})
    return info


def mesh_rows(views, resolution) -> list[dict]:
    """Each defect against its clean counterpart under the same construction (+ SAME_POINTS); the
    open box and the single triangle, which have no clean counterpart, against DISAGREE_BOUND."""
    clean = mesh_case("clean box", _box_raw(), None, views, resolution)
    rows = [_row("clean box (the baseline of the mesh rows)", clean["disagree"], None, None,
                 unit="fraction of AO rays disagreeing with Embree")]
    meshes = broken_meshes()
    base = {}
    for name, mesh in counterparts(meshes).items():
        base[name] = mesh_case(name, mesh, None, views, resolution)["disagree"]
        rows.append(_row(f"{name}, every edge manifold (the baseline of its rows)", base[name], None, None,
                         unit="fraction of AO rays disagreeing with Embree",
                         against_clean_box=base[name] - clean["disagree"]))
    for name, (raw, normals) in meshes.items():
        for load in (False, True):
            info = mesh_case(name, raw, normals, views, resolution, load=load)
            how = "load_mesh" if load else "raw"
            label = f"{name} ({how})"
            if "error" in info:
                rows.append(_row(label, float("nan"), DISAGREE_BOUND, False, unit="refused", error=info["error"]))
                continue
            extra = {"layer_rule": info["layer_rule"]}
            if info.get("warnings"):
                extra["warnings"] = info["warnings"]
            bound = (DISAGREE_BOUND if name in ("open box (no top)", "single triangle")
                     else base.get(name, clean["disagree"]) + SAME_POINTS)
            rows.append(_row(label, info["disagree"], bound, info["disagree"] <= bound,
                             unit="fraction of AO rays disagreeing with Embree", false_shadow=info["false_shadow"],
                             false_light=info["false_light"], rays=info["rays"], **extra))
    return rows


ROWS = {"mesh": lambda a: mesh_rows(a.views, a.resolution)}


def main(argv=None) -> int:
    import extremes

    return extremes.main(argv, groups=ROWS, benchmark="extremes_meshes")


if __name__ == "__main__":
    sys.exit(main())

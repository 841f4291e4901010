"""Corner colours and UVs of a loaded mesh follow trimesh where it re-orders the corners of faces."""
import numpy as np
import pytest
import trimesh

import pyshadow
from pyshadow.materials import VISUAL_KEY, point_colours, visual_of
from pyshadow.io import srgb_to_linear

# a closed octahedron: every vertex has its own colour and UV (no seams)
V = np.array([(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)], float)
F = np.array([(0, 2, 4), (2, 1, 4), (1, 3, 4), (3, 0, 4), (2, 0, 5), (1, 2, 5), (3, 1, 5), (0, 3, 5)])
RGB = np.array([(255, 0, 0), (0, 255, 0), (0, 0, 255), (255, 255, 0), (0, 255, 255), (128, 64, 32)], np.uint8)
UV = np.array([(0.1, 0.2), (0.3, 0.9), (0.5, 0.5), (0.7, 0.1), (0.9, 0.6), (0.2, 0.7)])


def _ply(path, faces):
    head = ["ply", "format ascii 1.0", f"element vertex {len(V)}", "property float x", "property float y",
            "property float z", "property uchar red", "property uchar green", "property uchar blue",
            f"element face {len(faces)}", "property list uchar int vertex_indices", "end_header"]
    rows = [" ".join(map(str, [*v, *c])) for v, c in zip(V.tolist(), RGB.tolist())]
    path.write_text("\n".join(head + rows + ["3 %d %d %d" % tuple(f) for f in faces]) + "\n")
    return str(path)


def _corner_colours(mesh):
    """point_colours at every corner of every face, (T, 3, 3)."""
    vis = visual_of(mesh)
    T = len(mesh.faces)
    return np.stack([point_colours(vis, np.arange(T), np.tile(np.eye(3)[k], (T, 1))) for k in range(3)], axis=1)


def _expected(mesh, loaded):
    """The colour of each corner's vertex, from the file (the loaded mesh's vertex order)."""
    lin = srgb_to_linear(RGB / 255.0)
    at = {tuple(np.round(p, 9)): c for p, c in zip(V, lin)}
    return np.array([[at[tuple(np.round(p, 9))] for p in loaded.vertices[f]] for f in np.asarray(mesh.faces)])


def _fix_normals(m):
    trimesh.repair.fix_normals(m)              # needs networkx: the test extra carries it


def _flip_some(m):
    """What fix_winding does to the faces it re-winds: fliplr of those rows."""
    f = np.asarray(m.faces).copy()
    f[1::3] = f[1::3, ::-1]
    m.faces = f


def _edits():
    return {"invert": lambda m: m.invert(), "mirror": lambda m: m.apply_transform(np.diag([-1.0, 1, 1, 1])),
            "roll": lambda m: setattr(m, "faces", np.asarray(m.faces)[:, [1, 2, 0]]), "fix_normals": _fix_normals,
            "flip_some": _flip_some}


@pytest.mark.parametrize("edit", sorted(_edits()))
def test_ply_vertex_colours_follow_reordered_corners(tmp_path, edit):
    """Was: after mesh.invert() (also a mirroring apply_transform, a roll of the corners) the corner colours
    kept their old order: vertex 0 of a tetrahedron, red at all 3 corners, showed green, yellow and blue
    (errors of 1.0 per channel). fix_normals here re-winds the one face of the file wound the wrong way."""
    faces = F.copy()
    if edit == "fix_normals":
        faces[3] = faces[3][::-1]
    m = pyshadow.load_mesh(_ply(tmp_path / "o.ply", faces))
    loaded = m.copy()
    before = m.faces.copy()
    _edits()[edit](m)
    assert not np.array_equal(m.faces, before)
    got = _corner_colours(m)
    np.testing.assert_allclose(got, _expected(m, loaded), atol=1e-6)      # by vertex id: mirror moved them


def test_textured_glb_uvs_follow_invert_and_fix_winding(tmp_path):
    """Was: a textured GLB's corner UVs stayed in the loaded corner order after invert(): 2 of the 3 corners of
    every face sampled another vertex's UV (UV errors up to 0.8)."""
    from PIL import Image

    image = Image.fromarray(np.arange(4 * 4 * 3, dtype=np.uint8).reshape(4, 4, 3) * 5)
    src = trimesh.Trimesh(V, F, visual=trimesh.visual.TextureVisuals(uv=UV, image=image), process=False)
    path = tmp_path / "o.glb"
    path.write_bytes(src.export(file_type="glb"))
    m = pyshadow.load_mesh(str(path))
    vis0 = visual_of(m)
    uv_of = np.zeros((len(m.vertices), 2))
    uv_of[np.asarray(m.faces).ravel()] = vis0.uv.reshape(-1, 2)
    np.testing.assert_array_equal(uv_of[m.faces], vis0.uv)          # one UV per vertex
    ref_pc = point_colours(vis0, [0, 1], [[1, 0, 0], [0.2, 0.3, 0.5]])
    m.invert()
    vis = visual_of(m)
    np.testing.assert_array_equal(vis.uv, uv_of[m.faces])
    f0 = int(np.flatnonzero((m.faces == m.faces[0]).all(axis=1))[0])
    np.testing.assert_allclose(point_colours(vis, [f0, 1], [[0, 0, 1], [0.5, 0.3, 0.2]]), ref_pc, atol=1e-12)
    m2 = m.copy()
    _flip_some(m2)                             # some faces re-wound (as trimesh.repair.fix_winding does)
    np.testing.assert_array_equal(visual_of(m2).uv, uv_of[m2.faces])
    trimesh.repair.fix_winding(m2)             # needs networkx: the test extra carries it
    np.testing.assert_array_equal(visual_of(m2).uv, uv_of[m2.faces])


def test_unmodified_mesh_gets_its_own_visual(tmp_path):
    """Was (fast path kept): the visual of a mesh whose faces did not change is the kept object itself."""
    m = pyshadow.load_mesh(_ply(tmp_path / "o.ply", F))
    v = m.metadata[VISUAL_KEY]
    np.testing.assert_array_equal(v.faces, m.faces)
    assert visual_of(m) is v
    m.invert()
    m.invert()
    assert visual_of(m) is v


def test_faces_of_other_vertices_are_refused(tmp_path):
    """Was: a face given other vertices (same face count) silently kept its old corner colours."""
    m = pyshadow.load_mesh(_ply(tmp_path / "o.ply", F))
    faces = np.asarray(m.faces).copy()
    faces[2] = faces[5]
    m.faces = faces
    with pytest.raises(ValueError, match="another mesh.*1 of 8 faces"):
        visual_of(m)


def test_renumbered_vertices_keep_their_colours(tmp_path):
    """Was (kept): faces renumbered by trimesh without re-ordering corners (unmerge_vertices,
    remove_unreferenced_vertices) keep their colours; unmerged and then inverted is refused, not wrong."""
    m = pyshadow.load_mesh(_ply(tmp_path / "o.ply", F))
    want = _corner_colours(m)
    u = m.copy()
    u.unmerge_vertices()
    np.testing.assert_allclose(_corner_colours(u), want, atol=0)
    u.remove_unreferenced_vertices()
    u.merge_vertices()
    np.testing.assert_allclose(_corner_colours(u), want, atol=0)
    w = m.copy()
    w.unmerge_vertices()
    w.invert()
    with pytest.raises(ValueError, match="another mesh"):
        visual_of(w)


def test_filled_holes_follow_invert(tmp_path):
    """Was: load_mesh(fill_holes=True) of an open coloured mesh, inverted (a room), showed each corner the
    colour of another vertex of its face (up to 1.0 per channel)."""
    path = _ply(tmp_path / "open.ply", F[:6])
    m = pyshadow.load_mesh(path, fill_holes=True)
    want = {}
    for f, row in zip(np.asarray(m.faces), _corner_colours(m)):
        for k in range(3):
            want.setdefault(int(f[k]), []).append(row[k])
    m.invert()
    for f, row in zip(np.asarray(m.faces), _corner_colours(m)):
        for k in range(3):
            assert any(np.allclose(row[k], c, atol=1e-6) for c in want[int(f[k])])


def test_recorded_faces_of_the_wrong_form_are_refused(tmp_path):
    """Was: no recorded faces existed; now faces that are not (T, 3) integers are a clear error."""
    from dataclasses import replace

    m = pyshadow.load_mesh(_ply(tmp_path / "o.ply", F))
    v = m.metadata[VISUAL_KEY]
    m.metadata[VISUAL_KEY] = replace(v, faces=v.faces.astype(float))
    with pytest.raises(TypeError, match="faces must be integer"):
        visual_of(m)
    m.metadata[VISUAL_KEY] = replace(v, faces=v.faces[:, :2])
    with pytest.raises(ValueError, match=r"faces must have shape \(T, 3\)"):
        visual_of(m)
    m.metadata[VISUAL_KEY] = replace(v, faces=v.faces[:-1])
    with pytest.raises(ValueError, match="another mesh"):
        visual_of(m)

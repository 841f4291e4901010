"""Colours of a PLY or OBJ that also has texture coordinates but no texture (pyshadow.materials)."""
import numpy as np
import pytest

import pyshadow
from pyshadow.materials import point_colours, visual_of

HEAD = """ply
format ascii 1.0
element vertex 4
property float x
property float y
property float z
property float s
property float t
{vprops}element face 2
property list uchar int vertex_indices
{fprops}end_header
"""
XYZ_ST = ["0 0 0 0 0", "1 0 0 1 0", "1 1 0 1 1", "0 1 0 0 1"]
VCOL = np.array([[255, 0, 0], [0, 255, 0], [0, 0, 255], [128, 128, 128]], np.uint8)
FCOL = np.array([[200, 50, 10], [10, 90, 250]], np.uint8)
FACES = np.array([[0, 1, 2], [0, 2, 3]])


def _srgb(code):
    """sRGB 8-bit code -> linear, float64 (IEC 61966-2-1)."""
    c = np.asarray(code, np.float64) / 255.0
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def _colours_at(path, bary):
    """point_colours of every face of the loaded mesh at ``bary``, with each loaded face's file face index."""
    mesh = pyshadow.load_mesh(str(path))
    v = visual_of(mesh)
    assert v is not None and v.colours is not None
    # faces matched back to the file's by their vertex positions
    verts = np.asarray(mesh.vertices)
    key = {(0, 0): 0, (1, 0): 1, (1, 1): 2, (0, 1): 3}
    vid = np.array([key[(round(x), round(y))] for x, y, _ in verts])
    return point_colours(v, np.arange(len(mesh.faces)), np.repeat([bary], len(mesh.faces), axis=0)), vid[mesh.faces]


@pytest.mark.parametrize("per", ["vertex", "face"])
def test_ply_with_uvs_keeps_its_colours(tmp_path, per):
    """Was: a PLY with per-vertex UVs (s, t) and red/green/blue but no texture rendered white: trimesh keeps the
    colours of a mesh with UVs in mesh.vertex_attributes (face_attributes), which were not read (colour 1.0
    where the file says e.g. (1, 0, 0) at a corner)."""
    rgb = "property uchar red\nproperty uchar green\nproperty uchar blue\n"
    if per == "vertex":
        head = HEAD.format(vprops=rgb, fprops="")
        rows = [f"{p} {' '.join(map(str, c))}" for p, c in zip(XYZ_ST, VCOL)] + [f"3 {a} {b} {c}" for a, b, c in FACES]
    else:
        head = HEAD.format(vprops="", fprops=rgb)
        rows = XYZ_ST + [f"3 {a} {b} {c} {' '.join(map(str, col))}" for (a, b, c), col in zip(FACES, FCOL)]
    path = tmp_path / "uvcol.ply"
    path.write_text(head + "\n".join(rows) + "\n")
    bary = [0.2, 0.3, 0.5]
    got, file_faces = _colours_at(path, bary)
    if per == "vertex":
        want = np.einsum("k,nkc->nc", bary, _srgb(VCOL)[file_faces])
    else:
        face_of = {tuple(sorted(f)): i for i, f in enumerate(FACES.tolist())}
        want = _srgb(FCOL)[[face_of[tuple(sorted(f))] for f in file_faces.tolist()]]
    np.testing.assert_allclose(got, want, atol=1e-6, rtol=0)       # float32 colours


def test_obj_with_uvs_and_vertex_colours_without_material(tmp_path):
    """Was: an OBJ with ``vt`` lines and ``v x y z r g b`` colours but no MTL rendered white (1.0 where the file
    says (1, 0, 0)): trimesh keeps those colours in mesh.vertex_attributes, which were not read."""
    obj = "".join(f"v {x} {y} 0 {r} {g} {b}\n" for (x, y), (r, g, b) in
                  zip([(0, 0), (1, 0), (1, 1), (0, 1)], [(1, 0, 0), (0, 1, 0), (0, 0, 1), (0.5, 0.5, 0.5)]))
    obj += "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n"
    path = tmp_path / "uvcol.obj"
    path.write_text(obj)
    got, file_faces = _colours_at(path, [0.2, 0.3, 0.5])
    table = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [0.5, 0.5, 0.5]]) * 255     # sRGB-encoded, as 8-bit
    want = np.einsum("k,nkc->nc", [0.2, 0.3, 0.5], _srgb(table)[file_faces])
    np.testing.assert_allclose(got, want, atol=2e-3, rtol=0)     # 0.5 may be kept as 127.5 or rounded to 128

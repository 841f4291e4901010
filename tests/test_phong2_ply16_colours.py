"""16-bit (ushort) PLY colours, which trimesh's reader wraps modulo 256 (pyshadow.gltf_materials.ply_colours)."""
import numpy as np
import pytest

import pyshadow
from pyshadow.materials import point_colours, visual_of

VCOL = np.array([[65535, 0, 0], [0, 40000, 0], [0, 0, 1000], [32768, 32768, 32768]])
FCOL = np.array([[40000, 1000, 65535], [32768, 200, 300]])
FACES = np.array([[0, 1, 2], [0, 2, 3]])
XY = [(0, 0), (1, 0), (1, 1), (0, 1)]


def _srgb(c):
    """sRGB-encoded [0, 1] -> linear, float64 (IEC 61966-2-1)."""
    c = np.asarray(c, np.float64)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def _ply(per, binary):
    rgb = "".join(f"property ushort {k}\n" for k in ("red", "green", "blue"))
    head = ("ply\nformat " + ("binary_little_endian" if binary else "ascii") + " 1.0\nelement vertex 4\n"
            "property float x\nproperty float y\nproperty float z\n" + (rgb if per == "vertex" else "")
            + "element face 2\nproperty list uchar int vertex_indices\n" + (rgb if per == "face" else "")
            + "end_header\n")
    if not binary:
        vrows = [f"{x} {y} 0" + (" " + " ".join(map(str, c)) if per == "vertex" else "") for (x, y), c in zip(XY, VCOL)]
        frows = [f"3 {a} {b} {c}" + (" " + " ".join(map(str, col)) if per == "face" else "")
                 for (a, b, c), col in zip(FACES, FCOL)]
        return (head + "\n".join(vrows + frows) + "\n").encode()
    vdt = [("xyz", "<f4", 3)] + ([("rgb", "<u2", 3)] if per == "vertex" else [])
    fdt = [("n", "u1"), ("idx", "<i4", 3)] + ([("rgb", "<u2", 3)] if per == "face" else [])
    v = np.zeros(4, vdt)
    v["xyz"] = [(x, y, 0) for x, y in XY]
    f = np.zeros(2, fdt)
    f["n"], f["idx"] = 3, FACES
    if per == "vertex":
        v["rgb"] = VCOL
    else:
        f["rgb"] = FCOL
    return head.encode() + v.tobytes() + f.tobytes()


@pytest.mark.parametrize("binary", [False, True])
@pytest.mark.parametrize("per", ["vertex", "face"])
def test_ushort_ply_colours(tmp_path, per, binary):
    """Was: trimesh reads ushort colours modulo 256 and those were used: 40000/65535 (linear 0.331) became
    64/255 (0.051), 1000/65535 (linear 0.0012) became 232/255 (0.807), 32768 (0.216) became 0 (black)."""
    path = tmp_path / "c16.ply"
    path.write_bytes(_ply(per, binary))
    mesh = pyshadow.load_mesh(str(path))
    v = visual_of(mesh)
    key = {xy: i for i, xy in enumerate(XY)}
    file_vid = np.array([key[(round(x), round(y))] for x, y, _ in np.asarray(mesh.vertices)])[mesh.faces]
    bary = np.array([0.2, 0.3, 0.5])
    got = point_colours(v, np.arange(len(mesh.faces)), np.repeat([bary], len(mesh.faces), axis=0))
    if per == "vertex":
        want = np.einsum("k,nkc->nc", bary, _srgb(VCOL / 65535.0)[file_vid])
    else:
        face_of = {tuple(sorted(f)): i for i, f in enumerate(FACES.tolist())}
        want = _srgb(FCOL / 65535.0)[[face_of[tuple(sorted(f))] for f in file_vid.tolist()]]
    np.testing.assert_allclose(got, want, atol=1e-6, rtol=0)       # float32 colours


def test_uchar_ply_colours_unchanged(tmp_path):
    """Was: right, and stays so: 8-bit PLY colours are trimesh's (ply_colours gives them back as they are)."""
    data = _ply("vertex", False).replace(b"ushort", b"uchar")
    for old, new in ((b"65535", b"255"), (b"40000", b"153"), (b"1000", b"4"), (b"32768", b"128")):
        data = data.replace(old, new)
    path = tmp_path / "c8.ply"
    path.write_bytes(data)
    mesh = pyshadow.load_mesh(str(path))
    v = visual_of(mesh)
    codes = np.array([[255, 0, 0], [0, 153, 0], [0, 0, 4], [128, 128, 128]])
    key = {xy: i for i, xy in enumerate(XY)}
    file_vid = np.array([key[(round(x), round(y))] for x, y, _ in np.asarray(mesh.vertices)])[mesh.faces]
    np.testing.assert_allclose(v.colours, _srgb(codes / 255.0)[file_vid], atol=1e-7, rtol=0)

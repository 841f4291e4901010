"""STL files read by pyshadow.load_mesh, against a brute-force reading of their facets written here."""
import re
import struct

import numpy as np
import pytest
import trimesh

from pyshadow.mesh import load_mesh

BOX = trimesh.creation.box(extents=(1.0, 2.0, 3.0))
TRIS = np.asarray(BOX.vertices)[np.asarray(BOX.faces)]          # (12, 3, 3), outward winding


def _binary(tris, header=b"binary", count=None, tail=b""):
    body = b"".join(struct.pack("<12fH", 0.0, 0.0, 0.0, *t.ravel(), 0) for t in tris)
    return header.ljust(80, b" ") + struct.pack("<I", len(tris) if count is None else count) + body + tail


def _ascii(tris, name="part", nl="\n"):
    text = f"solid {name}{nl}"
    for t in tris.tolist():
        text += f" facet normal 0 0 0{nl}  outer loop{nl}"
        text += "".join(f"   vertex {x!r} {y!r} {z!r}{nl}" for x, y, z in t) + f"  endloop{nl} endfacet{nl}"
    return text + f"endsolid {name}{nl}"


def _brute(data):
    """Brute force: every facet's corners, binary by struct, ASCII from its vertex lines; area and volume."""
    if data[:5].lower() == b"solid" and b"\0" not in data:
        xyz = [list(map(float, m)) for m in re.findall(rb"^\s*vertex\s+(\S+)\s+(\S+)\s+(\S+)", data, re.M)]
        tris = np.array(xyz).reshape(-1, 3, 3)
    else:
        n = (len(data) - 84) // 50
        tris = np.array([struct.unpack_from("<9f", data, 84 + 50 * k + 12) for k in range(n)]).reshape(-1, 3, 3)
    cross = np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0])
    return 0.5 * np.linalg.norm(cross, axis=1).sum(), np.einsum("ij,ij->", tris[:, 0], cross) / 6.0


@pytest.mark.parametrize("header", [b"binary exported", b"solid made by a CAD exporter"])
def test_binary_stl_with_facet_count_zero(tmp_path, header):
    """Was: ValueError "the file holds no geometry (empty mesh)" for a binary STL of 12 facets whose header
    counts 0 (as some CAD exporters write it; MeshLab refuses it as "malformed"). Now its 12 facets."""
    data = _binary(TRIS, header, count=0)
    (tmp_path / "zero.stl").write_bytes(data)
    mesh = load_mesh(tmp_path / "zero.stl")
    area, volume = _brute(_binary(TRIS, header))
    assert len(mesh.faces) == 12
    assert mesh.area == pytest.approx(area, rel=1e-12) and mesh.volume == pytest.approx(volume, rel=1e-12)


def test_binary_stl_with_bytes_after_its_facets(tmp_path):
    """Was: "the file holds no geometry (empty mesh)" for 12 facets followed by 2 padding bytes; now read."""
    (tmp_path / "pad.stl").write_bytes(_binary(TRIS, tail=b"\0\0"))
    mesh = load_mesh(tmp_path / "pad.stl")
    assert len(mesh.faces) == 12 and mesh.volume == pytest.approx(6.0, rel=1e-12)


def test_binary_stl_cut_short_says_so(tmp_path):
    """Was: "the file holds no geometry (empty mesh)" for a file cut 10 bytes short; now the message says
    how many facets the header counts and how many bytes there are."""
    (tmp_path / "cut.stl").write_bytes(_binary(TRIS)[:-10])
    with pytest.raises(ValueError, match=r"cut.stl: a binary STL whose header counts 12 facets .*590 bytes"):
        load_mesh(tmp_path / "cut.stl")


@pytest.mark.parametrize("name,nl", [("my part", "\n"), ("", "\r\n"), ("solid_vertex", "\n")])
def test_ascii_stl_against_brute_force(tmp_path, name, nl):
    """Was already right, kept so: ASCII STL (a name with a space, none, CRLF, binary STL whose header starts
    with "solid") loads the brute-force facets: area 22, volume 6 for this box."""
    files = {"a.stl": _ascii(TRIS, name, nl).encode(), "b.stl": _binary(TRIS, b"solid " + name.encode())}
    for fname, data in files.items():
        (tmp_path / fname).write_bytes(data)
        mesh = load_mesh(tmp_path / fname)
        area, volume = _brute(data)
        assert mesh.area == pytest.approx(area, rel=1e-12) and mesh.volume == pytest.approx(volume, rel=1e-12)
        assert area == pytest.approx(22.0) and volume == pytest.approx(6.0)

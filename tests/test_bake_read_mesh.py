"""read_baked_mesh: the float AO and bent normals of a baked PLY or GLB back, bit for bit (pyvista's reader
keeps only the 8-bit grey colour of such a file)."""
import numpy as np
import pytest
import trimesh

from pyshadow.bake import read_baked_mesh
from pyshadow.bake.assets import baked_mesh_bytes
from pyshadow.data import mesh as bundled


def _baked(tmp_path, fmt, mesh):
    rng = np.random.default_rng(7)
    ao = rng.uniform(0.0, 1.0, len(mesh.vertices))
    ao[:3] = [0.0, 1.0, 0.1]
    bent = rng.normal(size=(len(mesh.vertices), 3))
    bent /= np.linalg.norm(bent, axis=1, keepdims=True)
    path = tmp_path / f"baked.{fmt}"
    path.write_bytes(baked_mesh_bytes(mesh, ao, bent, fmt))
    return path, ao, bent


@pytest.mark.parametrize("fmt", ["ply", "glb"])
@pytest.mark.parametrize("name", ["spot", "fandisk"])
def test_a_baked_mesh_reads_back_as_written(tmp_path, fmt, name):
    mesh = bundled(name)
    path, ao, bent = _baked(tmp_path, fmt, mesh)
    back, ao2, bent2 = read_baked_mesh(path)
    assert ao2.dtype == np.float32 and bent2.dtype == np.float32
    np.testing.assert_array_equal(ao2, ao.astype(np.float32))
    np.testing.assert_array_equal(bent2, bent.astype(np.float32))
    np.testing.assert_array_equal(back.vertices, np.asarray(mesh.vertices, np.float32))
    np.testing.assert_array_equal(back.faces, mesh.faces)


def test_what_is_not_a_baked_mesh_is_refused_by_name(tmp_path):
    plain = tmp_path / "plain.ply"
    plain.write_bytes(trimesh.creation.box().export(file_type="ply"))
    with pytest.raises(ValueError, match="plain.ply: not a baked mesh .*ao, bent_nx"):
        read_baked_mesh(plain)
    two = tmp_path / "two.glb"
    two.write_bytes(trimesh.Scene([trimesh.creation.box(), trimesh.creation.icosphere(1)]).export(file_type="glb"))
    with pytest.raises(ValueError, match="holds one mesh, this one holds 2"):
        read_baked_mesh(two)
    with pytest.raises(ValueError, match=r"\.ply or \.glb file, not \.obj"):
        read_baked_mesh(tmp_path / "a.obj")
    with pytest.raises(FileNotFoundError, match="no baked mesh"):
        read_baked_mesh(tmp_path / "missing.ply")
    broken = tmp_path / "broken.glb"
    broken.write_bytes(b"glTF not really")
    with pytest.raises(ValueError, match="broken.glb: cannot read it as GLB"):
        read_baked_mesh(broken)

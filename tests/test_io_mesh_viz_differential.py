"""Differential checks of image I/O and mesh preparation (no defects found; these pin what was measured).

Each test compares two independent computations: OpenImageIO's raw file contents vs
:func:`pyshadow.io.read_image`'s decoding formula, and a mesh's bounding sphere vs the same
mesh under a rigid motion and power-of-two scale.
"""
import numpy as np
import OpenImageIO as oiio
import pytest
import trimesh

from pyshadow.io import read_image, srgb_to_linear, write_image
from pyshadow.mesh import bounding_sphere


def _write_raw(path, x, fmt):
    buf = oiio.ImageBuf(np.ascontiguousarray(x, dtype=np.float32))
    buf.set_write_format(fmt)
    assert buf.write(str(path)), buf.geterror()


def test_png8_every_code_decodes_and_reencodes_exactly(tmp_path):
    """All 256 8-bit codes read as srgb_to_linear(v / 255) in float32, and writing them back gives the codes."""
    codes = np.arange(256, dtype=np.uint8).reshape(1, 256)
    write_image(tmp_path / "a.png", codes)
    lin = read_image(tmp_path / "a.png")
    assert np.array_equal(lin, srgb_to_linear(codes / 255.0).astype(np.float32))
    write_image(tmp_path / "b.png", lin)
    inp = oiio.ImageInput.open(str(tmp_path / "b.png"))
    back = np.asarray(inp.read_image(oiio.TypeUInt8)).ravel()
    inp.close()
    assert np.array_equal(back, codes.ravel())


def test_png16_decodes_with_scale_65535(tmp_path):
    """A 16-bit PNG's code v reads as srgb_to_linear(v / 65535) (float32 rounding: 6e-8)."""
    v = np.arange(0, 65536, 257, dtype=np.float64).reshape(1, -1)
    _write_raw(tmp_path / "c.png", v / 65535.0, oiio.TypeUInt16)
    got = read_image(tmp_path / "c.png")
    assert got.shape == v.shape
    assert np.abs(got - srgb_to_linear(v / 65535.0)).max() < 6e-8


def test_half_exr_widens_exactly(tmp_path):
    """A half EXR reads as the half values widened exactly (0, 1, 65504, a subnormal-range value, -2, inf, NaN)."""
    x = np.array([[0.0, 1.0, 65504.0, 1e-7, -2.0, np.inf, np.nan]], np.float32)
    _write_raw(tmp_path / "e.exr", x, oiio.TypeHalf)
    got = read_image(tmp_path / "e.exr")
    assert np.array_equal(got, x.astype(np.float16).astype(np.float32), equal_nan=True)


@pytest.mark.parametrize("shape", [(1, 1), (1, 1, 3), (1, 1, 4), (1, 7), (7, 1, 4)])
def test_exr_round_trip_tiny_images_bit_exact(tmp_path, shape):
    """1x1 and 1xN float32 images, values in [-1, 2), come back from EXR bit for bit."""
    x = (np.random.default_rng(1).random(shape) * 3 - 1).astype(np.float32)
    write_image(tmp_path / "f.exr", x)
    assert np.array_equal(read_image(tmp_path / "f.exr"), x)


@pytest.mark.parametrize("off", [1e3, 1e5, 1e7])
@pytest.mark.parametrize("scale", [2.0 ** -10, 1.0, 2.0 ** 13])
def test_bounding_sphere_follows_rigid_motion_and_scale(off, scale):
    """The bounding sphere of an ellipsoid moved by up to 1e7 and scaled by 2**-10..2**13 is the moved,
    scaled sphere (measured: relative differences below 1e-9; 1e-6 allowed)."""
    base = trimesh.creation.icosphere(2)
    base.vertices *= [1.0, 0.7, 0.4]
    c0, r0 = bounding_sphere(base)
    shift = np.array([off, -off, off / 3])
    c, r = bounding_sphere(trimesh.Trimesh(base.vertices * scale + shift, base.faces, process=False))
    assert abs(r / (r0 * scale) - 1) < 1e-6
    assert np.abs(c - (c0 * scale + shift)).max() / (r0 * scale) < 1e-6


@pytest.mark.parametrize("scale", [1e-6, 1e-7, 2.0 ** -30])
def test_mesh_to_polydata_normals_of_a_tiny_mesh(scale):
    """A sphere of radius 1e-6 (a micrometre scan) had all-zero normals from mesh_to_polydata (trimesh
    drops faces whose cross product is below 1e-12), so it drew black; its normals must be those of the
    same sphere at size 1 (measured after the fix: 3e-17; float32 storage allows 1e-7)."""
    from pyshadow.viz.meshes import mesh_to_polydata

    base = trimesh.creation.icosphere(2)
    n0 = np.asarray(mesh_to_polydata(base).point_data["Normals"])
    tiny = trimesh.Trimesh(base.vertices * scale, base.faces, process=False)
    n = np.asarray(mesh_to_polydata(tiny).point_data["Normals"])
    assert np.abs(n - n0).max() < 1e-7
    assert np.allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-6)

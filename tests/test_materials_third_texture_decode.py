"""Decoding 8- and 16-bit textures and colours to linear RGB (pyshadow.materials): memory and values."""
import tracemalloc

import numpy as np
import trimesh
from PIL import Image

from pyshadow.materials import mesh_visual, point_colours


def _iec_srgb_to_linear(c):
    """IEC 61966-2-1 decoding, float64."""
    c = np.asarray(c, np.float64)
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def _textured_quad(image):
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    return trimesh.Trimesh(v, [[0, 1, 2], [0, 2, 3]], process=False,
                           visual=trimesh.visual.TextureVisuals(uv=v[:, :2], image=image))


def test_an_8_bit_texture_is_decoded_without_float64_copies_of_the_image():
    """Was: the texture was decoded elementwise in float64 (a copy per step: clip, both branches of the
    sRGB curve, where): NumPy's peak while decoding a 1024^2 RGB image was 153 MB, 13 times the 12 MB
    float32 result (2.4 GB and 7.3 s for a 4096^2 image, 7.5 s to load a glb holding one; now 0.19 GB
    and 0.4-0.7 s). Now a table of the 256 codes: 15 MB, the result and the 3 MB image."""
    n = 1024
    rng = np.random.default_rng(5)
    img = rng.integers(0, 256, (n, n, 3), dtype=np.uint8)
    mesh = _textured_quad(Image.fromarray(img))
    tracemalloc.start()
    try:
        visual = mesh_visual(mesh)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    result = n * n * 3 * 4
    assert visual.texture.shape == (n, n, 3) and visual.texture.dtype == np.float32
    assert peak < 2 * result, f"peak {peak / 2**20:.1f} MB while decoding a {result / 2**20:.1f} MB texture"
    # the values are IEC 61966-2-1's of code / 255, rounded once to float32
    np.testing.assert_array_equal(visual.texture, _iec_srgb_to_linear(img / 255.0).astype(np.float32))


def test_every_8_and_16_bit_code_decodes_as_the_iec_curve():
    """The table gives each code exactly the float32 rounding of the float64 curve (8-bit over 255,
    16-bit over 65535; glTF's linear colours only scaled), and a texel sample interpolates them."""
    from pyshadow.materials import _linear

    for dtype, top in ((np.uint8, 255.0), (np.uint16, 65535.0)):
        codes = np.arange(int(top) + 1, dtype=dtype)
        rgba = np.stack([codes, codes[::-1], codes, np.full_like(codes, 7)], axis=1)
        want = _iec_srgb_to_linear(rgba[:, :3] / top).astype(np.float32)
        got = _linear(rgba)
        assert got.shape == (len(codes), 3) and got.dtype == np.float32
        np.testing.assert_array_equal(got, want)
        np.testing.assert_array_equal(_linear(rgba, srgb=False), (rgba[:, :3] / top).astype(np.float32))
        got[0, 0] = 5.0                                     # a fresh array, not the shared table
        assert _linear(rgba)[0, 0] == want[0, 0]
    img = np.array([[[0, 0, 0], [255, 255, 255]]], np.uint8)                # 1 x 2: black left, white right
    visual = mesh_visual(_textured_quad(Image.fromarray(img)))
    got = point_colours(visual, [0], [[0.0, 1.0, 0.0]])                     # corner (1, 0): u = 1 wraps to 0
    np.testing.assert_allclose(got, [[0.5, 0.5, 0.5]], atol=1e-7)           # halfway between both texels

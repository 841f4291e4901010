"""pyshadow.viz.vtk_ssao's bias and kernel size: refused where VTK's pass would not do what was asked."""
import pytest
import trimesh

import pyshadow


@pytest.mark.parametrize("bias", [-0.01, -0.1])
def test_vtk_ssao_refuses_a_negative_bias(bias):
    """Was: a negative bias was handed to VTK's SSAO pass, which then counted samples on the open ground as
    occluded: the median AO of a box on the ground (64x48, radius 0.5, 32 samples) fell from 0.87 (bias
    0.01) to 0.78 at -0.01 and 0.45 at -0.1, the ground beside the box from 0.94 to 0.41-0.53, without a word.
    Now it is refused before anything is drawn, as screen_space_ao refuses it."""
    pytest.importorskip("pyvista")
    from pyshadow.viz.ssao_pass import vtk_ssao

    scene = pyshadow.Scene(ground=0.0)
    scene.add(trimesh.creation.box((1.0, 1.0, 1.0)), trimesh.transformations.translation_matrix([0, 0.5, 0]),
              casts=False)
    cam = pyshadow.Camera([0.0, 1.6, 3.0], [0.0, 0.3, 0.0], width=32, height=24)
    with pytest.raises(ValueError, match=r"bias must be finite and >= 0"):
        vtk_ssao(scene, cam, 0.5, kernel_size=4, bias=bias)


@pytest.mark.parametrize("kernel_size", [1001, 4096])
def test_vtk_ssao_refuses_more_samples_than_vtk_takes(kernel_size):
    """Was: VTK's SSAO pass clamps its kernel size to 1000, so kernel_size=4096 rendered the very image of
    kernel_size=1000 (equal bit for bit on a box on the ground at 32x24) while the caller, and the methods
    benchmark (kernel size = its samples), took it for 4096 samples. Now a kernel size above VTK's largest is
    refused before anything is drawn."""
    pytest.importorskip("pyvista")
    from pyshadow.viz.ssao_pass import vtk_ssao

    scene = pyshadow.Scene(ground=0.0)
    cam = pyshadow.Camera([0.0, 1.6, 3.0], [0.0, 0.3, 0.0], width=32, height=24)
    with pytest.raises(ValueError, match=r"kernel_size must be at most 1000"):
        vtk_ssao(scene, cam, 0.5, kernel_size=kernel_size)

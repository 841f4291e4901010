"""pyshadow.viz.vtk_ssao: a scene or camera of the wrong kind is refused with a TypeError naming it."""
import pytest
import trimesh

import pyshadow


def _box():
    scene = pyshadow.Scene(ground=0.0)
    scene.add(trimesh.creation.box((1.0, 1.0, 1.0)), trimesh.transformations.translation_matrix([0, 0.5, 0]),
              casts=False)
    return scene, pyshadow.Camera([0.0, 1.6, 3.0], [0.0, 0.3, 0.0], width=32, height=24)


@pytest.mark.parametrize("which", ["pair", "mesh", "none"])
def test_vtk_ssao_refuses_what_is_no_scene(which):
    """Was: the (scene, camera) pair of pyshadow.data.default_scene(), a bare mesh or None passed as the scene
    got as far as VTK's imports and failed with AttributeError "'tuple' object has no attribute
    'draw_items'" (likewise 'Trimesh', 'NoneType'). Now a TypeError names the scene, as
    pyshadow.visibility's functions do."""
    from pyshadow.viz.ssao_pass import vtk_ssao

    scene, cam = _box()
    bad = {"pair": (scene, cam), "mesh": trimesh.creation.box(), "none": None}[which]
    with pytest.raises(TypeError, match="scene must be a pyshadow.Scene"):
        vtk_ssao(bad, cam, 0.5, kernel_size=4)


@pytest.mark.parametrize("which", ["pair", "string"])
def test_vtk_ssao_refuses_what_is_no_camera(which):
    """Was: a (scene, camera) pair or a string passed as the camera failed with AttributeError "'tuple' object
    has no attribute 'width'" (or 'str'). Now a TypeError names the camera, as screen_space_ao's does."""
    from pyshadow.viz.ssao_pass import vtk_ssao

    scene, cam = _box()
    bad = {"pair": (scene, cam), "string": "camera"}[which]
    with pytest.raises(TypeError, match="camera must be a pyshadow.Camera"):
        vtk_ssao(scene, bad, 0.5, kernel_size=4)

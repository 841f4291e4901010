"""Arguments of the lighting API that were taken silently or failed without naming themselves (lightuser, s36)."""
import numpy as np
import pytest

from pyshadow.lighting import EnvironmentMap, Lighting, auto_exposure


def _image():
    rng = np.random.default_rng(0)
    img = rng.uniform(0.0, 10.0, (12, 16, 3))
    ids = np.where(rng.uniform(size=(12, 16)) < 0.7, 1, -1)     # Frame.object_id: -1 background
    return img, ids


def test_auto_exposure_refuses_object_ids_as_covered():
    # covered=frame.object_id (ints) indexed rows of the image and gave another exposure, silently
    img, ids = _image()
    with pytest.raises(TypeError, match="covered"):
        auto_exposure(img, covered=ids)


def test_auto_exposure_names_a_covered_mask_of_the_wrong_shape():
    img, ids = _image()
    with pytest.raises(ValueError, match=r"covered.*\(12, 16\)"):
        auto_exposure(img, covered=np.ones((16, 12), bool))


def test_auto_exposure_names_radiance_without_three_channels():
    with pytest.raises(ValueError, match="radiance"):
        auto_exposure(np.ones((4, 4)))


def test_auto_exposure_with_a_bool_mask_is_unchanged():
    img, ids = _image()
    keep = ids >= 0
    lum = img[keep] @ np.array([0.2126, 0.7152, 0.0722])
    np.testing.assert_allclose(auto_exposure(img, keep), 0.8 / np.percentile(lum, 99.0), rtol=1e-12)
    assert auto_exposure(img, keep.tolist()) == auto_exposure(img, keep)


@pytest.mark.parametrize("mode", [np.array(["bent"]), np.array("bent"), ["bent"]])
def test_lighting_mode_must_be_a_string(mode):
    # an array mode passed `mode not in MODES` (its == answers elementwise) and was kept as the array
    with pytest.raises(ValueError, match="mode"):
        Lighting(EnvironmentMap(np.ones((2, 4, 3))), mode=mode)


@pytest.mark.parametrize("path", [3, None, 2.5])
def test_from_file_names_a_path_of_the_wrong_type(path):
    # was: "expected str, bytes or os.PathLike object, not int", naming nothing
    with pytest.raises(TypeError, match="path"):
        EnvironmentMap.from_file(path)


def test_constructor_given_a_file_name_points_at_from_file(tmp_path):
    with pytest.raises(ValueError, match="from_file"):
        EnvironmentMap(str(tmp_path / "sky.exr"))

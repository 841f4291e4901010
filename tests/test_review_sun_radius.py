"""Lighting.from_environment(sun_radius=) beyond extract_sun's range (0, pi / 4]: refused by its own name, with
or without ``extract`` (0f299cb refused a value <= 0 by name; 1.0 rad was refused as "radius: ..." with
extract=True and accepted, unused, with extract=False)."""
import numpy as np
import pytest

from pyshadow.lighting import EnvironmentMap, Lighting


@pytest.mark.parametrize("extract", [True, False])
@pytest.mark.parametrize("value", [1.0, 10.0])
def test_from_environment_names_sun_radius_beyond_pi_over_4(extract, value):
    env = EnvironmentMap(np.ones((8, 16, 3)))
    with pytest.raises(ValueError, match=r"^sun_radius: must lie in \[0, 0.785398\] \(got " + str(value)):
        Lighting.from_environment(env, sun_radius=value, extract=extract)


def test_from_environment_takes_sun_radius_up_to_pi_over_4():
    env = EnvironmentMap(np.ones((8, 16, 3)))
    for r in (1e-3, np.float32(0.01), np.pi / 4):
        Lighting.from_environment(env, sun_radius=r)
        Lighting.from_environment(env, sun_radius=r, extract=False)

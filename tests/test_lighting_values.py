"""Lights are values: ``==``, ``in`` and hashing work on the frozen light classes, whose fields hold
NumPy arrays. Their dataclass ``==`` compared the fields' tuples and raised "The truth value of an
array with more than one element is ambiguous" (so ``light in lights`` and ``lights.remove(light)``
raised ValueError), and ``hash(light)`` / ``{light}`` raised "unhashable type: 'numpy.ndarray'"."""
import numpy as np
import pytest

from pyshadow.lighting import DirectionalLight, DiscLight, PointLight, RectLight, SpotLight
from pyshadow.lighting.sun import SunLight

MAKERS = {
    "directional": lambda k: DirectionalLight([0.0, 1.0, 0.0], [1.0, k, 1.0]),
    "point": lambda k: PointLight([0.0, 2.0, 0.0], [1.0, k, 1.0], radius=0.1),
    "spot": lambda k: SpotLight([0.0, 2.0, 0.0], [1.0, k, 1.0], direction=[0.0, -1.0, 0.0], angle=0.5),
    "disc": lambda k: DiscLight([0.0, 2.0, 0.0], [0.0, -1.0, 0.0], 0.5, intensity=k),
    "rect": lambda k: RectLight([0.0, 2.0, 0.0], [0.4, 0.0, 0.0], [0.0, 0.0, 0.3], intensity=k),
    "sun": lambda k: SunLight(np.array([0.0, 1.0, 0.0]), np.array([1.0, k, 1.0]), 0.01,
                              np.array([3, 4]), np.full((2, 3), k)),
}


@pytest.mark.parametrize("kind", sorted(MAKERS))
def test_equal_lights_compare_and_hash_equal_and_others_differ(kind):
    make = MAKERS[kind]
    a, b, c = make(2.0), make(2.0), make(3.0)
    assert a == b and not a != b and hash(a) == hash(b)
    assert a != c and not a == c
    lights = [c, b]
    assert a in lights and lights.index(a) == 1
    lights.remove(a)
    assert lights == [c]
    assert len({a, b, c}) == 2 and {a: 1}[b] == 1


def test_minus_zero_equals_zero_and_hashes_alike_and_classes_stay_apart():
    a = PointLight([0.0, 2.0, 0.0], [1.0, 1.0, 1.0])
    b = PointLight([-0.0, 2.0, -0.0], [1.0, 1.0, 1.0])
    assert a == b and hash(a) == hash(b)
    spot = SpotLight([0.0, 2.0, 0.0], [1.0, 1.0, 1.0], direction=[0.0, -1.0, 0.0], angle=np.pi / 2)
    assert a != spot and spot != a          # a spot is not the point light at its position
    assert a != (a.position, a.intensity, a.radius) and a != "PointLight"

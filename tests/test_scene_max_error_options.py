"""Scene options that ``Scene.add(mesh, max_error=...)`` cannot honour are refused, not dropped."""
from __future__ import annotations

import pytest
import trimesh

import pyshadow


def test_footprint_scene_refuses_max_error():
    """Was: ``Scene(footprint=True).add(mesh, max_error=0.01)`` built the chosen CSM without the footprint the
    scene asks of its casters, silently (CoherentShadowMap.build itself refuses the pair)."""
    scene = pyshadow.Scene(ground=0.0, footprint=True)
    with pytest.raises(TypeError, match="footprint"):
        scene.add(trimesh.creation.box((1.0, 1.0, 1.0)), max_error=0.01)
    assert not scene.instances                     # nothing added

"""``Scene.add(mesh, max_bytes=...)``, alone or with ``max_error``: the caster's CSM chosen as
:meth:`pyshadow.CoherentShadowMap.build` chooses it, once per mesh, target and budget."""
import pytest
import trimesh

import pyshadow


@pytest.fixture(scope="module")
def box():
    return trimesh.creation.box()


def test_scene_add_chooses_within_max_bytes_once_per_mesh_and_budget(box):
    """Was: Scene.add took max_error but not max_bytes (TypeError): a budget meant building the CSM by hand and
    adding it. The box's smallest default candidate (16x32 maps at 64^2) takes 617,292 bytes; none larger fits
    in 700,000."""
    s = pyshadow.Scene(ground=0.0)
    a = s.add(box, pyshadow.stand_on_ground(box), max_error=0.03, max_bytes=700_000)
    b = s.add(box, pyshadow.stand_on_ground(box, position=(3, 0)), max_error=0.03, max_bytes=700_000)
    csm = s.instances[a].csm
    assert s.instances[b].csm is csm
    assert (csm.choice["target"], csm.choice["met"], csm.stats["bytes"]) == (0.03, True, 617_292)
    c = s.add(box, pyshadow.stand_on_ground(box, position=(6, 0)), max_bytes=700_000.5)    # whole bytes, as build
    within = s.instances[c].csm
    assert within is not csm and (within.choice["budget_bytes"], within.stats["bytes"]) == (700_000, 617_292)
    assert s.instances[s.add(box, max_bytes=700_000)].csm is within
    assert len(s.instances) == 4


def test_scene_add_refuses_max_bytes_where_nothing_is_chosen(box):
    s = pyshadow.Scene()
    csm = pyshadow.CoherentShadowMap.build(box, pyshadow.ViewSet.zigzag(4, 8), resolution=16, progress=False)
    with pytest.raises(ValueError, match="built already"):
        s.add(csm, max_bytes=10_000_000)
    with pytest.raises(ValueError, match="receiver"):
        s.add(box, casts=False, max_bytes=10_000_000)
    for bad, error in (("1e6", TypeError), (0, ValueError), (float("inf"), ValueError), (True, TypeError)):
        with pytest.raises(error, match="max_bytes"):
            s.add(box, max_bytes=bad)
    with pytest.raises(ValueError, match="no candidate CSM fits in 1000 bytes"):
        s.add(box, max_bytes=1000)
    assert s.instances == []

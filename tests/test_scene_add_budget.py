"""``Scene.add(mesh, max_bytes=...)``, alone or with ``max_error``: the caster's CSM chosen as
:meth:`pyshadow.CoherentShadowMap.build` chooses it, once per mesh, target and budget."""
import numpy as np
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


def test_budget_with_auto_lookup_takes_the_most_accurate_pair_and_measures_its_lookup():
    """Was: ``max_bytes`` with ``lookup="auto"`` raised ("lookup must be 'nearest' or 'vote'"), though with
    ``max_error`` it chooses. Now every candidate is predicted with both lookups and the most accurate (candidate,
    lookup) pair within the bytes is taken; the verification measures the lookup taken, and a query asking the
    other lookup is warned, as for ``max_error``."""
    from pyshadow.csm.choose import _check_seed, choose_within, measure
    from pyshadow.csm.error_model import rays_for

    torus = pyshadow.data.mesh("torus")
    cands = ((4, 8, 16), (8, 16, 16), (4, 8, 32))
    draw = dict(points=200, samples=4, near=1000)
    csm, c = choose_within(torus, 10 ** 8, lookup="auto", candidates=cands, **draw)
    pairs = [(tuple(t["predicted"]["maps"]), t["predicted"]["resolution"], t["predicted"]["lookup"])
             for t in c["tried"]]
    assert pairs == [(m[:2], m[2], lk) for m in cands for lk in ("nearest", "vote")]
    best = min(c["tried"], key=lambda t: (t["predicted"]["disagreement"], t["predicted_bytes"],  # the rule's ties
                                          t["predicted"]["lookup"] != "nearest"))
    assert c["predicted"] is best["predicted"] and c["lookup"] == best["predicted"]["lookup"]
    assert (tuple(c["maps"]), c["resolution"]) == (tuple(best["predicted"]["maps"]), best["predicted"]["resolution"])
    again = measure(csm, torus, rays_for(torus, seed=_check_seed(7), **draw), c["lookup"])
    assert c["measured"]["disagreement"] == again["disagreement"]
    # the one lookup asked: only its predictions, the same numbers as auto's of that lookup
    _, one = choose_within(torus, 10 ** 8, lookup="nearest", candidates=cands, verify=False, **draw)
    assert [t["predicted"]["disagreement"] for t in one["tried"]] == [
        t["predicted"]["disagreement"] for t in c["tried"] if t["predicted"]["lookup"] == "nearest"]
    with pytest.raises(ValueError, match="'nearest', 'vote' or 'auto'"):
        choose_within(torus, 10 ** 8, lookup="best", candidates=cands, **draw)


def test_scene_add_budget_with_auto_lookup_warns_a_query_of_the_other_lookup(box):
    s = pyshadow.Scene(ground=0.0)
    i = s.add(box, pyshadow.stand_on_ground(box), max_bytes=700_000, lookup="auto")
    choice = s.instances[i].csm.choice
    assert choice["lookup"] in ("nearest", "vote") and choice["budget_bytes"] == 700_000
    other = "vote" if choice["lookup"] == "nearest" else "nearest"
    p, d = np.array([[0.0, 0.0, 3.0]]), np.array([[0.0, 0.0, -1.0]])
    with pytest.warns(UserWarning, match=f"within max_bytes=700000 with lookup='{choice['lookup']}'"):
        assert not s.visible(p, d, lookup=other)[0]             # the box is below: occluded whatever the lookup
    assert not s.visible(p, d, lookup=choice["lookup"])[0]      # its own lookup: no warning (errors in this suite)

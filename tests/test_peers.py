"""The arithmetic and geometry of benchmarks/peers.py and benchmarks/table61.py, at toy sizes."""
import sys

import numpy as np
import pytest
import trimesh

import pyshadow
from conftest import REPO

sys.path.insert(0, str(REPO / "benchmarks"))
import peers  # noqa: E402
import table61  # noqa: E402


def test_agreement_counts_by_hand():
    a = np.array([1, 0, 1, 1, 0], bool)
    r = np.array([1, 1, 1, 0, 0], bool)
    # 3 of 5 traced rays equal; 5 ground-decided queries agree: (3 + 5) / 10
    assert peers.agreement(a, r) == {"traced": 0.6, "all": 0.6, "differ": 2}
    assert peers.agreement(a, r, ground=5) == {"traced": 0.6, "all": 0.8, "differ": 2}
    assert peers.agreement(np.zeros(0, bool), np.zeros(0, bool), ground=4)["all"] == 1.0
    with pytest.raises(ValueError, match="equal 1-d shapes"):
        peers.agreement(a, r[:4])


def test_summarize_medians_rates_and_ratios():
    s = peers.summarize({"embreex": [0.3, 0.1, 0.2], "fast": [0.05, 0.5, 0.1]}, 1_000_000)
    assert s["embreex"] == {"median_s": 0.2, "Mq_per_s": pytest.approx(5.0), "ratio": 1.0, "ratio_rounds": 1.0}
    # per round: 0.3/0.05 = 6, 0.1/0.5 = 0.2, 0.2/0.1 = 2 -> median 2
    assert s["fast"] == {"median_s": 0.1, "Mq_per_s": pytest.approx(10.0), "ratio": 2.0,
                         "ratio_rounds": pytest.approx(2.0)}
    s = peers.summarize({"embreex": [1.0, 1.0, 4.0], "fast": [0.25, 1.0, 1.0]}, 10)
    assert s["fast"]["ratio"] == 1.0 and s["fast"]["ratio_rounds"] == 4.0     # 4, 1, 4 -> 4
    assert peers.summarize({"fast": [0.1]}, 10)["fast"]["ratio"] is None


def test_peers_trace_the_casters_embree_traces():
    # the triangles every peer gets are the casters' (the receiver left out), as
    # pyshadow.embree.caster_scene places them: Embree gives identical answers on both
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(4, 8), resolution=16)
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    scene.add(box, trimesh.transformations.translation_matrix([10.3, 0.5, -4.0]))
    scene.add(trimesh.creation.box((4.0, 4.0, 0.1)), trimesh.transformations.translation_matrix([10.0, 2.0, -6.0]),
              casts=False)
    ref, anchor = pyshadow.embree.caster_scene(scene)
    tris = peers.caster_triangles(scene, anchor)
    assert tris.dtype == np.float32 and tris.shape == (12, 3, 3)
    rng = np.random.default_rng(1)
    o = (rng.uniform(-2.0, 2.0, (2000, 3)) + [0.3, 0.5, 0.0]).astype(np.float32)
    d = rng.normal(size=(2000, 3)).astype(np.float32)
    got = pyshadow.embree.EmbreeScene(tris).occluded(o, d)
    assert np.array_equal(got, ref.occluded(o, d))
    assert 0.05 < got.mean() < 0.95          # the rays both hit and miss the box


def test_table61_camera_sees_a_plane_in_every_pixel():
    items = [(p, np.eye(4)) for p in table61.corner_planes()]
    g = pyshadow.render_gbuffer(items, table61.camera(40, 30))
    assert (g["object_id"] >= 0).all()
    assert set(np.unique(g["object_id"])) == {0, 1, 2}      # floor and both walls in view

"""``pyshadow-bench --light`` (pyshadow/bench/light.py): the light's forms, placement and the figures."""
from __future__ import annotations

import math
import types

import numpy as np
import pytest

import pyshadow
from conftest import box_and_ball
from pyshadow.bench.light import light_pass, parse_light, place_light


@pytest.fixture(scope="module")
def small():
    """A box and a sphere on the ground, small CSMs, a 96x72 camera."""
    return box_and_ball((16, 32), 64, 3, (96, 72))


def test_parse_light_forms():
    s = parse_light("sun:90,30")
    assert s["kind"] == "sun"
    np.testing.assert_allclose(s["direction"], [0.0, 0.5, math.sqrt(3) / 2], atol=1e-12)
    assert np.isclose(np.linalg.norm(parse_light("sun")["direction"]), 1.0)
    p = parse_light("point:1,2.5,-3")
    np.testing.assert_array_equal(p["position"], [1.0, 2.5, -3.0])
    assert parse_light("point")["position"] is None


@pytest.mark.parametrize("spec", ["moon", "sun:1", "sun:0,0", "sun:0,95", "sun:a,b", "point:1,2", "point:1,nan,2"])
def test_parse_light_refuses(spec):
    with pytest.raises(ValueError, match="--light"):
        parse_light(spec)


def test_default_point_light_outside_every_caster(small):
    scene, _, _ = small
    pos = place_light(parse_light("point"), scene)["position"]
    for i in scene.casters:
        c, r = scene.instances[i].world_sphere()
        assert np.linalg.norm(pos - c) > r
    with pytest.raises(ValueError, match="inside caster"):
        place_light(parse_light("point:0,0.5,0"), scene)


@pytest.mark.parametrize("spec", ["sun:40,35", "point"])
def test_light_pass_figures(small, tmp_path, spec):
    """Agreement figures equal the answers recomputed here; the scene is back in place afterwards."""
    from pyshadow import embree, render, visibility

    scene, cam, nbytes = small
    T = {i: scene.instances[i].transform.copy() for i in scene.casters}
    light = place_light(parse_light(spec), scene)
    rec, files = light_pass(types.SimpleNamespace(repeats=1), scene, cam, nbytes, light, tmp_path, lambda m: None)
    for i in scene.casters:
        np.testing.assert_array_equal(scene.instances[i].transform, T[i])
    sp = render.surface_points(scene, cam)
    n = sp.normals / np.linalg.norm(sp.normals, axis=1, keepdims=True)
    if light["kind"] == "sun":
        w, t = np.broadcast_to(light["direction"], n.shape), None
    else:
        d = light["position"] - sp.points
        t = np.linalg.norm(d, axis=1)
        w = d / t[:, None]
    sel = np.einsum("ij,ij->i", n, w) >= 0.1
    tt = None if t is None else t[sel]
    truth = embree.visible(scene, sp.points[sel], np.ascontiguousarray(w[sel]), max_distance=tt)
    assert rec["pixels"] == int(sel.sum()) > 1000
    assert rec["shadowed"]["value"] == pytest.approx(1 - truth.mean())
    v = visibility.visible(scene, sp.points[sel], np.ascontiguousarray(w[sel]), max_distance=tt, backend="csm",
                           surface_ids=sp.surface_ids[sel], normals=n[sel])
    m = rec["methods"]
    assert m["csm"]["agreement"]["value"] == pytest.approx(np.mean(v == truth))
    assert m["csm"]["false_shadow"]["value"] + m["csm"]["false_lit"]["value"] == pytest.approx(
        1 - m["csm"]["agreement"]["value"])
    faces = 1 if light["kind"] == "sun" else 6
    R = rec["equal_memory_resolution"]
    assert 4 * faces * R * R <= nbytes < 4 * faces * (R + 1) ** 2
    assert m[f"shadow-map {R}"]["bytes"]["value"] == 4 * faces * R * R
    for row in m.values():                                # shadows of a box and a ball: every method close
        assert row["agreement"]["value"] > 0.97
        assert row["frame_time_moving"]["value"] > 0
    img = pyshadow.read_image(files["shadow.png"])
    assert img.shape[:2] == (cam.height, cam.width)


def test_bench_light_cli(tmp_path):
    """``pyshadow-bench --light`` at tiny settings: a 'light' entry whose csm agreement equals the ray count
    recomputed from its own false-shadow / false-lit split, and shadow.png; bad values exit 2 before any work."""
    import json

    from test_bench import TINY, bench

    p = bench(*TINY, "--light", "sun:-30,25", "--out", tmp_path / "o", "--json", cache=tmp_path / "c")
    rec = json.loads(p.stdout)["light"]
    assert rec["kind"] == "sun" and rec["pixels"] > 100
    assert set(rec["methods"]) >= {"csm", "csm-vote", "shadow-map 1024"}
    for row in rec["methods"].values():
        s = row["agreement"]["value"] + row["false_shadow"]["value"] + row["false_lit"]["value"]
        assert s == pytest.approx(1.0)
    assert (tmp_path / "o" / "shadow.png").is_file()
    for bad, msg in (("moon", "--light"), ("sun:0,0", "elevation")):
        q = bench(*TINY, "--light", bad, "--out", tmp_path / "b", check=False)
        assert q.returncode == 2 and msg in q.stderr
    q = bench(*TINY, "--light", "sun", "--sweep", "--out", tmp_path / "b", check=False)
    assert q.returncode == 2 and "single benchmark" in q.stderr

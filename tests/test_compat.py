"""The deprecated forms of the API (pyshadow._compat): each warns once per process, naming
the new form, and answers bit for bit as the new form does.

Every test calls ``pyshadow._compat.reset()`` first, so that the warning is seen again
whatever ran before (the suite turns warnings into errors: the old forms appear only here).
"""
import re
import sys
import warnings

import numpy as np
import pytest

import pyshadow
from pyshadow import Sampling, _compat, embree
from pyshadow.scene import VOTE_BIAS_TEXELS

from conftest import load, on_ground, unit_frame


@pytest.fixture(scope="module")
def coarse():
    """The bunny on the ground (coarse CSM: quick) with 400 of its vertices and a camera."""
    bunny = load("stanford-bunny.obj")
    scene = pyshadow.Scene(ground=0.0, views=pyshadow.ViewSet.zigzag(8, 16), resolution=32)
    scene.add(bunny, on_ground(bunny, unit_frame(bunny)))
    pts, nrm = scene.vertex_points(0)
    pick = np.random.default_rng(2).choice(len(pts), 400, replace=False)
    pts, nrm = pts[pick], nrm[pick]
    ok = np.linalg.norm(nrm, axis=1) > 0
    cam = pyshadow.Camera([1.5, 1.2, 2.5], [0.0, 0.5, 0.0], width=40, height=30)
    return scene, pts[ok], nrm[ok], cam


def warns_once(call, match):
    """``call()`` under the old form: one DeprecationWarning matching ``match``, pointing at
    the caller; a second call is silent. Returns both answers."""
    _compat.reset()
    with pytest.warns(DeprecationWarning, match=match) as record:
        first = call()
    deprecations = [w for w in record if issubclass(w.category, DeprecationWarning)]
    assert len(deprecations) == 1, [str(w.message) for w in deprecations]
    assert deprecations[0].filename == __file__, deprecations[0].filename     # the caller's line
    assert "deprecated" in str(deprecations[0].message) and "next release" in str(deprecations[0].message)
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)      # once per process: no second warning
        second = call()
    return first, second


def any_order(where, *names):
    """A pattern for the warning of ``where``'s old keywords ``names``, listed in any order."""
    ahead = "".join(rf"(?=[^;]*\b{n}\b)" for n in names)
    return rf"^{ahead}{re.escape(where)}'s [a-z_, ]* arguments is deprecated"


def assert_same(a, b):
    """Equal answers, bit for bit (tuples of arrays, arrays, or Frames)."""
    if isinstance(a, pyshadow.Frame):
        assert isinstance(b, pyshadow.Frame) and list(a) == list(b)
        a, b = [a[k] for k in a], [b[k] for k in b]
    if isinstance(a, (tuple, list)):
        assert isinstance(b, (tuple, list)) and len(a) == len(b)
        for x, y in zip(a, b):
            assert_same(x, y)
        return
    assert a.dtype == b.dtype and a.shape == b.shape
    np.testing.assert_array_equal(a, b)


# ---------------------------------------------------------------------------
# Scene.ambient_occlusion and Scene.vertex_ao: positional sampling, samples=..., bent_normals=
# ---------------------------------------------------------------------------
def test_ambient_occlusion_positional_sampling_arguments(coarse):
    """Old order: samples, strategy, patterns, seed, bent_normals."""
    scene, p, n, _ = coarse
    new = scene.ambient_occlusion(p, n, sampling=Sampling(16, "halton", 32, 3), return_bent_normals=True)
    for call, match in [
        (lambda: scene.ambient_occlusion(p, n, 16, "halton", 32, 3, True),
         r"Scene\.ambient_occlusion's positional samples, strategy, patterns, seed, bent_normals arguments"),
        (lambda: scene.ambient_occlusion(p, n, 16, "halton", 32, 3, return_bent_normals=True),
         r"positional samples, strategy, patterns, seed arguments .*use sampling=pyshadow\.Sampling"),
    ]:
        for old in warns_once(call, match):
            assert_same(old, new)
    old, _ = warns_once(lambda: scene.ambient_occlusion(p, n, 16), r"positional samples argument")
    assert_same(old, scene.ambient_occlusion(p, n, sampling=Sampling(16)))


def test_ambient_occlusion_sampling_keywords(coarse):
    scene, p, n, _ = coarse
    old, again = warns_once(lambda: scene.ambient_occlusion(p, n, samples=24, strategy="stratified", seed=5,
                                                            patterns=8),
                            any_order("Scene.ambient_occlusion", "samples", "strategy", "patterns", "seed"))
    new = scene.ambient_occlusion(p, n, sampling=Sampling(24, "stratified", 8, 5))
    assert_same(old, new)
    assert_same(again, new)
    # one old keyword changes that field of the default Sampling()
    old, _ = warns_once(lambda: scene.ambient_occlusion(p, n, seed=7), "seed argument")
    assert_same(old, scene.ambient_occlusion(p, n, sampling=Sampling(seed=7)))


def test_ambient_occlusion_bent_normals_keyword(coarse):
    scene, p, n, _ = coarse
    s = Sampling(12)
    old, _ = warns_once(lambda: scene.ambient_occlusion(p, n, sampling=s, bent_normals=True),
                        r"bent_normals argument is deprecated .*return_bent_normals=")
    new = scene.ambient_occlusion(p, n, sampling=s, return_bent_normals=True)
    assert isinstance(old, tuple) and len(old) == 2
    assert_same(old, new)
    old, _ = warns_once(lambda: scene.ambient_occlusion(p, n, sampling=s, bent_normals=False), "bent_normals")
    assert_same(old, scene.ambient_occlusion(p, n, sampling=s))


def test_vertex_ao_old_sampling_forms(coarse):
    scene = coarse[0]
    new = scene.vertex_ao(0, sampling=Sampling(16))
    for call in (lambda: scene.vertex_ao(0, 16), lambda: scene.vertex_ao(0, samples=16)):
        for old in warns_once(call, r"Scene\.vertex_ao's (positional )?samples argument"):
            assert_same(old, new)
    old, _ = warns_once(lambda: scene.vertex_ao(0, 16, "halton", 64, 1, True), r"Scene\.vertex_ao's positional")
    assert_same(old, scene.vertex_ao(0, sampling=Sampling(16, "halton", 64, 1), return_bent_normals=True))
    old, _ = warns_once(lambda: scene.vertex_ao(0, bent_normals=True), r"Scene\.vertex_ao's bent_normals")
    assert_same(old, scene.vertex_ao(0, return_bent_normals=True))


# ---------------------------------------------------------------------------
# filtered= (lookup=) and filter= (denoise=)
# ---------------------------------------------------------------------------
def test_filtered_is_lookup(coarse):
    scene, p, n, cam = coarse
    d = pyshadow.sample_directions(n, sampling=Sampling(8)).reshape(-1, 3)
    q = np.repeat(p, 8, axis=0)
    for filtered, lookup in ((True, "vote"), (False, "nearest")):
        new = scene.visible(q, d, lookup=lookup, surface_ids=0)
        for old in warns_once(lambda: scene.visible(q, d, filtered=filtered, surface_ids=0),
                              r"Scene\.visible\(filtered=\.\.\.\) is deprecated .*lookup=\"vote\""):
            assert_same(old, new)
        s = Sampling(8)
        old, _ = warns_once(lambda: scene.ambient_occlusion(p, n, sampling=s, filtered=filtered),
                            r"Scene\.ambient_occlusion\(filtered=\.\.\.\)")
        assert_same(old, scene.ambient_occlusion(p, n, sampling=s, lookup=lookup))
        old, _ = warns_once(lambda: scene.vertex_ao(0, sampling=s, filtered=filtered), r"Scene\.vertex_ao\(filtered=")
        assert_same(old, scene.vertex_ao(0, sampling=s, lookup=lookup))
        old, _ = warns_once(lambda: scene.render(cam, sampling=s, filtered=filtered), r"Scene\.render\(filtered=")
        assert_same(old, scene.render(cam, sampling=s, lookup=lookup))
    assert (scene.visible(q, d, lookup="vote") != scene.visible(q, d)).any()     # not the same lookup


def test_render_filter_is_denoise(coarse):
    scene, _, _, cam = coarse
    s = Sampling(8)
    for name in ("bilateral", "separable", "box"):
        old, _ = warns_once(lambda: scene.render(cam, sampling=s, filter=name),
                            r"Scene\.render\(filter=\.\.\.\) is deprecated .*denoise=")
        assert_same(old, scene.render(cam, sampling=s, denoise=name))


def test_render_positional_sampling_arguments(coarse):
    """Scene.render's old order: samples, strategy, seed, patterns (not Sampling's order)."""
    scene, _, _, cam = coarse
    new = scene.render(cam, sampling=Sampling(8, "halton", 16, 3))
    for old in warns_once(lambda: scene.render(cam, 8, "halton", 3, 16),
                          r"Scene\.render's positional samples, strategy, seed, patterns arguments"):
        assert_same(old, new)
    old, _ = warns_once(lambda: scene.render(cam, samples=8, strategy="halton", seed=3, patterns=16),
                        any_order("Scene.render", "samples", "strategy", "seed", "patterns"))
    assert_same(old, new)
    old, _ = warns_once(lambda: scene.render(cam, 8), r"Scene\.render's positional samples argument")
    assert_same(old, scene.render(cam, sampling=Sampling(8)))


def test_old_and_new_forms_together_are_errors(coarse):
    scene, p, n, cam = coarse
    _compat.reset()
    with pytest.raises(TypeError, match="not both"):
        scene.ambient_occlusion(p, n, 16, sampling=Sampling(16))
    with pytest.raises(TypeError, match="not both"):
        scene.render(cam, samples=8, sampling=Sampling(8))
    with pytest.raises(TypeError, match="'samples' both by position and by keyword"):
        scene.ambient_occlusion(p, n, 16, samples=16)
    with pytest.raises(TypeError, match="at most 5 positional arguments"):
        scene.ambient_occlusion(p, n, 16, "halton", 32, 3, True, 1)
    with pytest.raises(TypeError, match="at most 4 positional arguments"):
        scene.render(cam, 8, "halton", 3, 16, 1)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        with pytest.raises(TypeError, match="pass lookup= or the old filtered=, not both"):
            scene.visible(p, n, lookup="vote", filtered=True)
        with pytest.raises(TypeError, match="pass denoise= or the old filter=, not both"):
            scene.render(cam, denoise="box", filter="bilateral")
        # the old forms check what they pass on as the new ones do
        with pytest.raises(ValueError, match="samples must be in 1..4096, got 0"):
            scene.ambient_occlusion(p, n, samples=0)
        with pytest.raises(ValueError, match="unknown strategy 'sobol'"):
            scene.ambient_occlusion(p, n, 16, "sobol")


# ---------------------------------------------------------------------------
# moved names
# ---------------------------------------------------------------------------
def test_scene_visible_reference_moved(coarse):
    from pyshadow.visibility import visible_reference

    scene, p, n, _ = coarse
    d = pyshadow.sample_directions(n, sampling=Sampling(4)).reshape(-1, 3)
    q = np.repeat(p, 4, axis=0)
    old_fn, _ = warns_once(lambda: pyshadow.scene.visible_reference,
                           r"pyshadow\.scene\.visible_reference is deprecated .*pyshadow\.visibility\.mirror")
    _compat.reset()
    with pytest.warns(DeprecationWarning, match="visible_reference"):
        from pyshadow.scene import visible_reference as imported
    assert imported is old_fn           # the old function: it also takes the old filtered=
    assert_same(old_fn(scene, q, d, surface_ids=0), visible_reference(scene, q, d, surface_ids=0))
    # the old keyword filtered= of the old function: lookup=
    for filtered, lookup in ((True, "vote"), (False, "nearest")):
        _compat.reset()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)
            old = pyshadow.scene.visible_reference(scene, q, d, surface_ids=0, filtered=filtered)
        assert_same(old, visible_reference(scene, q, d, surface_ids=0, lookup=lookup))


def test_scene_shadow_vote_moved():
    from pyshadow.csm.reference import shadow_vote

    old, again = warns_once(lambda: pyshadow.scene.shadow_vote,
                            r"pyshadow\.scene\.shadow_vote is deprecated .*pyshadow\.csm\.reference\.shadow_vote")
    assert old is shadow_vote and again is shadow_vote
    with pytest.raises(AttributeError, match="no attribute 'no_such_name'"):
        pyshadow.scene.no_such_name


def test_filtered_bias_texels_is_vote_bias_texels():
    with pytest.warns(DeprecationWarning, match=r"FILTERED_BIAS_TEXELS .*VOTE_BIAS_TEXELS"):
        assert pyshadow.scene.FILTERED_BIAS_TEXELS == VOTE_BIAS_TEXELS
    from pyshadow.csm import core

    assert core.VOTE_BIAS_TEXELS == VOTE_BIAS_TEXELS


def test_import_pyshadow_reference_is_embree(monkeypatch):
    monkeypatch.delitem(sys.modules, "pyshadow.reference", raising=False)
    monkeypatch.delattr(pyshadow, "reference", raising=False)
    with pytest.warns(DeprecationWarning, match=r"pyshadow\.reference is now pyshadow\.embree"):
        import pyshadow.reference as reference
    for name in embree.__all__:
        assert getattr(reference, name) is getattr(embree, name), name


# ---------------------------------------------------------------------------
# pyshadow.embree's old forms
# ---------------------------------------------------------------------------
def test_embree_ambient_occlusion_old_forms(coarse):
    """embree.ambient_occlusion's old order: samples, strategy, seed, patterns, bent_normals."""
    scene, p, n, _ = coarse
    new = embree.ambient_occlusion(scene, p, n, sampling=Sampling(16, "halton", 32, 3), return_bent_normals=True)
    for old in warns_once(lambda: embree.ambient_occlusion(scene, p, n, 16, "halton", 3, 32, True), "deprecated"):
        assert_same(old, new)
    old, _ = warns_once(lambda: embree.ambient_occlusion(scene, p, n, 16, "halton", seed=3, patterns=32,
                                                         bent_normals=True), "deprecated")
    assert_same(old, new)
    old, _ = warns_once(lambda: embree.ambient_occlusion(scene, p, n, samples=16), "deprecated")
    assert_same(old, embree.ambient_occlusion(scene, p, n, sampling=Sampling(16)))


def test_embree_render_old_forms(coarse):
    """embree.render's old order: samples, strategy, seed, patterns."""
    scene, _, _, cam = coarse
    new = embree.render(scene, cam, sampling=Sampling(8, "halton", 16, 3))
    for old in warns_once(lambda: embree.render(scene, cam, 8, "halton", 3, 16), "deprecated"):
        assert_same(old, new)
    old, _ = warns_once(lambda: embree.render(scene, cam, samples=8), "deprecated")
    assert_same(old, embree.render(scene, cam, sampling=Sampling(8)))


# ---------------------------------------------------------------------------
# keyword-only options after the data: _compat.keyword_only and its users
# ---------------------------------------------------------------------------
@_compat.keyword_only("toy", old=2)
def _toy(a, b=0, *, c=1, d=2, e=3):
    return (a, b, c, d, e)


class _Toy:
    @_compat.keyword_only("_Toy.method")
    def method(self, a, *, c=1, d=2):
        return (self, a, c, d)

    @classmethod
    @_compat.keyword_only("_Toy.make")
    def make(cls, a, *, c=1):
        return (cls, a, c)


def test_keyword_only_maps_old_positionals_in_declared_order():
    match = r"^toy's positional c argument is deprecated .*use keywords \(c=\)$"
    assert warns_once(lambda: _toy(0, 1, 5), match) == ((0, 1, 5, 2, 3),) * 2
    assert warns_once(lambda: _toy(0, 1, 5, 6, e=7), r"^toy's positional c, d arguments is deprecated") \
        == ((0, 1, 5, 6, 7),) * 2
    toy = _Toy()
    assert warns_once(lambda: toy.method(0, 5, 6), r"_Toy\.method's positional c, d arguments") \
        == ((toy, 0, 5, 6),) * 2
    assert warns_once(lambda: _Toy.make(0, 5), r"_Toy\.make's positional c argument") == ((_Toy, 0, 5),) * 2


def test_keyword_only_new_forms_do_not_warn():
    _compat.reset()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert _toy(0) == (0, 0, 1, 2, 3) and _toy(0, 1, c=5, e=7) == (0, 1, 5, 2, 7)
        assert _toy(a=0, b=1, d=6) == (0, 1, 1, 6, 3)
        assert _Toy.make(0, c=5)[1:] == (0, 5)
    import inspect

    assert str(inspect.signature(_toy)) == "(a, b=0, *, c=1, d=2, e=3)"       # help() shows the new form


def test_keyword_only_refuses_both_ways_and_too_many():
    _compat.reset()
    with pytest.raises(TypeError, match="toy got 'c' both by position and by keyword"):
        _toy(0, 1, 5, c=5)
    with pytest.raises(TypeError, match=r"toy takes at most 2 options by position \(deprecated\) "
                                        r"after the data \(3 given\)"):
        _toy(0, 1, 5, 6, 7)                                 # e was never positional (old=2)
    with pytest.raises(TypeError, match="at most 1 options"):
        _Toy.make(0, 5, 6)
    with pytest.raises(TypeError, match="unexpected keyword"):
        _toy(0, f=1)
    with pytest.raises(TypeError, match="needs keyword-only options"):
        _compat.keyword_only("bad")(lambda a, b=1: a)


@pytest.fixture(scope="module")
def small_gbuffer():
    rng = np.random.default_rng(3)
    depth = (2.0 + 0.05 * rng.random((12, 16))).astype(np.float32)
    depth[0, :3] = np.inf
    normal = np.zeros((12, 16, 3), np.float32)
    normal[..., 2] = 1.0
    normal[:, 8:] = [0.0, 0.6, 0.8]
    ao = rng.random((12, 16)).astype(np.float32)
    return ao, depth, normal


def test_filters_positional_options(small_gbuffer):
    from pyshadow import filters

    ao, depth, normal = small_gbuffer
    low = ao[::2, ::2].copy()
    g = (ao, depth, normal)
    cases = [
        (lambda: pyshadow.bilateral(*g, 2, 1.5, 0.05, 0.3),
         lambda: pyshadow.bilateral(*g, radius=2, sigma_spatial=1.5, sigma_depth=0.05, sigma_normal=0.3),
         r"pyshadow\.bilateral's positional radius, sigma_spatial, sigma_depth, sigma_normal arguments"),
        (lambda: filters.bilateral_reference(*g, 2, 1.5, separable=True),
         lambda: filters.bilateral_reference(*g, radius=2, sigma_spatial=1.5, separable=True),
         r"bilateral_reference's positional radius, sigma_spatial arguments"),
        (lambda: filters.separable_reference(*g, 2), lambda: filters.separable_reference(*g, radius=2),
         "separable_reference's positional radius argument"),
        (lambda: pyshadow.edge_aware_box(*g, 5, 0.03, 0.8),
         lambda: pyshadow.edge_aware_box(*g, size=5, depth_threshold=0.03, normal_threshold=0.8),
         r"pyshadow\.edge_aware_box's positional size, depth_threshold, normal_threshold arguments"),
        (lambda: filters.edge_aware_box_reference(*g, 5),
         lambda: filters.edge_aware_box_reference(*g, size=5),
         "edge_aware_box_reference's positional size argument"),
        (lambda: pyshadow.upsample(low, depth, normal, 2, 1, fill=0.5),
         lambda: pyshadow.upsample(low, depth, normal, scale=2, radius=1, fill=0.5),
         r"pyshadow\.upsample's positional scale, radius arguments .*use keywords \(scale=, radius=\)"),
        (lambda: filters.upsample_reference(low, depth, normal, 2, 2, 1.0, 0.05, 0.3),
         lambda: filters.upsample_reference(low, depth, normal, scale=2, radius=2, sigma_spatial=1.0,
                                            sigma_depth=0.05, sigma_normal=0.3),
         "upsample_reference's positional scale, radius, sigma_spatial, sigma_depth, sigma_normal arguments"),
    ]
    for old, new, match in cases:
        for answer in warns_once(old, match):
            assert_same(answer, new())
    with pytest.raises(TypeError, match="both by position and by keyword"):
        pyshadow.bilateral(ao, depth, normal, 2, radius=2)
    with pytest.raises(TypeError, match="at most 4 options"):
        pyshadow.bilateral(*g, 2, 1.5, 0.05, 0.3, False)                   # separable was never positional


def test_render_depth_and_build_positional_options():
    from pyshadow.raster import render_depth_reference

    mesh = load("teapot.obj")
    views = pyshadow.ViewSet.zigzag(2, 4)
    for old, new, match in [
        (lambda: pyshadow.render_depth(mesh, views, 16, 3),
         lambda: pyshadow.render_depth(mesh, views, resolution=16, layers=3),
         r"pyshadow\.render_depth's positional resolution, layers arguments"),
        (lambda: render_depth_reference(mesh, views[0:1], 8, facing=True),
         lambda: render_depth_reference(mesh, views[0:1], resolution=8, facing=True),
         r"render_depth_reference's positional resolution argument"),
        (lambda: embree.depth_layers(mesh, views, 16, 1),
         lambda: embree.depth_layers(mesh, views, resolution=16, layers=1),
         r"embree\.depth_layers's positional resolution, layers arguments"),
    ]:
        for answer in warns_once(old, match):
            assert_same(answer, new())
    with pytest.raises(TypeError, match="at most 2 options"):
        pyshadow.render_depth(mesh, views, 16, 2, None)                     # frame was never positional
    build = pyshadow.CoherentShadowMap.build
    new = build(mesh, views, resolution=16, depth_bits=32, layers=2, progress=False)
    old, _ = warns_once(lambda: build(mesh, views, 16, 32, 2, None, False),
                        r"CoherentShadowMap\.build's positional resolution, depth_bits, layers, block, progress ")
    assert_same((old.offsets, old.iend, old.depth), (new.offsets, new.iend, new.depth))
    with pytest.raises(TypeError, match="'progress' both by position and by keyword"):
        build(mesh, views, 16, 32, 2, None, False, progress=False)


def test_sample_directions_old_forms():
    n = np.random.default_rng(5).normal(size=(300, 3))
    idx = np.arange(300) * 3
    s = Sampling(16, "halton", 32, 3)
    reference = pyshadow.sampling.sample_directions_reference
    new, ref = s.directions(n, indices=idx), reference(n, sampling=s, indices=idx)
    for call in (lambda: pyshadow.sample_directions(n, 16, "halton", 32, 3, indices=idx),
                 lambda: pyshadow.sample_directions(n, 16, "halton", seed=3, patterns=32, indices=idx)):
        for answer in warns_once(call, r"pyshadow\.sample_directions's .*use sampling=pyshadow\.Sampling"):
            assert_same(answer, new)
    old, _ = warns_once(lambda: reference(n, 16, "halton", 32, 3, indices=idx),
                        r"sample_directions_reference's positional samples, strategy, patterns, seed arguments")
    assert_same(old, ref)
    old, _ = warns_once(lambda: pyshadow.sample_directions(n, samples=16), r"directions's samples argument")
    assert_same(old, pyshadow.sample_directions(n, sampling=Sampling(16)))
    with pytest.raises(TypeError, match="not both"):
        pyshadow.sample_directions(n, 16, sampling=s)
    with pytest.raises(TypeError, match="at most 4 positional arguments"):
        pyshadow.sample_directions(n, 16, "halton", 32, 3, idx)              # indices was never positional
    with pytest.raises(TypeError, match="unexpected keyword argument 'sample'"):
        pyshadow.sample_directions(n, sample=16)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        for call in (pyshadow.sample_directions, reference):          # the old forms check as Sampling does
            with pytest.raises(ValueError, match="samples must be in 1..4096, got 0"):
                call(n, samples=0)
            with pytest.raises(ValueError, match="unknown strategy 'sobol'"):
                call(n, 8, "sobol")


def test_scene_add_positional_casts():
    bunny = load("stanford-bunny.obj")
    scene = pyshadow.Scene(views=pyshadow.ViewSet.zigzag(2, 4), resolution=8)
    match = r"Scene\.add's positional casts argument .*use keywords \(casts=\)"
    for i, answer in enumerate(warns_once(lambda: scene.add(bunny, None, False), match)):
        assert answer == i and not scene.instances[i].casts and scene.instances[i].csm is None
    with pytest.raises(TypeError, match="at most 1 options"):
        scene.add(bunny, None, False, None)                                   # mesh was never positional
    with pytest.raises(TypeError, match="'casts' both by position and by keyword"):
        scene.add(bunny, None, False, casts=False)

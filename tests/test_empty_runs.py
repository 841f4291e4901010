"""Empty runs of maps (pyshadow.csm.device.empty_bits; EMPTY_RUNS in kernels/csm_lookup.h and
kernels/batch.h): the one-texel lookups whose maps all miss the mesh at their texel are answered
open without a search; with a bit for every map, those whose point lies behind every surface of
the caster (its sphere far behind, or another body) over a texel that holds a surface are answered
occluded without one. The bits against a per-map reading of the segment lists, on every shared
mesh; the kernels' answers bit-identical with and without them, with a bit for every map and for
runs of maps, and under a bias that leaves the search the only answer; bits that claim everything
empty, or nothing, change the answers (the kernels read them)."""
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import pyshadow
from pyshadow.csm import device
from pyshadow.visibility import csm as csm_backend


def _misses_per_map(csm):
    """(R*R, D) bool: whether map k stores a miss at texel t, read segment by segment."""
    R, D = csm.resolution, csm.maps
    off = np.asarray(csm.offsets, np.int64)
    iend = np.asarray(csm.iend, np.int64)
    miss = np.isinf(csm.stored_to_depth(np.asarray(csm.depth)))
    out = np.zeros((R * R, D), bool)
    for t in range(R * R):
        start = 0
        for s in range(off[t], off[t + 1]):
            out[t, start:iend[s] + 1] = miss[s]
            start = iend[s] + 1
        assert start == D
    return out


def _bits_reference(misses, words):
    """The bits of empty_bits from the per-map table: run c of texel t set where all its maps miss."""
    D = misses.shape[1]
    shift = 0
    while D > (32 * words) << shift:
        shift += 1
    runs = np.arange(D) >> shift
    want = np.zeros((misses.shape[0], 32 * words), bool)
    for c in range(runs[-1] + 1):
        want[:, c] = misses[:, runs == c].all(axis=1)
    return want, shift


@pytest.fixture(scope="module")
def shared_csms():
    out = {}
    for name in pyshadow.data.MESHES:
        views = pyshadow.ViewSet.zigzag(6, 12) if name != "teapot.obj" else pyshadow.ViewSet.hilbert(3)
        out[name] = pyshadow.CoherentShadowMap.build(pyshadow.data.mesh(name.split(".")[0]), views,
                                                     resolution=24, progress=False)
    return out


@pytest.mark.parametrize("words", [1, 2, 3])
def test_empty_bits_match_the_segment_lists_on_every_shared_mesh(shared_csms, words):
    for name, csm in shared_csms.items():
        misses = _misses_per_map(csm)
        got, shift = device.empty_bits(csm, words)
        want, want_shift = _bits_reference(misses, words)
        assert shift == want_shift and got.dtype == np.uint32 and got.shape == (csm.resolution ** 2, words)
        bits = np.unpackbits(got.view(np.uint8), axis=1, bitorder="little").astype(bool)
        assert np.array_equal(bits, want), name
        # something to skip and something to search on every mesh: whole texels outside the mesh in every
        # map, and runs next to them holding it
        assert 0 < bits.sum() < bits[:, :-(-csm.maps >> shift)].size, name


def test_empty_words_follow_the_budget(shared_csms):
    assert device.empty_words(64, 512) == 16               # a bit per map: 64^2 x 64 bytes = 256 KiB
    assert device.empty_words(128, 8192) == 4              # 128^2 texels: 4 words in 256 KiB
    assert device.empty_words(512, 8192) == 1              # at least one word
    assert device.empty_words(32, 40) == 2                 # a bit per map, no more
    for bad in (0, True, 2.0):
        with pytest.raises(ValueError, match="words must be an integer >= 1"):
            device.empty_bits(shared_csms["spot.obj"], bad)


def _two_type_scene(n):
    """n casters of two CSM types (different maps and resolutions: words and shifts differ) on a grid."""
    spot, fan = pyshadow.data.mesh("spot"), pyshadow.data.mesh("fandisk")
    a = pyshadow.CoherentShadowMap.build(spot, pyshadow.ViewSet.zigzag(16, 32), resolution=32, progress=False)
    b = pyshadow.CoherentShadowMap.build(fan, pyshadow.ViewSet.zigzag(8, 16), resolution=48, progress=False)
    s = pyshadow.Scene(ground=0.0)
    k = int(np.ceil(np.sqrt(n)))
    rng = np.random.default_rng(5)
    for i in range(n):
        T = np.eye(4)
        T[:3, :3] = Rotation.random(random_state=i).as_matrix() * rng.uniform(0.2, 0.5)
        T[:3, 3] = [i % k - k / 2, rng.uniform(0.8, 1.1), i // k - k / 2]   # clear of the ground: no contacts
        s.add(a if i % 3 else b, T, mesh=spot if i % 3 else fan)
    return s, k


def _queries(k, m, seed=6):
    rng = np.random.default_rng(seed)
    P = np.c_[rng.uniform(-k / 2, k / 2, m), np.zeros(m), rng.uniform(-k / 2, k / 2, m)]
    D = rng.normal(size=(m, 3))
    D[:, 1] = np.abs(D[:, 1]) * 0.5                       # upward, many of them low among the casters
    up = np.tile([0.0, 1.0, 0.0], (m, 1))
    return P, D, up


def _answers(s, P, D, up):
    ao, bent = s.ambient_occlusion(P[:600], up[:600], sampling=pyshadow.Sampling(16), return_bent_normals=True)
    return [s.visible(P, D), s.visible(P, D, normals=up), ao, bent]


def _forced(monkeypatch, on):
    defines = csm_backend.CSMVisibility._defines
    monkeypatch.setattr(csm_backend.CSMVisibility, "_defines",
                        lambda self, *a, **kw: {**defines(self, *a, **kw), "EMPTY_RUNS": int(on)})


@pytest.mark.parametrize("n, grid", [(3, True), (40, True), (40, False)])   # every caster, the grid, the tree
def test_kernels_answer_bit_identical_with_and_without_empty_runs(monkeypatch, n, grid):
    monkeypatch.setattr(csm_backend, "USE_GRID", grid)
    s, k = _two_type_scene(n)
    assert csm_backend.instance_accel(s) == ("all" if n < 16 else "grid" if grid else "tree")
    P, D, up = _queries(k, 6000)
    with monkeypatch.context() as m:
        _forced(m, True)
        on = _answers(s, P, D, up)
    _forced(monkeypatch, False)
    off = _answers(s, P, D, up)
    for x, y in zip(on, off):
        assert np.array_equal(x, y)
    assert 50 < (~on[0]).sum() < 0.9 * len(P)               # rays the casters occlude, and open ones


@pytest.mark.parametrize("words, bias", [(None, None), (1, None), (None, 1.5)])
def test_lookups_behind_every_surface_answer_as_the_search(monkeypatch, words, bias):
    """A bit for every map (shift 0: both types here) answers the lookups behind every surface; runs of maps
    (one word: shifts 2 and 4) leave them to the search; a bias of 1.5 (a stored depth of 0.5 and more plus
    the bias is not below the depth 2 of such a point) too."""
    if words is not None:
        monkeypatch.setattr(device, "empty_words", lambda R, D: words)
    s, k = _two_type_scene(40)
    shifts = [device._empty_shift(c.maps, device.empty_words(c.resolution, c.maps)) for c in s.caster_types()[0]]
    assert shifts == ([0, 0] if words is None else [2, 4])
    P, D, up = _queries(k, 6000, seed=8)
    D[::2] = -P[::2] + [0.0, 1.0, 0.0]                     # half of them towards a caster's height over the origin
    D[::2, 1] = np.abs(D[::2, 1])

    def answers():
        return [s.visible(P, D, bias=bias), s.visible(P, D, normals=up, bias=bias)]
    with monkeypatch.context() as m:
        _forced(m, True)
        on = answers()
    _forced(monkeypatch, False)
    off = answers()
    for x, y in zip(on, off):
        assert np.array_equal(x, y)
    assert 100 < (~on[0]).sum() < 0.9 * len(P)


def test_bits_claiming_no_run_empty_occlude_the_lookups_behind_every_surface(monkeypatch):
    """Bits that claim a surface in every map of every texel: the lookups of points behind every surface of
    their caster are answered occluded from them (the search would open those over texels without one);
    the others still search and keep their answers."""
    s, k = _two_type_scene(40)
    P, D, up = _queries(k, 4000)
    real = s.visible(P, D)
    bits = device._empty_bits
    monkeypatch.setattr(device, "_empty_bits", lambda *source: (lambda b, shift: (b & 0, shift))(*bits(*source)))
    t, _ = _two_type_scene(40)
    claimed = t.visible(P, D)
    assert not (claimed & ~real).any()                      # nothing opens
    assert (real & ~claimed).sum() > 100                    # and many more are occluded


def test_empty_runs_are_read_among_many_casters_and_by_the_one_texel_lookup_only():
    few, _ = _two_type_scene(3)
    many, _ = _two_type_scene(40)
    be = csm_backend.CSMVisibility
    assert be("nearest").query_defines(many)["EMPTY_RUNS"] == 1
    assert be("nearest").query_defines(few)["EMPTY_RUNS"] == 0     # a lone body's rays mostly leave its surface
    assert be("vote").query_defines(many)["EMPTY_RUNS"] == 0


def test_bits_claiming_every_run_empty_open_every_caster_lookup(monkeypatch):
    s, k = _two_type_scene(40)
    P, D, up = _queries(k, 4000)
    real = s.visible(P, D)
    bits = device._empty_bits
    monkeypatch.setattr(device, "_empty_bits", lambda *source: (lambda b, shift: (b | 0xFFFFFFFF, shift))(
        *bits(*source)))
    t, _ = _two_type_scene(40)                              # its atlas built with the claimed bits
    claimed = t.visible(P, D)
    assert (~real).sum() > 100 and claimed.all()            # the ground occludes none of these upward rays
    # the vote reads no bits: its answers stay
    assert np.array_equal(t.visible(P, D, lookup="vote"), s.visible(P, D, lookup="vote"))


def test_bits_follow_the_arrays_the_atlas_was_built_from():
    s, k = _two_type_scene(40)
    P, D, up = _queries(k, 4000)
    vote = s.visible(P, D, lookup="vote")                  # builds the atlas; the vote reads no bits
    csm = s.caster_types()[0][0]
    want = _two_type_scene(40)[0].visible(P, D)
    csm.depth = np.full_like(csm.depth, np.iinfo(np.uint16).max)   # every segment a miss, set after the atlas
    assert np.array_equal(s.visible(P, D), want)           # the bits of the atlas's arrays, not these
    assert np.array_equal(s.visible(P, D, lookup="vote"), vote)

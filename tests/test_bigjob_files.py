"""Long jobs on large meshes (bigjob): a build's memory held in proportion to the CSM it makes, and a
.csm header's version refused unless it is the integer 1."""
import shutil
import tracemalloc

import pytest

import pyshadow
from pyshadow import CoherentShadowMap, CSMFormatError

from conftest import load
from test_csmfuzz_files import resealed_with


@pytest.fixture(scope="module")
def teapot():
    return load("teapot.obj")


def _with_header(path, out, **edits):
    """``path`` copied to ``out`` with header ``edits`` and a valid checksum."""
    shutil.copyfile(path, out)
    return resealed_with(out, **edits)


@pytest.mark.parametrize("version", [True, 1.0, "1", None])
def test_bigjob_header_version_must_be_the_integer_one(tmp_path, teapot, version):
    """JSON's ``true`` equals 1 in Python: it (and 1.0, "1", null) was taken for version 1."""
    csm = CoherentShadowMap.build(teapot, pyshadow.ViewSet.zigzag(2, 4), resolution=8, progress=False)
    good = csm.save(tmp_path / "good.csm")
    assert CoherentShadowMap.load(_with_header(good, tmp_path / "same.csm", version=1)).segments == csm.segments
    bad = _with_header(good, tmp_path / "bad.csm", version=version)
    with pytest.raises(CSMFormatError, match="pyshadow-csm version 1"):
        CoherentShadowMap.load(bad)


def _traced_peak(fn):
    tracemalloc.start()
    try:
        out = fn()
        return out, tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


def test_bigjob_build_memory_does_not_grow_with_blocks(teapot):
    """A block of maps kept R^2 4-byte counts until the end: 512 one-map blocks of 128^2 texels held
    33 MB of counts for a 2 MB CSM (4096^2 texels, 8,192 maps: 550 GB). Held now in proportion to the
    segments, the peak of one-map blocks is within a few CSMs of the default's."""
    views = pyshadow.ViewSet.zigzag(16, 32)
    CoherentShadowMap.build(teapot, pyshadow.ViewSet.zigzag(2, 4), resolution=8, progress=False)   # compiled
    ref, peak_default = _traced_peak(lambda: CoherentShadowMap.build(teapot, views, resolution=128, progress=False))
    csm, peak_one = _traced_peak(lambda: CoherentShadowMap.build(teapot, views, resolution=128, block=1,
                                                                 progress=False))
    for name in ("offsets", "iend", "depth"):
        assert getattr(csm, name).tobytes() == getattr(ref, name).tobytes()
    assert peak_one <= peak_default + 2 * csm.stats["bytes"] + (4 << 20), (peak_one, peak_default)


def test_bigjob_progress_bar_opens_before_the_slow_preparation(monkeypatch):
    """The bar opened only at the first map: on an open mesh of 10^6 faces the exposed backs alone took
    22 s without a sign on the terminal. It now opens first and names the step under way."""
    import tqdm.auto

    from pyshadow.csm import build as build_mod

    events = []

    class Bar:
        def __init__(self, *a, **k):
            events.append("open")

        def set_postfix_str(self, s):
            events.append(f"stage {s}")

        def update(self, n):
            events.append("update")

        def close(self):
            events.append("close")

    real = build_mod.both_sided_faces
    monkeypatch.setattr(tqdm.auto, "tqdm", Bar)
    monkeypatch.setattr(build_mod, "both_sided_faces", lambda *a, **k: events.append("backs") or real(*a, **k))
    open_mesh = load("teapot.obj")
    assert not open_mesh.is_watertight
    CoherentShadowMap.build(open_mesh, pyshadow.ViewSet.zigzag(2, 4), resolution=8, progress=True)
    assert events.index("open") < events.index("stage exposed backs") < events.index("backs") < \
        events.index("update") < events.index("close")
    assert events[-1] == "close"
    # an error in the preparation closes the bar as well
    events.clear()
    monkeypatch.setattr(build_mod, "both_sided_faces", lambda *a, **k: (_ for _ in ()).throw(KeyboardInterrupt))
    with pytest.raises(KeyboardInterrupt):
        CoherentShadowMap.build(open_mesh, pyshadow.ViewSet.zigzag(2, 4), resolution=8, progress=True)
    assert events[0] == "open" and events[-1] == "close"


def test_bigjob_choice_names_its_steps(monkeypatch, teapot):
    """build(max_error=) showed nothing but the last build's bar: on a mesh of 10^6 faces its pilots,
    predictions and check took minutes in silence. A bar over the steps now names each."""
    import tqdm.auto

    from pyshadow.csm.choose import choose_csm, choose_within

    bars = []

    class Bar:
        def __init__(self, *a, desc="", **k):
            self.desc, self.steps, self.closed = desc, [], False
            bars.append(self)

        def set_postfix_str(self, s, refresh=True):
            self.steps.append(s)

        def update(self, n=1):
            pass

        def close(self):
            self.closed = True

    monkeypatch.setattr(tqdm.auto, "tqdm", Bar)
    kw = dict(points=200, samples=4, near=400, candidates=[(8, 16, 32)], progress=True)
    with pytest.warns(UserWarning):         # a target so small that no candidate meets it
        choose_csm(teapot, 1e-6, **kw)
    choice = next(b for b in bars if b.desc == "CSM choice")
    assert choice.closed and choice.steps[:2] == ["rays of the error model", "pilot builds"]
    assert choice.steps[2:] == ["predict 8x16 r32 (nearest)", "build 8x16 r32", "verify 8x16 r32 (nearest)"]
    bars.clear()
    choose_within(teapot, 10 ** 9, **kw)
    choice = next(b for b in bars if b.desc == "CSM choice")
    assert choice.closed and choice.steps[-2:] == ["build 8x16 r32", "verify 8x16 r32 (nearest)"]
    bars.clear()
    with pytest.warns(UserWarning):
        choose_csm(teapot, 1e-6, **{**kw, "progress": False})
    assert not any(b.desc == "CSM choice" for b in bars)


def test_bigjob_build_says_when_the_segments_cannot_be_assembled(monkeypatch, teapot):
    """A build whose segments outgrow the memory left was killed by the system (no reason given) at the
    assembly, after all its maps' work; it is now a MemoryError naming the sizes once the segments held
    exceed the memory left, and the progress bar is closed."""
    from pyshadow.csm import build as build_mod

    views = pyshadow.ViewSet.zigzag(8, 16)
    monkeypatch.setattr(build_mod, "available_memory", lambda: 1000)
    with pytest.raises(MemoryError, match=r"after \d+ of 128 maps of 64\^2 texels .* memory is left"):
        CoherentShadowMap.build(teapot, views, resolution=64, block=1, progress=False)
    monkeypatch.setattr(build_mod, "available_memory", lambda: None)       # unknown: no check
    assert CoherentShadowMap.build(teapot, views, resolution=64, block=1, progress=False).maps == 128
    monkeypatch.undo()
    free = build_mod.available_memory()
    assert free is None or free > 0

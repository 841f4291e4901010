"""pyshadow-bench's converged references are cached under a key that covers the code that traces them."""
from pathlib import Path

import pytest

import pyshadow
from pyshadow.cache import CSMCache
from pyshadow.sampling import Sampling

from conftest import modules_run

#: Modules whose functions run in a reference's tracing without deciding its values: the device and launch
#: choice, argument checks, the cache's file store and its check of a cached array.
LAUNCH_ONLY = ("_compat.py", "_validate.py", "lighting/_checks.py", "bench/common.py", "cache.py")


@pytest.fixture(scope="module")
def tiny():
    """The bundled scene at 4x8 maps of 16^2 texels, 32x24 pixels: (scene, covered pixels)."""
    from pyshadow.bench import Config, GBuffer, SceneFactory

    scene, cam, _ = SceneFactory(None, (32, 24), CSMCache(None), False)(Config((4, 8), 16, 16, 4))
    return scene, GBuffer.from_render(scene.render(cam, sampling=Sampling(1)), cam, scene)


def _references(cache, scene, gb):
    """(source of the unlimited reference, source of the distance-limited one), 8 samples a pixel."""
    from pyshadow.bench.measure import converged_reference
    from pyshadow.bench.methods import limited_reference
    from pyshadow.embree import EmbreeTracer

    with EmbreeTracer(scene, 1) as tracer:
        return (converged_reference(cache, tracer, scene, gb, 8, "hammersley", 0, 16, lambda m: None)[2],
                limited_reference(cache, tracer, scene, gb, 0.8, 8, "hammersley", 0, 16, lambda m: None)[2])


def test_reference_sources_cover_every_module_the_tracing_runs(tiny):
    """Was: the key named pyshadow's version alone of the code (REFERENCE_SOURCES did not exist): every module
    whose functions run while the references are traced (sys.setprofile) is in REFERENCE_SOURCES, but for
    the launch and checks of LAUNCH_ONLY."""
    from pyshadow.bench.measure import REFERENCE_SOURCES

    pkg = Path(pyshadow.__file__).resolve().parent
    ran = modules_run(lambda: _references(CSMCache(None), *tiny))
    assert {"embree.py", "sampling.py", "bench/measure.py", "bench/methods.py"} <= ran
    extra = {f for f in ran if not f.startswith("_cl/") and f not in LAUNCH_ONLY} - set(REFERENCE_SOURCES)
    assert not extra, extra
    assert all((pkg / f).is_file() for f in REFERENCE_SOURCES)


@pytest.mark.parametrize("changed", ["_embree_lift.py", "methods.py", "sampling.h"])
def test_a_cached_reference_of_other_code_is_traced_again(tiny, tmp_path, monkeypatch, changed):
    """Was: a reference cached before a change to the code that traces it was read back as if current, here
    ('cached', 'cached') a third time: the key held pyshadow's version, not the code (30f924a made the limited
    pass re-trace rays grazing their own surface, 73 of 3,072 rays of its test answered otherwise, and kept
    the key). The Embree lift, the limited pass (bench/methods.py) and the sampling kernel's header each
    decide a reference."""
    cache = CSMCache(tmp_path)
    assert _references(cache, *tiny) == ("computed", "computed")
    assert _references(cache, *tiny) == ("cached", "cached")
    real_bytes, real_text = Path.read_bytes, Path.read_text          # the file edited on disk
    monkeypatch.setattr(Path, "read_bytes", lambda p: real_bytes(p) + (b"\n" if p.name == changed else b""))
    monkeypatch.setattr(Path, "read_text", lambda p, *a, **k: real_text(p, *a, **k) + ("\n" if p.name == changed
                                                                                         else ""))
    assert _references(cache, *tiny) == ("computed", "computed")

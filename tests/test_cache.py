"""pyshadow.cache: the on-disk CSM cache, in process (the bench's use of it through the
command line is tested in test_bench.py)."""
from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import pytest

import pyshadow
from pyshadow.cache import CSMCache, default_cache_dir
from pyshadow.mesh import mesh_hash

from conftest import load, modules_run

RES, BITS = 16, 16


@pytest.fixture(scope="module")
def mesh():
    return load("spot.obj")


@pytest.fixture(scope="module")
def views():
    return pyshadow.ViewSet.zigzag(4, 8)


class Log(list):
    """A ``log`` callable that keeps the messages."""

    def __call__(self, msg):
        self.append(msg)

    def text(self):
        return "\n".join(self)


def _files(root):
    return sorted(p.relative_to(root).as_posix() for p in root.rglob("*") if p.is_file())


def _same_csm(a, b):
    """Both CSMs hold the same maps (their files differ in the recorded build time)."""
    return (all(getattr(a, k) == getattr(b, k)
                for k in ("mesh_hash", "maps", "resolution", "depth_bits", "layer_rule", "radius"))
            and a.views.layout == b.views.layout and a.views.params == b.views.params
            and all(np.array_equal(getattr(a, k), getattr(b, k))
                    for k in ("centre", "offsets", "iend", "depth")))


def test_csm_cache_builds_once_then_loads(tmp_path, mesh, views):
    root = tmp_path / "cache"
    log = Log()
    csm1, info1 = CSMCache(root, log).csm("spot", mesh, views, RES, BITS)
    assert info1["source"] == "built" and info1["name"] == "spot"
    assert "building the CSM of spot" in log.text()
    mh = mesh_hash(mesh)
    key = CSMCache(root).csm_key(mh, views, RES, BITS, "auto")
    path = root / "csm" / f"{mh[:12]}-{key[:24]}.csm"
    assert info1["file"] == str(path)
    assert _files(root) == [f"csm/{path.name}", f"csm/{path.with_suffix('.json').name}"]
    meta = json.loads(path.with_suffix(".json").read_text())
    assert meta == {"key": key, "build_seconds": info1["build_seconds"], "name": "spot"}
    assert info1["build_seconds"] == info1["seconds"] > 0
    assert info1["stats"] == csm1.stats
    before = {p: p.stat().st_mtime_ns for p in root.rglob("*") if p.is_file()}

    # a new cache object on the same folder: loaded, not rebuilt or rewritten
    log = Log()
    csm2, info2 = CSMCache(root, log).csm("spot again", mesh, views, RES, BITS)
    assert info2["source"] == "cached" and info2["name"] == "spot again"
    assert "building" not in log.text()
    assert info2["build_seconds"] == info1["build_seconds"]            # the original build's
    assert info2["file"] == info1["file"] and info2["stats"] == csm2.stats
    for k in ("bytes", "segments", "ratio"):
        assert info2["stats"][k] == info1["stats"][k], k
    assert all(p.stat().st_mtime_ns == t for p, t in before.items())
    assert _same_csm(csm1, csm2)


def test_csm_cache_sidecar_missing_build_time_unknown(tmp_path, mesh, views):
    cache = CSMCache(tmp_path)
    _, info = cache.csm("spot", mesh, views, RES, BITS)
    os.unlink(os.path.splitext(info["file"])[0] + ".json")
    _, info = cache.csm("spot", mesh, views, RES, BITS)
    assert info["source"] == "cached" and info["build_seconds"] is None


def test_csm_cache_key_covers_every_parameter(mesh, views, monkeypatch):
    import pyshadow.cache as cache_module

    cache = CSMCache(None)
    mh = mesh_hash(mesh)
    key = cache.csm_key(mh, views, RES, BITS, "auto")
    assert len(key) == 64 and int(key, 16) >= 0
    assert CSMCache(None).csm_key(mh, views, RES, BITS, "auto") == key          # stable
    others = [
        cache.csm_key(mesh_hash(load("cow.obj")), views, RES, BITS, "auto"),
        cache.csm_key(mh, pyshadow.ViewSet.zigzag(4, 9), RES, BITS, "auto"),
        cache.csm_key(mh, views, RES + 1, BITS, "auto"),
        cache.csm_key(mh, views, RES, 32, "auto"),
        cache.csm_key(mh, views, RES, BITS, 2),
    ]
    assert len({key, *others}) == 1 + len(others)
    # the code a CSM is built by (version, kernel sources) is part of the key
    monkeypatch.setattr(cache_module, "_code_digest", lambda: "other code")
    assert CSMCache(None).csm_key(mh, views, RES, BITS, "auto") != key


def test_code_digest_depends_on_the_build_kernels(monkeypatch):
    from pyshadow import _cl
    from pyshadow.cache import _code_digest

    d = _code_digest()
    assert len(d) == 64 and _code_digest() == d
    real = _cl.kernel_source
    monkeypatch.setattr(_cl, "kernel_source",
                        lambda name: real(name) + ("\n// changed" if name == "csm.cl" else ""))
    assert _code_digest() != d


def test_code_digest_covers_every_module_a_build_runs(mesh, monkeypatch):
    """Every module of the package whose functions run in a build (zigzag and Hilbert views, closed and
    open meshes, footprint, 'auto' backs: traced with sys.setprofile) is in BUILD_SOURCES, but for the
    device and launch choice (_cl, answers the same at every lane width) and the argument checks
    (_compat, _validate); and a change to the text of one of them changes the digest."""
    from pyshadow import cache as cache_module

    meshes = (mesh, load("teapot.obj"))

    def builds():
        for m in meshes:
            pyshadow.CoherentShadowMap.build(m, pyshadow.ViewSet.zigzag(2, 4), resolution=8, progress=False)
            pyshadow.CoherentShadowMap.build(m, pyshadow.ViewSet.hilbert(0), resolution=8, footprint=True,
                                             progress=False)

    ran = modules_run(builds)
    launch_only = {f for f in ran if f.startswith("_cl/") or f in ("_compat.py", "_validate.py")}
    assert {"csm/build.py", "raster.py", "csm/exposure.py"} <= ran
    assert ran - launch_only <= set(cache_module.BUILD_SOURCES), ran - launch_only
    d = cache_module._code_digest()
    real = Path.read_bytes
    monkeypatch.setattr(Path, "read_bytes", lambda p: real(p) + (b"#" if p.name == "views.py" else b""))
    assert cache_module._code_digest() != d


def test_csm_cache_corrupt_file_rebuilt(tmp_path, mesh, views):
    cache = CSMCache(tmp_path)
    csm1, info = cache.csm("spot", mesh, views, RES, BITS)
    path = info["file"]
    data = bytearray(Path(path).read_bytes())
    data[len(data) // 2] ^= 0xFF
    Path(path).write_bytes(bytes(data))
    with pytest.raises(pyshadow.CSMFormatError):
        pyshadow.CoherentShadowMap.load(path)
    log = Log()
    csm2, info = CSMCache(tmp_path, log).csm("spot", mesh, views, RES, BITS)
    assert info["source"] == "rebuilt" and info["file"] == path
    assert "rebuilding" in log.text() and os.path.basename(path) in log.text()
    pyshadow.CoherentShadowMap.load(path)                       # a good file again
    assert _same_csm(csm1, csm2)
    _, info = CSMCache(tmp_path).csm("spot", mesh, views, RES, BITS)
    assert info["source"] == "cached"


def test_csm_cache_file_of_other_parameters_rebuilt(tmp_path, mesh, views):
    """A valid CSM file that does not match its key (here: another depth precision) is replaced."""
    cache = CSMCache(tmp_path)
    _, info16 = cache.csm("spot", mesh, views, RES, 16)
    _, info32 = cache.csm("spot", mesh, views, RES, 32)
    os.replace(info32["file"], info16["file"])
    log = Log()
    csm, info = CSMCache(tmp_path, log).csm("spot", mesh, views, RES, 16)
    assert info["source"] == "rebuilt" and csm.depth_bits == 16
    assert "holds different depth_bits" in log.text()


def test_csm_cache_unwritable_folder_only_disables_caching(tmp_path, mesh, views):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    log = Log()
    cache = CSMCache(blocker / "cache", log)
    assert cache.enabled
    for _ in range(2):
        csm, info = cache.csm("spot", mesh, views, RES, BITS)
        assert info["source"] == "built" and info["file"] is None
        assert info["build_seconds"] == info["seconds"] > 0 and csm.maps == len(views)
    cache.put_array("ab" * 20, np.ones(3))
    assert cache.array("ab" * 20) is None
    assert sum("not caching" in m for m in log) == 1            # warned once


def test_csm_cache_disabled(tmp_path, mesh, views):
    cache = CSMCache(None)
    assert not cache.enabled
    _, info = cache.csm("spot", mesh, views, RES, BITS)
    assert info["source"] == "built" and info["file"] is None
    cache.put_array("cd" * 20, np.ones(3))
    assert cache.array("cd" * 20) is None


def test_csm_cache_arrays_round_trip(tmp_path):
    cache = CSMCache(tmp_path)
    key = "0123456789abcdef" * 4
    assert cache.array(key) is None
    a = np.linspace(0.0, 1.0, 12).reshape(3, 4)               # float64 in, float32 out
    cache.put_array(key, a)
    assert _files(tmp_path) == [f"reference/{key[:40]}.npz"]
    got = cache.array(key)
    assert got.dtype == np.float32 and got.shape == (3, 4)
    np.testing.assert_array_equal(got, a.astype(np.float32))
    cache.put_array(key, np.zeros(5, np.float32))             # replaces the entry
    np.testing.assert_array_equal(CSMCache(tmp_path).array(key), np.zeros(5, np.float32))


@pytest.mark.parametrize("damage", ["truncated", "checksum"])
def test_csm_cache_damaged_array_removed(tmp_path, damage):
    log = Log()
    cache = CSMCache(tmp_path, log)
    key = "fe" * 32
    cache.put_array(key, np.arange(100, dtype=np.float32))
    path = tmp_path / "reference" / f"{key[:40]}.npz"
    if damage == "truncated":
        path.write_bytes(path.read_bytes()[:50])
    else:                                                      # valid file, wrong checksum
        np.savez_compressed(path, data=np.arange(100, dtype=np.float32),
                            sha256=np.zeros(32, np.uint8))
    assert cache.array(key) is None
    assert not path.exists()
    assert "recomputing" in log.text() and path.name in log.text()


def test_default_cache_dir(monkeypatch, tmp_path):
    import platformdirs

    monkeypatch.setenv("PYSHADOW_CACHE", str(tmp_path / "c"))
    assert default_cache_dir() == tmp_path / "c"
    monkeypatch.setenv("PYSHADOW_CACHE", "~/pyshadow-cache")
    assert default_cache_dir() == Path.home() / "pyshadow-cache"
    for value in ("  ", None):
        if value is None:
            monkeypatch.delenv("PYSHADOW_CACHE")
        else:
            monkeypatch.setenv("PYSHADOW_CACHE", value)
        assert str(default_cache_dir()) == platformdirs.user_cache_dir("pyshadow")

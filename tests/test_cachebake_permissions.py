"""pyshadow.cache.CSMCache in a shared cache folder whose subfolders belong to another user."""
from __future__ import annotations

import errno
import os

import numpy as np

import pyshadow
from pyshadow.cache import CSMCache


def _lock_out(root, monkeypatch):
    """Make ``root/csm`` and ``root/reference`` folders this process cannot search (mode 0700 of another
    user): for real where permissions apply, else (root) as the system calls would answer."""
    subs = [root / "csm", root / "reference"]
    for d in subs:
        d.mkdir(parents=True)
    if os.geteuid() != 0:
        for d in subs:
            os.chmod(d, 0o600)          # the test's finally gives the permissions back
        return subs
    blocked = {str(d) for d in subs}
    real_stat, real_access = os.stat, os.access

    def inside(p):
        return isinstance(p, (str, os.PathLike)) and os.path.dirname(os.fspath(p)) in blocked

    def stat(p, *a, **k):
        if inside(p):
            raise PermissionError(errno.EACCES, "Permission denied", os.fspath(p))
        return real_stat(p, *a, **k)

    def access(p, mode, *a, **k):
        if isinstance(p, (str, os.PathLike)) and (os.fspath(p) in blocked or inside(p)):
            return False
        return real_access(p, mode, *a, **k)

    monkeypatch.setattr(os, "stat", stat)
    monkeypatch.setattr(os, "access", access)
    return subs


def test_unsearchable_cache_folders_only_disable_caching(tmp_path, monkeypatch):
    """Was: PermissionError out of CSMCache.array and CSMCache.csm (``path.exists()`` on a file in a folder
    that cannot be searched), although a cache folder that cannot be used is documented to disable caching
    with one warning and never fail a call."""
    root = tmp_path / "shared cache"
    subs = _lock_out(root, monkeypatch)
    log = []
    cache = CSMCache(root, log.append)
    try:
        assert cache.array("ab" * 20) is None
        cache.put_array("ab" * 20, np.ones(3))
        mesh = pyshadow.data.mesh("spot.obj")
        views = pyshadow.ViewSet.zigzag(4, 8)
        csm, info = cache.csm("spot", mesh, views, 8, 16)
    finally:
        for d in subs:
            os.chmod(d, 0o700)
    assert info["source"] == "built" and info["file"] is None and csm.maps == 32
    warnings = [m for m in log if m.startswith("warning")]
    assert len(warnings) == 1 and "not caching" in warnings[0], log
    fresh = pyshadow.CoherentShadowMap.build(mesh, views, resolution=8, progress=False)
    for k in ("centre", "offsets", "iend", "depth"):
        np.testing.assert_array_equal(getattr(csm, k), getattr(fresh, k))


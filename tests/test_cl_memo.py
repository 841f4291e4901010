"""Programs and kernels built once per key, each build outside the tables' lock (pyshadow._cl.memo)."""
import threading

import pytest

from pyshadow import _cl
from pyshadow._cl import memo

WAIT_S = 10.0           # far beyond any step here; a deadlock fails the test instead of hanging the suite


def _in_thread(fn, start=True):
    """Run fn in a daemon thread (started unless ``start`` is False); returns (thread, box): box["value"] or
    box["error"] once it ends."""
    box = {}

    def run():
        try:
            box["value"] = fn()
        except Exception as exc:            # noqa: BLE001 - handed to the test
            box["error"] = exc

    t = threading.Thread(target=run, daemon=True)
    if start:
        t.start()
    return t, box


def test_a_build_holds_up_no_other_key():
    table, started, release = {}, threading.Event(), threading.Event()

    def slow():
        started.set()
        assert release.wait(WAIT_S)
        return "slow"

    t, box = _in_thread(lambda: memo.once(table, "slow", slow))
    assert started.wait(WAIT_S)
    u, other = _in_thread(lambda: memo.once(table, "fast", lambda: "fast"))
    u.join(WAIT_S)
    assert other == {"value": "fast"} and not release.is_set()     # done while "slow" still builds
    assert "slow" not in table
    release.set()
    t.join(WAIT_S)
    assert box == {"value": "slow"} and table == {"slow": "slow", "fast": "fast"}


def test_one_build_per_key_whatever_the_threads():
    table, calls, gate = {}, [], threading.Event()

    def build():
        calls.append(1)
        assert gate.wait(WAIT_S)
        return object()

    runs = [_in_thread(lambda: memo.once(table, "k", build)) for _ in range(8)]
    gate.set()
    for t, _ in runs:
        t.join(WAIT_S)
    values = [box["value"] for _, box in runs]
    assert len(calls) == 1 and all(v is values[0] for v in values) and table["k"] is values[0]


class _SeenGets(dict):
    """memo's table of builds under way, telling which threads looked a build up."""

    def __init__(self):
        super().__init__()
        self.looked = threading.Event()
        self.thread = None

    def get(self, key, default=None):
        found = super().get(key, default)
        if found is not None and threading.current_thread() is self.thread:
            self.looked.set()           # that thread found the build under way: it waits for it
        return found


def test_a_failed_build_is_built_again_by_a_waiting_caller(monkeypatch):
    table, calls, first_in = {}, [], threading.Event()
    seen = _SeenGets()
    monkeypatch.setattr(memo, "_building", seen)

    def build():
        calls.append(1)
        if len(calls) == 1:
            first_in.set()
            assert seen.looked.wait(WAIT_S)         # the second caller waits on this build
            raise ValueError("the first build fails")
        return "built"

    t, first = _in_thread(lambda: memo.once(table, "k", build))
    assert first_in.wait(WAIT_S)
    u, box = _in_thread(lambda: memo.once(table, "k", build), start=False)
    seen.thread = u
    u.start()
    t.join(WAIT_S)
    u.join(WAIT_S)
    assert seen.looked.is_set()
    assert isinstance(first.get("error"), ValueError)
    assert box == {"value": "built"} and len(calls) == 2 and table == {"k": "built"} and seen == {}


def test_a_kernel_build_holds_up_no_lookup_of_a_built_kernel(monkeypatch):
    built = _cl.kernel("raster.cl", "render_depth_layers", {"RES": 16, "LAYERS": 2})
    started, release, real = threading.Event(), threading.Event(), _cl.build_source

    def slow_build(src, label, defines=None):
        started.set()
        assert release.wait(WAIT_S)
        return real(src, label, defines)

    monkeypatch.setattr(_cl, "build_source", slow_build)
    t, box = _in_thread(lambda: _cl.kernel("raster.cl", "render_depth_layers", {"RES": 24, "LAYERS": 3}))
    try:
        assert started.wait(WAIT_S)
        u, again = _in_thread(lambda: _cl.kernel("raster.cl", "render_depth_layers", {"RES": 16, "LAYERS": 2}))
        u.join(WAIT_S)
        assert again.get("value") is built and not release.is_set()
    finally:
        release.set()
        t.join(WAIT_S)
    assert box["value"].function_name == "render_depth_layers"
    assert box["value"] is _cl.kernel("raster.cl", "render_depth_layers", {"RES": 24, "LAYERS": 3})


if __name__ == "__main__":
    pytest.main([__file__, "-q"])

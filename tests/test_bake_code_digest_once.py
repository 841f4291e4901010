"""The bake's code digest is the code a process loaded, read once (pyshadow/bake/params.py)."""
from __future__ import annotations

import pyshadow.cache
from pyshadow.bake.params import code_digest


def test_code_digest_is_read_once_per_process(monkeypatch):
    """Was: every call hashed pyshadow's files on disk again; files changed during a bake (an editable install
    being edited, a reinstall) made every later asset and frame fail as baked by "other pyshadow code", the
    serial bake's too, whose code was the driver's own."""
    d = code_digest()
    monkeypatch.setattr(pyshadow.cache, "source_digest", lambda *a, **k: "0" * 64)     # the files changed on disk
    assert code_digest() == d and len(d) == 64

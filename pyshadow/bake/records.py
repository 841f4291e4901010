"""Done marks: a task's outputs, then a record listing their hashes, each written atomically.

A record (JSON) is written after every output it lists, so its presence
with a matching ``key`` and matching output hashes is the proof that a task
finished with these inputs; anything else is redone.
"""
from __future__ import annotations

import hashlib
import json
from pathlib import Path

from .._files import write_bytes_atomic

__all__ = ["done", "store", "sha256_file", "drop_manifest", "other_bake", "differences"]


def sha256_file(path) -> str:
    """SHA-256 (hex) of a file's bytes, read in 4 MiB chunks."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 22), b""):
            h.update(chunk)
    return h.hexdigest()


def done(out: Path, record: str, key: str):
    """The record at ``out/record`` if it has status 'baked', this ``key`` and every output intact, else None.

    An output listed outside ``out`` (an absolute path, or one through ``..``: a hand-edited or hostile
    record) makes the record not done; such a file is not read.
    """
    try:
        rec = json.loads((out / record).read_text())
        if rec.get("status") != "baked" or rec.get("key") != key:
            return None
        for rel, meta in rec["outputs"].items():
            if Path(rel).is_absolute() or ".." in Path(rel).parts:     # was hashed, and the record trusted
                return None
            f = out / rel
            if not f.is_file() or f.stat().st_size != meta["bytes"] or sha256_file(f) != meta["sha256"]:
                return None
        return rec
    except (OSError, ValueError, KeyError, TypeError, AttributeError, RecursionError):   # deep nesting: corrupt
        return None


def other_bake(out: Path, record: str, key: str):
    """The record at ``out/record`` when it marks a finished task of another bake (status 'baked', a key
    other than ``key``: other parameters, inputs or code), else None (none there, unreadable, or this
    bake's own, done or damaged)."""
    try:
        rec = json.loads((out / record).read_text())
    except (OSError, ValueError, RecursionError):
        return None
    if not isinstance(rec, dict) or rec.get("status") != "baked" or rec.get("key") == key:
        return None
    return rec


def differences(there, here: dict, names=None) -> list:
    """``'name A there, B here'`` for each entry of the dict ``here`` that the dict ``there`` (an earlier
    bake's, from its record) holds otherwise, in the order of ``names`` (default: ``here``'s keys)."""
    if not isinstance(there, dict):
        return []
    return [f"{k} {there.get(k)!r} there, {here[k]!r} here" for k in (names or here)
            if k in here and there.get(k) != here[k]]


def store(out: Path, record: str, rec: dict, files: dict) -> dict:
    """Write ``files`` (relative path -> bytes) under ``out``, then ``rec`` with their hashes as ``out/record``.

    Returns ``rec`` with ``outputs`` (relative path -> ``sha256``, ``bytes``).
    """
    outputs = {}
    for rel, data in sorted(files.items()):
        (out / rel).parent.mkdir(parents=True, exist_ok=True)
        write_bytes_atomic(out / rel, data)
        outputs[rel] = {"sha256": hashlib.sha256(data).hexdigest(), "bytes": len(data)}
    rec = dict(rec, outputs=outputs)
    (out / record).parent.mkdir(parents=True, exist_ok=True)
    write_bytes_atomic(out / record, json.dumps(rec, indent=1, sort_keys=True).encode())
    return rec


def drop_manifest(out: Path) -> None:
    """Remove an earlier run's ``out/manifest.json`` before this run writes its first output.

    A run killed before it writes its own manifest (SIGKILL, the out-of-memory killer, a job's time limit)
    left the earlier one's, which described outputs this run had replaced (frames rendered with other
    parameters) as that run's; the records stay the proof of what is done. A folder of that name raises
    (IsADirectoryError) before anything is baked.
    """
    try:
        (out / "manifest.json").unlink()
    except FileNotFoundError:
        pass

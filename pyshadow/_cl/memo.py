"""Values built once per key (the package's programs and kernels), each build outside the tables' lock.

A kernel build takes seconds on a CPU device (PoCL compiles with clang). Under
one lock for the whole table, a thread building a new variant held up every
other thread's lookup of a kernel built long before (a viewer's frame behind
another thread's first query of a new scene). Here the lock covers only the
table: a key's first caller builds it with no lock held, later callers of that
key wait for that build, and callers of other keys go on.
"""
from __future__ import annotations

import os
import threading

__all__ = ["once"]

_lock = threading.Lock()
_building: dict = {}            # (id(table), key) -> Event, set when that build ends (done or failed)


def once(table: dict, key, build):
    """``table[key]``, made by ``build()`` the first time it is asked for.

    Parameters
    ----------
    table : dict
        Where built values are kept (read by others without this module).
    key : hashable
    build : callable
        Makes the value; called with no lock held, once per key while it
        succeeds. Where it raises, the error reaches its caller, and a caller
        that waited for it builds again itself (and so gets its own error).

    Returns
    -------
    object
        The value kept for ``key``.
    """
    mark = (id(table), key)
    while True:
        with _lock:
            if key in table:
                return table[key]
            done = _building.get(mark)
            mine = done is None
            if mine:
                done = _building[mark] = threading.Event()
        if not mine:
            done.wait()
            continue            # built (now in the table), or failed: then this thread tries itself
        try:
            value = build()
            with _lock:
                table[key] = value
            return value
        finally:
            with _lock:
                del _building[mark]
            done.set()


def _after_fork() -> None:
    """A child of ``os.fork``: builds in other threads of the parent never end here; a new lock."""
    global _lock
    _lock = threading.Lock()
    _building.clear()


if hasattr(os, "register_at_fork"):
    os.register_at_fork(after_in_child=_after_fork)

"""Where bake tasks run: in this process, in a local process pool, or on Dask.

Every executor takes the same tasks (a picklable function and plain
arguments: names, bytes, dicts; never an object of the OpenCL runtime) and
yields results as they complete, keeping at most ``window`` tasks in flight
so that neither the driver nor a worker holds more than a few tasks' data.

Dask (``dask.distributed``) is the path for more than one machine: a
``LocalCluster`` of ``workers`` single-threaded worker processes by default,
or an existing cluster by scheduler address. A worker that dies has its
tasks rerun on the others by the Dask scheduler; a task the cluster cancels
(a restart, or the death of every worker holding the run's shared data,
which Dask cannot recompute) is sent again, with that data sent again
first. Without Dask installed a ``concurrent.futures`` process pool (or
``serial``) runs the same tasks.
"""
from __future__ import annotations

import json
import logging
import os
import re
import threading
import time
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from multiprocessing import get_context
from pathlib import Path

from .._validate import check_int

__all__ = ["EXECUTORS", "check_executor", "open_executor", "close_executor", "executor_info", "thread_env",
           "sweep_temporaries",
           "dask_available", "WorkerDied", "SharedDataLost",
           "STALE_SECONDS"]

EXECUTORS = ("dask", "process", "serial")

# the temporary names of pyshadow._files.atomic_path: ".<stem>.<12 hex>.tmp<suffix>"
_TEMPORARY = re.compile(r"^\..+\.[0-9a-f]{12}\.tmp(\.[^.]*)?$")
# a bake sweeps only temporaries unchanged for this long: a younger one may be the write in progress of
# another bake into the same folder (removed, its rename failed and that bake lost the output)
STALE_SECONDS = 3600.0


def dask_available() -> bool:
    """True when ``dask.distributed`` can be imported."""
    import importlib.util

    return importlib.util.find_spec("distributed") is not None


def thread_env(threads: int) -> dict:
    """Environment that limits the OpenCL CPU device of a worker to ``threads`` threads.

    PoCL's CPU device starts one thread per core in every process; ``workers``
    processes on one machine would then run ``workers x cores`` threads. Both
    PoCL's names for the limit are set (``POCL_MAX_PTHREAD_COUNT``, read by
    the pip wheel's PoCL 3, and ``POCL_CPU_MAX_CU_NUM``, read by later
    versions). GPUs ignore them.
    """
    n = str(max(1, int(threads)))
    return {"POCL_MAX_PTHREAD_COUNT": n, "POCL_CPU_MAX_CU_NUM": n, "OMP_NUM_THREADS": n}


def sweep_temporaries(root, min_age: float = 0.0) -> list[Path]:
    """Remove the temporary files atomic writes left under ``root`` (a killed run's); returns them.

    Parameters
    ----------
    root : str or path-like
    min_age : float
        Seconds since a temporary file was last modified before it is removed (0: every one). The bakes
        pass :data:`STALE_SECONDS`, so that two bakes into one folder keep each other's writes in
        progress; a killed run's younger leftovers go in a later run.
    """
    root = Path(root)
    gone = []
    if not root.is_dir():
        return gone
    now = time.time()
    for path in root.rglob(".*"):
        if path.is_file() and _TEMPORARY.match(path.name):
            try:
                if min_age > 0 and now - path.stat().st_mtime < min_age:
                    continue
                path.unlink()
                gone.append(path)
            except OSError:
                pass
    return gone


# per process-pool worker: the run's ``shared`` argument, sent once when the process starts (not with every task)
_SHARED: dict = {}


def _init_process_worker(env: dict, parent: int | None = None, shared=None) -> None:
    os.environ.update(env)
    _SHARED.clear()
    if shared is not None:
        _SHARED["value"] = shared
    if parent is not None:
        threading.Thread(target=_exit_with_parent, args=(parent,), name="pyshadow-parent-watch", daemon=True).start()


def _exit_with_parent(parent: int, every: float = 1.0) -> None:
    """End this worker process once its parent ``parent`` (the driver) is gone.

    A pool's idle worker waits on a queue whose writing end it holds itself, so it never sees the driver
    die: a driver killed (SIGKILL, the out-of-memory killer) left its workers running for good, holding
    their memory and the driver's output pipes (a ``... | tee`` of the command never returned).
    """
    while os.getppid() == parent:
        time.sleep(every)
    os._exit(1)


class WorkerDied(RuntimeError):
    """A task's worker process died while running it (the task ran alone, so it was the cause)."""


class _Serial:
    kind = "serial"

    def __init__(self):
        self.workers = 1
        self.threads = None             # this process's own device

    def run(self, fn, tasks, shared=None, window=None):
        for tag, args in tasks:
            extra = (shared,) if shared is not None else ()
            try:
                yield tag, fn(*args, *extra), None
            except Exception as e:           # the driver reports it with the task's tag
                yield tag, None, e

    def close(self):
        pass


def _call_with_shared(fn, *args):
    """A process-pool task: ``fn(*args, shared)`` with the ``shared`` its worker process was started with."""
    return fn(*args, _SHARED["value"])


class _Pool:
    kind = "process"

    def __init__(self, workers: int, threads: int):
        self.workers, self.threads = workers, threads
        self.pool, self._shared = None, None        # started by run(): its workers start with run's shared
        self._pending = {}                          # run's tasks in flight (future -> (tag, args))

    def _new_pool(self):
        return ProcessPoolExecutor(max_workers=self.workers, mp_context=get_context("spawn"),
                                   initializer=_init_process_worker,
                                   initargs=(thread_env(self.threads), os.getpid(), self._shared))

    def _submit(self, fn, args):
        if self._shared is None:
            return self.pool.submit(fn, *args)
        return self.pool.submit(_call_with_shared, fn, *args)

    def run(self, fn, tasks, shared=None, window=None):
        window = window or 2 * self.workers
        if self.pool is None or shared is not self._shared:
            # sent to each worker process once, as it starts (it went with every task: a scene's CSMs,
            # 34 MB at the CLI's defaults, pickled and piped again for every chunk of 4 frames)
            self._shared = shared
            self._restart()
        it = iter(tasks)
        pending = self._pending = {}    # future -> (tag, args)
        broken = []                     # tasks in flight when a worker process died

        def submit():
            for tag, args in it:
                try:
                    pending[self._submit(fn, args)] = (tag, args)
                except BrokenProcessPool:
                    broken.append((tag, args))
                return True
            return False

        while len(pending) < window and not broken and submit():
            pass
        while pending or broken:
            if pending:
                done, _ = wait(list(pending), return_when=FIRST_COMPLETED)
                for fut in done:
                    tag, args = pending.pop(fut)
                    err = fut.exception()
                    if isinstance(err, BrokenProcessPool):
                        broken.append((tag, args))
                    else:
                        yield (tag, fut.result(), None) if err is None else (tag, None, err)
            if broken:                  # the pool is dead: every task still in it died with it
                for fut in list(pending):
                    tag, args = pending.pop(fut)
                    if fut.done() and fut.exception() is None:
                        yield tag, fut.result(), None
                    else:
                        broken.append((tag, args))
                self._restart()
                while broken:           # one at a time: only the task that kills its worker fails
                    tag, args = broken.pop(0)
                    yield self._alone(fn, tag, args)
            while len(pending) < window and not broken and submit():
                pass

    def _alone(self, fn, tag, args):
        """Run one task by itself in the pool: a dead worker is then this task's doing."""
        try:
            return tag, self._submit(fn, args).result(), None
        except BrokenProcessPool:
            self._restart()
            return tag, None, WorkerDied("its worker process died while running it (a crash in native code, "
                                         "or killed by the system, e.g. out of memory)")
        except Exception as e:
            return tag, None, e

    def _restart(self):
        if self.pool is not None:
            self.pool.shutdown(wait=True, cancel_futures=True)
        self.pool = self._new_pool()

    def close(self):
        if self.pool is None:
            return
        if any(not fut.done() for fut in self._pending):
            # closed mid-run (Ctrl-C, SIGTERM): the driver drops what the running tasks return, and shutdown
            # waited for them (a SIGTERM'd bake ran on for its longest task, minutes for a large asset, and a
            # job scheduler's SIGKILL then came before the manifest); a worker process only ever holds its task
            for proc in list((getattr(self.pool, "_processes", None) or {}).values()):
                proc.terminate()
        self.pool.shutdown(wait=True, cancel_futures=True)


class SharedDataLost(RuntimeError):
    """The Dask workers lost a run's shared data (all that held it died) and it could not be sent again."""


class _Dask:
    kind = "dask"
    resubmits = 3                       # times a task cancelled by the cluster (a restart, lost data) is sent again
    resend_timeout = 60.0               # seconds to wait for a worker to send lost shared data to again

    def __init__(self, workers: int, threads: int, scheduler: str | None):
        from distributed import Client, LocalCluster

        self.cluster = None
        self.threads = threads if scheduler is None else None
        if scheduler is None:
            self.cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                        dashboard_address=None, env=thread_env(threads),
                                        silence_logs=logging.ERROR)
            self.client = Client(self.cluster)
        else:
            self.client = Client(scheduler, timeout="30s")
        info = self.client.scheduler_info()
        self.address = info.get("address")
        self.workers = max(1, len(info.get("workers", {})))
        self._futures = []

    def _send(self, shared, timeout=None):
        """``shared`` on every worker (their first use of it copies it to workers that join later)."""
        [fut] = self.client.scatter([shared], broadcast=True, hash=False,
                                    **({} if timeout is None else {"timeout": timeout}))
        return fut

    def _resend(self, shared):
        """:meth:`_send` again, retried until :attr:`resend_timeout` (a restart's leaving workers fail it)."""
        deadline = time.monotonic() + self.resend_timeout
        while True:
            try:
                return self._send(shared, max(1.0, deadline - time.monotonic()))
            except Exception:
                if time.monotonic() >= deadline:
                    raise
                time.sleep(0.5)

    def run(self, fn, tasks, shared=None, window=None):
        from distributed import as_completed

        window = window or max(2, 2 * self.workers)
        copy = self._send(shared) if shared is not None else None     # sent to every worker once, not per task
        lost = []                       # why shared, lost by the workers, could not be sent again
        it = iter(tasks)
        pending = {}                    # future -> (tag, args, resubmissions, the copy of shared it uses)
        ac = as_completed()

        def submit(tag, args, tries=0):
            fut = self.client.submit(fn, *args, *(() if copy is None else (copy,)), pure=False)
            pending[fut] = (tag, args, tries, copy)
            ac.add(fut)

        def fill():
            while len(pending) < window and not lost:
                task = next(it, None)
                if task is None:
                    return
                submit(*task)

        fill()
        for fut in ac:
            tag, args, tries, used = pending.pop(fut)
            if fut.status == "cancelled" and not lost and tries < self.resubmits:
                # the cluster restarted, or every worker that held shared died: Dask cannot recompute
                # scattered data and cancelled every task that needs it ("lost dependencies"; every frame
                # of a bake failed, also those sent later, while the restarted workers sat idle)
                fut.release()
                if shared is not None and used is copy:
                    try:
                        copy = self._resend(shared)
                    except Exception as e:
                        lost.append(f"{type(e).__name__}: {e}")
                if not lost:
                    submit(tag, args, tries + 1)
                    continue
            try:
                yield tag, fut.result(), None
            except Exception as e:           # e.g. KilledWorker after repeated worker deaths
                yield tag, None, (self._lost(lost) if lost and fut.status == "cancelled" else e)
            fut.release()
            fill()
        for tag, _ in (it if lost else ()):
            yield tag, None, self._lost(lost)
        self._futures = list(pending)

    @staticmethod
    def _lost(why):
        return SharedDataLost("the Dask workers lost the data every task needs (a frame bake's scene; every "
                              "worker that held it died, or the cluster restarted) and it could not be sent again: "
                              f"{why[0]}; the finished outputs are kept: rerun to continue")

    def close(self):
        try:
            for fut in self._futures:
                fut.cancel()
            self.client.close()
        finally:                             # a Ctrl-C while the client closes still stops the local workers
            if self.cluster is not None:
                self.cluster.close()


def close_executor(ex):
    """Close ``ex`` and return the ``KeyboardInterrupt`` that cut the closing short, if one did.

    Closing a Dask cluster takes seconds, and a Ctrl-C that lands then
    must not skip what the driver still has to do (remove temporary files,
    write the manifest): the driver finishes that, then raises the returned
    interrupt, as it does for one that lands while tasks run.

    Parameters
    ----------
    ex : executor or None
        From :func:`open_executor`; None when none was opened.

    Returns
    -------
    KeyboardInterrupt or None
        None when ``ex`` closed (or was None).
    """
    if ex is None:
        return None
    try:
        ex.close()
    except KeyboardInterrupt as e:
        return e
    return None


def executor_info(ex, kind=None) -> dict:
    """The manifest's ``executor`` entry: ``kind``, ``workers``, ``threads`` (per local
    worker), ``address`` (Dask scheduler); ``ex`` None when nothing was run."""
    return {"kind": ex.kind if ex is not None else kind, "workers": getattr(ex, "workers", None),
            "threads": getattr(ex, "threads", None), "address": getattr(ex, "address", None)}


def check_executor(kind=None, workers=None, scheduler=None, threads=None) -> str:
    """The executor kind :func:`open_executor` would open for these arguments; ValueError for ones it refuses.

    The bakes call it before anything is built or written, not only when a task is left to run (a rerun
    with every output done took ``executor='bogus'``, and wrote it to its manifest).

    Parameters
    ----------
    kind, workers, scheduler, threads :
        As :func:`open_executor`.

    Returns
    -------
    str
        'dask', 'process' or 'serial' (``kind`` None resolved as :func:`open_executor` does).
    """
    if kind is None:
        kind = "dask" if (scheduler is not None or dask_available()) else "process"
    if not isinstance(kind, str) or kind not in EXECUTORS:
        raise ValueError(f"executor must be one of {EXECUTORS}, got {kind!r}")
    if scheduler is not None and kind != "dask":
        raise ValueError(f"a scheduler address needs the 'dask' executor, not {kind!r}")
    for arg, v in (("workers", workers), ("threads", threads)):
        if v is None:
            continue
        try:
            check_int(v, arg, 1)
        except (TypeError, ValueError):     # not 2.5 cut to 2, nor 'abc'; one error type, as documented
            raise ValueError(f"{arg} must be a positive int, got {v!r}") from None
    return kind


def open_executor(kind: str | None = None, workers: int | None = None, scheduler: str | None = None,
                  threads: int | None = None):
    """An executor of bake tasks.

    Parameters
    ----------
    kind : {'dask', 'process', 'serial'} or None
        None: 'dask' when ``dask.distributed`` is installed (or a
        ``scheduler`` is given), else 'process'.
    workers : int, optional
        Worker processes on this machine (default: its cores); each is
        limited to ``cores // workers`` OpenCL CPU threads
        (:func:`thread_env`). Ignored with ``scheduler``, and with 'serial'
        (one task at a time in this process; the manifest says 1 worker).
    scheduler : str, optional
        Address of an existing Dask scheduler (``tcp://host:8786``) or the
        path of a scheduler file; its workers bring their own environment.
    threads : int, optional
        OpenCL CPU threads per local worker (default ``cores // workers``,
        at least 1). Ignored with 'serial' (this process's own device).

    Returns
    -------
    executor
        ``.run(fn, tasks, shared=None, window=None)`` yields ``(tag, result,
        exception)`` per task as they complete (``tasks`` an iterable of
        ``(tag, args)``; ``shared`` appended to every call's arguments and
        sent to each worker process once, not with every task: a process
        pool's workers get it as they start, Dask's by a broadcast, sent
        again if every worker holding it dies); ``.close()``; ``.kind``;
        ``.workers``.
    """
    cores = os.cpu_count() or 1
    kind = check_executor(kind, workers, scheduler, threads)
    workers = int(workers) if workers is not None else cores
    threads = int(threads) if threads is not None else max(1, cores // workers)
    if kind == "serial":
        return _Serial()
    if kind == "process":
        return _Pool(workers, threads)
    if not dask_available():
        raise ImportError("the 'dask' executor needs dask.distributed: pip install 'pyshadow[dask]' "
                          "(or use executor='process' on one machine)")
    if scheduler is not None and Path(scheduler).is_file():       # a scheduler file (dask scheduler --scheduler-file)
        try:
            scheduler = json.loads(Path(scheduler).read_text())["address"]
        except (OSError, ValueError, KeyError) as e:
            raise ValueError(f"{scheduler}: not a Dask scheduler file ({e})") from None
    return _Dask(workers, threads, scheduler)

"""Closing a process pool of bake tasks mid-run (pyshadow.bake.runner), found by the second audit of the
bake: the interrupted driver drops what the running tasks return, so it must not wait for them."""
import time

from pyshadow.bake.runner import close_executor, open_executor


def test_closing_a_process_pool_mid_run_does_not_wait_for_its_running_tasks():
    """Was: close() (what a bake calls on Ctrl-C or SIGTERM) waited for every running task to finish:
    here 20 s for a 20 s task whose result was then dropped; `pyshadow-bake assets` of two 20,480-face
    meshes on 2 workers took 9.8 s to exit after SIGTERM (a large asset's CSM build: minutes, and a
    job scheduler's SIGKILL came first, leaving no manifest). Now the workers are stopped: 0.14 s."""
    ex = open_executor("process", workers=2, threads=1)
    results = ex.run(time.sleep, [("quick", (0.0,)), ("slow", (20.0,))])
    tag, res, err = next(results)
    assert (tag, res, err) == ("quick", None, None)
    t0 = time.perf_counter()
    assert close_executor(ex) is None
    took = time.perf_counter() - t0
    assert took < 5.0, f"close waited {took:.1f} s for a task whose result is dropped"
    assert not ex.pool._processes


def test_closing_a_process_pool_after_its_run_keeps_its_results():
    """The pool closed after every task finished is closed as before (nothing terminated mid-task)."""
    ex = open_executor("process", workers=2, threads=1)
    got = sorted((tag, res, err) for tag, res, err in ex.run(abs, [(i, (-i,)) for i in range(5)]))
    assert close_executor(ex) is None
    assert got == [(i, i, None) for i in range(5)]

"""Worker processes for the CLI: cases and studies on every CPU, results as a serial run gives them.

Workers are forked (on Linux), so they start with the parent's imports and
with every reference solution the parent holds: forked after the cases ran,
the studies' workers reuse the cases' solves instead of repeating them. Each
worker runs MuJoCo on one thread (the workers, not MuJoCo's threads, share
the cores) and ignores Ctrl-C, which is the parent's: it stops them all. A
worker dies with its parent whatever ends the parent, SIGKILL included
(:func:`harness.core.lifetime.die_with_parent`), and a SIGTERM sent to a
worker alone ends it.

:func:`run_tasks` returns results in the order the calls were given, and
raises a call's error once every earlier call has finished, as a serial
loop would raise its first error; the other workers are stopped at once.
"""

from __future__ import annotations

import contextlib
import gc
import multiprocessing
import os
import signal
import sys
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import Future, ProcessPoolExecutor, as_completed
from typing import Any

from harness.core.lifetime import die_with_parent
from harness.engine import recording
from harness.pipeline.executor import LOCAL, Executor

__all__ = ["cpus", "fork_pool", "run_tasks"]


def cpus() -> int:
    """CPUs this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


HELD = {signal.SIGTERM, signal.SIGINT}
"""The signals a parent holds while it forks its workers: a child forked as the parent dies would otherwise get the
parent-death signal inside Python's after-fork hooks, before its own handlers are set, and print a traceback."""


def _worker_init(parent: int) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's: it stops the workers
    signal.signal(signal.SIGTERM, signal.SIG_DFL)  # not the parent's handler, inherited by the fork
    signal.pthread_sigmask(signal.SIG_UNBLOCK, HELD)  # held by the parent while it forked (fork_pool)
    die_with_parent(parent)
    recording.set_threads(1)  # one worker per CPU: the workers, not MuJoCo's threads, share the cores


@contextlib.contextmanager
def fork_pool(workers: int) -> Iterator[ProcessPoolExecutor]:
    """A process pool of ``workers``, forked where the platform can (spawn re-imports everything in
    every worker). On an error or an interrupt in the ``with`` body the workers are terminated
    at once rather than after their current call.

    Everything this process holds is frozen out of the garbage collector while the pool lives
    (``gc.freeze``, as Python's docs advise before a fork): a worker's collections would otherwise
    walk every inherited object (sympy's expressions, the modules) and write to it, copying its
    memory page by page in each worker (what that costs: docs/findings/speed.md).
    """
    context = multiprocessing.get_context("fork" if sys.platform.startswith("linux") else None)
    gc.freeze()
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=context, initializer=_worker_init,
                               initargs=(os.getpid(),))
    try:
        held = signal.pthread_sigmask(signal.SIG_BLOCK, HELD)
        try:  # every worker forked now (a forking pool starts them all at its first task), the signals held
            pool.submit(int).result()
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, held)  # one that came meanwhile is raised here
        yield pool
    except BaseException:
        for process in list(getattr(pool, "_processes", {}).values()):
            process.terminate()
        pool.shutdown(wait=False, cancel_futures=True)
        raise
    else:
        pool.shutdown()
    finally:
        gc.unfreeze()


def run_tasks(calls: Sequence[tuple[Callable[..., Any], tuple]], workers: int, *,
              on_done: Callable[[int, Any], None] | None = None, executor: Executor = LOCAL,
              failed: Callable[[int, str], Any] | None = None, labels: Sequence[str] | None = None) -> list:
    """``fn(*args)`` for every call on ``workers`` processes, or as Ray tasks; results in the order of ``calls``.

    Calls are submitted in the given order (put the costliest first). ``on_done(i, result)`` runs in
    this process as call i finishes (progress). ``fn`` must be a module-level function and its result
    picklable. With one worker (or fewer) and no cluster the calls run here, one after another, with no
    pool. On a cluster (:mod:`harness.pipeline.cluster`) ``labels`` name the calls' tasks, and a call that
    fails for good (not by an error of its own) is replaced by ``failed(i, reason)``, else raises
    :class:`~harness.pipeline.executor.TaskLost`; a call's own error is raised as here.
    """
    if executor.kind == "ray":
        from harness.pipeline import cluster  # lazy: Ray is an optional extra, imported only when asked for

        return cluster.run_tasks(calls, executor, on_done=on_done, failed=failed, labels=labels)
    if workers <= 1:
        done = []
        for i, (fn, args) in enumerate(calls):
            done.append(fn(*args))
            if on_done is not None:
                on_done(i, done[-1])
        return done
    results: dict[int, Any] = {}
    errors: dict[int, BaseException] = {}
    with fork_pool(workers) as pool:
        futures: dict[Future, int] = {pool.submit(fn, *args): i for i, (fn, args) in enumerate(calls)}
        next_in_order = 0
        for future in as_completed(futures):
            i = futures[future]
            try:
                results[i] = future.result()
            except Exception as exc:  # raised once every call before it has finished
                errors[i] = exc
            else:
                if on_done is not None:
                    on_done(i, results[i])
            while next_in_order in results or next_in_order in errors:
                if next_in_order in errors:
                    raise errors[next_in_order]
                next_in_order += 1
    return [results[i] for i in range(len(calls))]

"""The local runner of a sweep: the cases in this process (one worker) or in a pool of forked processes.

A sweep on this machine needs no scheduler: :func:`local_pool` runs tasks (a function of the spec
and a batch of case numbers) in this process when one worker is asked for, and otherwise in
``workers`` processes forked from this one, which inherit the compiled kernel and the imported
modules (no import, no build, no socket: a pool starts in milliseconds). Tasks are handed out one at
a time as workers free up, so the load stays balanced to the end.

A worker ignores Ctrl-C (the parent stops the pool and reports the interruption once) and exits
within a second of its parent's death (even a ``kill -9`` of the parent leaves nothing running). A
worker that dies mid-task breaks the pool: the unfinished tasks run again in a new pool, at most
:data:`RETRIES` times each, as a Dask scheduler's retries would. Where ``fork`` is not available the
processes are spawned (each then imports and loads the kernel once).
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import signal
import threading
import time
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from typing import Any, Callable, Iterator, Sequence

import numpy as np

from model.errors import InputError

__all__ = ["RETRIES", "LocalPool", "local_pool"]

#: How many times a task whose worker died is run again.
RETRIES = 2
_PARENT_POLL_S = 0.5


def _watch_parent(parent: int) -> None:
    while True:
        time.sleep(_PARENT_POLL_S)
        if os.getppid() != parent:
            os._exit(1)  # the parent is gone (killed): nothing is left to report to


def _worker_start(parent: int) -> None:
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle
    threading.Thread(target=_watch_parent, args=(parent,), daemon=True, name="sweep-parent-watch").start()


class LocalPool:
    """Runs ``task(spec, batch)`` for each batch; see :func:`local_pool`."""

    def __init__(self, workers: int) -> None:
        self.workers = workers
        self._executor: ProcessPoolExecutor | None = None

    def _start(self) -> ProcessPoolExecutor:
        methods = multiprocessing.get_all_start_methods()
        context = multiprocessing.get_context("fork" if "fork" in methods else "spawn")
        self._executor = ProcessPoolExecutor(self.workers, mp_context=context, initializer=_worker_start,
                                             initargs=(os.getpid(),))
        return self._executor

    def run(self, task: Callable[[Any, np.ndarray], np.ndarray], spec: Any,
            batches: Sequence[np.ndarray]) -> Iterator[tuple[np.ndarray, np.ndarray]]:
        """``(batch, rows)`` of every batch, in the order they finish."""
        if self.workers == 1:
            for batch in batches:
                yield batch, task(spec, batch)
            return
        todo = list(range(len(batches)))
        tries = [0] * len(batches)
        while todo:
            executor = self._start()
            running: dict[Future, int] = {}
            queue = list(todo)
            todo = []
            broken = False

            def submit() -> None:  # keep each worker busy with one task and one waiting: balanced to the end
                while queue and len(running) < 2 * self.workers:
                    i = queue.pop(0)
                    running[executor.submit(task, spec, batches[i])] = i

            submit()
            while running:
                finished, _ = wait(running, return_when=FIRST_COMPLETED)
                for fut in finished:
                    i = running.pop(fut)
                    try:
                        rows = fut.result()
                    except BrokenProcessPool:
                        broken = True
                        tries[i] += 1
                        if tries[i] > RETRIES:
                            raise
                        todo.append(i)
                        continue
                    yield batches[i], rows
                if broken:
                    todo += [running.pop(f) for f in list(running)] + queue
                    queue = []
                    self.close()
                    break
                submit()

    def close(self) -> None:
        """Stop the workers now (unfinished tasks are dropped)."""
        executor, self._executor = self._executor, None
        if executor is None:
            return
        processes = list(getattr(executor, "_processes", {}).values())  # terminated below: no waiting on a task
        executor.shutdown(wait=False, cancel_futures=True)
        for p in processes:
            if p.is_alive():
                p.terminate()
        for p in processes:
            p.join(timeout=5)


@contextlib.contextmanager
def local_pool(workers: int) -> Iterator[LocalPool]:
    """A :class:`LocalPool` of ``workers`` processes (this process alone for 1), stopped on exit."""
    if workers < 1:
        raise InputError(f"expected a number of processes >= 1, got {workers!r}", parameter="workers")
    pool = LocalPool(workers)
    try:
        yield pool
    finally:
        pool.close()

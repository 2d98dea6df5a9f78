"""Pluggable executors: anything with ``map(fn, iterable)`` runs a sweep.

* ``None`` (default): a local :class:`concurrent.futures.ProcessPoolExecutor` with :data:`DEFAULT_WORKERS`
  workers, created for the sweep and shut down after it.
* ``"serial"`` or :class:`SerialExecutor`: in this process (tests, debugging, a single core).
* any object with ``map(fn, iterable)``: used as is and left open, e.g. your own pool, or on a Ray cluster
  ``ray.util.multiprocessing.Pool()`` (its ``map``/``imap`` take the same pure function and picklable tasks;
  workers must import ``triplanar`` and any user effect module so that effect names resolve).
"""

from __future__ import annotations

import os
from concurrent.futures import ProcessPoolExecutor, as_completed
from contextlib import contextmanager
from typing import Any, Callable, Iterable, Iterator, Protocol, Sequence, TypeVar

T = TypeVar("T")
R = TypeVar("R")

DEFAULT_WORKERS = 2


class Executor(Protocol):
    def map(self, fn: Callable[[T], R], iterable: Iterable[T]) -> Iterable[R]: ...


class SerialExecutor:
    """Runs tasks one after another in this process."""

    def map(self, fn: Callable[[T], R], iterable: Iterable[T]) -> Iterator[R]:
        return map(fn, iterable)


ExecutorLike = Executor | str | None


@contextmanager
def pool_scope(workers: int) -> Iterator[Executor]:
    """A process pool of ``workers`` (in this process when 1), shut down on exit."""
    if workers <= 1:
        yield SerialExecutor()
        return
    pool = ProcessPoolExecutor(max_workers=workers)
    try:
        yield pool
    finally:
        pool.shutdown(wait=True, cancel_futures=True)


@contextmanager
def executor_scope(executor: ExecutorLike, n_tasks: int = 2) -> Iterator[Executor]:
    """Yield an executor for ``executor``; a pool made here is shut down on exit."""
    if executor is None:
        with pool_scope(max(1, min(DEFAULT_WORKERS, n_tasks, os.cpu_count() or 1))) as pool:
            yield pool
    elif isinstance(executor, str):
        if executor != "serial":
            raise ValueError(f"executor must be None, 'serial' or an object with map(fn, iterable), got {executor!r}")
        yield SerialExecutor()
    else:
        if not callable(getattr(executor, "map", None)):
            raise TypeError(f"executor {executor!r} has no map(fn, iterable) method")
        yield executor


def run_tasks(fn: Callable[[T], R], tasks: Sequence[T], executor: ExecutorLike = None,
              progress: bool | Any = False, desc: str = "") -> list[R]:
    """``[fn(t) for t in tasks]`` through ``executor``, in task order, with an optional tqdm progress bar
    (``progress``: True for a bar on stderr, or an open tqdm bar to update)."""
    bar = None
    own_bar = False
    if progress is True:
        from tqdm import tqdm
        bar, own_bar = tqdm(total=len(tasks), desc=desc, unit="task", leave=True), True
    elif progress:
        bar = progress
    try:
        with executor_scope(executor, len(tasks)) as ex:
            if bar is not None and callable(getattr(ex, "submit", None)):
                # concurrent.futures: tick the bar as tasks finish, in any order.
                futures = [ex.submit(fn, task) for task in tasks]
                index = {f: i for i, f in enumerate(futures)}
                done: list[Any] = [None] * len(tasks)
                for fut in as_completed(futures):
                    done[index[fut]] = fut.result()
                    bar.update(1)
                return done
            out: list[R] = []
            for result in ex.map(fn, tasks):
                out.append(result)
                if bar is not None:
                    bar.update(1)
            return out
    finally:
        if own_bar:
            bar.close()

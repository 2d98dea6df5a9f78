"""The executor layer: every fan-out of the project (workbench fits, folds and refits, paper figures, lab-data
tests, PPO seeds, the actuator study) is ``run_tasks(fn, tasks, executor=...)`` over pure functions and
picklable tasks. Backends (the ``executor`` argument, or ``--executor`` on the CLI):

* ``None`` or ``"local"`` (default): a local :class:`concurrent.futures.ProcessPoolExecutor` with
  :data:`DEFAULT_WORKERS` workers, created for the sweep and shut down after it.
* ``"serial"`` or :class:`SerialExecutor`: in this process (tests, debugging, a single core).
* ``"ray"`` or a :class:`triplanar.ray_executor.RayExecutor`: Ray tasks, on a cluster or a Ray started for the
  sweep (``docs/scaling.md``); a task whose worker dies is retried.
* any object with ``map(fn, iterable)`` (and optionally ``submit``): used as is and left open.

Whatever the backend, results come back in task order and a task computes the same numbers: each task runs with
BLAS/OpenMP limited to one thread (:class:`OneThreadTask`; a multi-threaded BLAS splits sums differently and
changes the last bits of a fit, and Ray starts its workers with one thread anyway: the task is the unit of
parallelism). With a
:class:`TaskCheckpoint` each finished task's result is saved (atomically) in this process as it arrives, so an
interrupted sweep resumes without redoing finished tasks.

Every pool made here dies with its command: each worker asks the kernel to kill it when its parent dies
(Linux ``prctl(PR_SET_PDEATHSIG)``) and runs a watchdog thread that exits when the process that made the pool
is gone (any platform); a SIGTERM to the command terminates the workers before it exits.
"""

from __future__ import annotations

import ctypes
import hashlib
import os
import pickle
import shutil
import signal
import sys
import threading
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Callable, Iterable, Iterator, Protocol, Sequence, TypeVar

from .atomic import write_atomic
from . import plain_data

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

BACKENDS = ("local", "serial", "ray")


WATCHDOG_PERIOD_S = 0.5


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    try:  # a dead but not yet reaped parent is a zombie
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except (OSError, IndexError):
        return True


def _watch_parent(owner: int) -> None:
    while _alive(owner):
        time.sleep(WATCHDOG_PERIOD_S)
    os._exit(1)


def die_with_parent(owner: int) -> None:
    """Worker initializer: exit when process ``owner`` (the pool's maker) dies, however it dies. Ctrl-C (SIGINT,
    sent to the whole foreground group) is the maker's to handle: it terminates its workers, which would otherwise
    each print a ``KeyboardInterrupt`` traceback. SIGTERM goes back to its default: a worker forked while
    :func:`pool_scope`'s handler is installed would inherit it, and a ``Terminated`` raised inside a task is caught by
    the pool's worker loop as the task's error, so the worker would live on and the command hang at exit."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    if sys.platform.startswith("linux") and os.getppid() == owner:
        try:
            ctypes.CDLL(None, use_errno=True).prctl(1, int(signal.SIGKILL))  # PR_SET_PDEATHSIG = 1
        except (OSError, AttributeError):
            pass
    if not _alive(owner):
        os._exit(1)
    threading.Thread(target=_watch_parent, args=(owner,), name="parent-watchdog", daemon=True).start()


def new_pool(workers: int) -> ProcessPoolExecutor:
    """A ProcessPoolExecutor whose workers die with this process."""
    return ProcessPoolExecutor(max_workers=workers, initializer=die_with_parent, initargs=(os.getpid(),))


def terminate_pool(pool: ProcessPoolExecutor) -> None:
    """Stop ``pool`` now: kill its workers instead of waiting for their tasks."""
    for process in list((getattr(pool, "_processes", None) or {}).values()):
        if process.is_alive():
            process.terminate()
    pool.shutdown(wait=False, cancel_futures=True)


class Terminated(SystemExit):
    """Raised in the main thread by SIGTERM while a pool is open, so that the pool is terminated first."""


def _raise_terminated(signum, frame) -> None:
    raise Terminated(128 + signum)


@contextmanager
def open_executor(backend: str = "local", address: str | None = None, workers: int | None = None,
                  plugins: Sequence[str] = ()) -> Iterator[Any]:
    """The executor of ``backend``, shut down on exit: ``"serial"``, this process; ``"ray"``, Ray tasks (the cluster
    at ``address``, else a local Ray with ``workers`` CPUs; the ``plugins`` modules reach its workers); ``"local"``, a
    pool of ``workers`` processes (``None``: each sweep makes one sized to its tasks, :func:`run_tasks`). The
    ``--executor``, ``--ray-address`` and ``--workers`` options of the commands arrive here as plain arguments."""
    if backend == "serial":
        yield SerialExecutor()
    elif backend == "ray":
        from .ray_executor import RayExecutor  # Ray is the optional `ray` extra
        with RayExecutor(address, num_cpus=workers, plugins=plugins) as ex:
            yield ex
    elif backend != "local":
        raise ValueError(f"executor backend must be 'local', 'serial' or 'ray', got {backend!r}")
    elif workers is None:
        yield "local"
    else:
        with pool_scope(workers) as ex:
            yield ex


@contextmanager
def pool_scope(workers: int) -> Iterator[Executor]:
    """A process pool of ``workers`` (in this process when 1), shut down on exit; on an error, an interrupt or
    SIGTERM its workers are terminated."""
    if workers <= 1:
        yield SerialExecutor()
        return
    previous = None
    if threading.current_thread() is threading.main_thread():
        previous = signal.signal(signal.SIGTERM, _raise_terminated)
    pool = new_pool(workers)
    try:
        yield pool
    except BaseException:
        terminate_pool(pool)
        raise
    else:
        pool.shutdown(wait=True, cancel_futures=True)
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


@contextmanager
def executor_scope(executor: ExecutorLike, n_tasks: int = 2) -> Iterator[Executor]:
    """Yield an executor for ``executor`` (``None``/``"local"``, ``"serial"``, ``"ray"`` or an object with
    ``map``); a pool or a Ray made here is shut down on exit, an executor given is left open."""
    if executor is None or executor == "local":
        with pool_scope(max(1, min(DEFAULT_WORKERS, n_tasks, os.cpu_count() or 1))) as pool:
            yield pool
    elif isinstance(executor, str):
        if executor == "serial":
            yield SerialExecutor()
        elif executor == "ray":
            from .ray_executor import RayExecutor  # Ray is an optional extra: imported only when asked for
            with RayExecutor() as ray_executor:
                yield ray_executor
        else:
            raise ValueError(f"executor must be one of {', '.join(BACKENDS)}, None, or an object with "
                             f"map(fn, iterable), got {executor!r}")
    else:
        if not callable(getattr(executor, "map", None)):
            raise TypeError(f"executor {executor!r} has no map(fn, iterable) method")
        yield executor


def _one_thread_for_good() -> None:
    """Limit BLAS and OpenMP to one thread in this worker process, once (it runs nothing but tasks): the libraries
    loaded now through ``threadpoolctl``, those a task loads later (torch's OpenMP, for a policy's forward pass)
    through the environment they read when they load. Without the latter a worker's torch ran two threads beside
    the other worker's on two cores, and a shipped LSTM agent's episodes took twice as long."""
    global _LIMITED
    if not _LIMITED:
        from threadpoolctl import threadpool_limits
        for name in ONE_THREAD_ENV:
            os.environ[name] = "1"
        threadpool_limits(limits=1)
        _LIMITED = True


ONE_THREAD_ENV = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


_LIMITED = False


class OneThreadTask:
    """``fn`` run with BLAS and OpenMP limited to one thread (``threadpoolctl``), so that a task's numbers do not
    depend on the process it runs in (the caller's, a pool's or a Ray worker's). In a worker process the limit is
    set once, for good; in the process that made the task, only while it runs."""

    def __init__(self, fn: Callable[[T], R]):
        self.fn = fn
        self.owner = os.getpid()

    def __call__(self, task: T) -> R:
        if os.getpid() != self.owner:
            _one_thread_for_good()
            return self.fn(task)
        from threadpoolctl import threadpool_limits
        with threadpool_limits(limits=1):
            return self.fn(task)


class TaskCheckpoint:
    """Finished tasks' results on disk, so that an interrupted sweep resumes where it stopped: each result is
    written (atomically) as ``<directory>/<key>.npz`` when its task finishes, the key being a hash of the
    function and the task. The files are plain data (:mod:`triplanar.plain_data`: JSON and arrays, never pickle),
    so a file planted there can at worst stand for a result, never run code; a result that plain data cannot hold
    is not kept, and a file that does not load (a damaged write) is ignored and its task run again (the new result
    replaces it)."""

    def __init__(self, directory: str | os.PathLike[str]):
        self.directory = Path(directory)

    def key(self, fn: Callable, task: Any) -> str | None:
        try:
            data = pickle.dumps((getattr(fn, "__module__", ""), getattr(fn, "__qualname__", repr(fn)), task),
                                protocol=5)   # only hashed, never loaded
        except Exception:  # an unpicklable task is simply not checkpointed
            return None
        return hashlib.sha256(data).hexdigest()[:32]

    def load(self, key: str | None) -> tuple[bool, Any]:
        if key is None:
            return False, None
        path = self.directory / f"{key}.npz"
        try:
            return True, plain_data.load(path)
        except FileNotFoundError:
            return False, None
        except plain_data.PlainDataError:
            # Damaged, or naming a dataclass whose module this process has not imported: the task runs again and
            # its save replaces the file; it is not deleted here, so that a reader lacking a module (a script
            # looking at a study's store) never destroys a result the study itself can read.
            return False, None

    def save(self, key: str | None, result: Any) -> None:
        if key is None:
            return
        try:
            data = plain_data.dumps(result)
        except plain_data.PlainDataError:  # not plain data: the task runs again after an interruption
            return
        self.directory.mkdir(parents=True, exist_ok=True)
        write_atomic(self.directory / f"{key}.npz", lambda tmp: tmp.write_bytes(data))

    def forget(self, fn: Callable, tasks: Sequence[Any]) -> int:
        """Remove the stored results of ``tasks`` (run by ``fn``), so that they run again (their code changed);
        returns how many were stored."""
        removed = 0
        for task in tasks:
            key = self.key(fn, task)
            path = self.directory / f"{key}.npz"
            if key is not None and path.exists():
                path.unlink()
                removed += 1
        return removed

    def clear(self) -> None:
        """Remove the directory (the sweep finished and its outputs are written)."""
        shutil.rmtree(self.directory, ignore_errors=True)


def run_tasks(fn: Callable[[T], R], tasks: Sequence[T], executor: ExecutorLike = None,
              progress: bool | Any = False, desc: str = "", checkpoint: TaskCheckpoint | None = None) -> list[R]:
    """``[fn(t) for t in tasks]`` through ``executor``, in task order, with an optional tqdm progress bar
    (``progress``: True for a bar on stderr, or an open tqdm bar to update). With ``checkpoint``, results
    already on disk are used instead of running their tasks, and each new result is saved when it arrives."""
    bar = None
    own_bar = False
    if progress is True:
        from tqdm import tqdm
        bar, own_bar = tqdm(total=len(tasks), desc=desc, unit="task", leave=True), True
    elif progress:
        bar = progress
    done: list[Any] = [None] * len(tasks)
    keys: list[str | None] = [None] * len(tasks)
    todo = list(range(len(tasks)))
    if checkpoint is not None:
        todo = []
        for i, task in enumerate(tasks):
            keys[i] = checkpoint.key(fn, task)
            found, result = checkpoint.load(keys[i])
            if found:
                done[i] = result
            else:
                todo.append(i)
        if bar is not None and len(todo) < len(tasks):
            bar.update(len(tasks) - len(todo))

    def finished(i: int, result: Any) -> None:
        done[i] = result
        if checkpoint is not None:
            checkpoint.save(keys[i], result)
        if bar is not None:
            bar.update(1)

    call = OneThreadTask(fn)
    try:
        if not todo:
            return done
        with executor_scope(executor, len(todo)) as ex:
            if (bar is not None or checkpoint is not None) and callable(getattr(ex, "submit", None)):
                # concurrent.futures: record tasks as they finish, in any order.
                futures = {ex.submit(call, tasks[i]): i for i in todo}
                for fut in as_completed(futures):
                    finished(futures[fut], fut.result())
                return done
            if isinstance(ex, SerialExecutor):  # in this process: one limit for the whole sweep (it costs ~1 ms)
                from threadpoolctl import threadpool_limits
                with threadpool_limits(limits=1):
                    for i in todo:
                        finished(i, fn(tasks[i]))
                return done
            for i, result in zip(todo, ex.map(call, [tasks[i] for i in todo])):
                finished(i, result)
            return done
    finally:
        if own_bar:
            bar.close()

"""The Ray backend of the executor layer (:mod:`triplanar.executor`): each task of a sweep is one Ray task.

Why Ray tasks (and not Ray's multiprocessing ``Pool`` or Ray Tune): a sweep here is a fixed list of independent,
pure tasks whose results must come back in task order and be saved one by one as they finish (the resumable
checkpoint). A task's future (``ObjectRef.future()``) gives exactly that through the same
``submit``/``as_completed`` path as the local process pool, Ray retries a task whose worker died
(``max_retries``), and nothing else is needed on the nodes. ``docs/scaling.md`` says more.

Addresses: with ``address`` (``--ray-address``) or ``RAY_ADDRESS`` set, the sweep joins that cluster and leaves
it running; otherwise a Ray is started for the sweep on this machine, bound to the loopback address only
(127.0.0.1), with ``num_cpus`` CPUs and a small object store, and shut down after it; a watchdog process
(:mod:`triplanar.ray_watchdog`) ends that Ray's processes within about a second if the command is killed before it
can (Ray's own agents would otherwise outlive it by a minute). Inside an already initialised Ray (e.g. a test's
cluster) the sweep uses it as it is.

Plugins: the ``--plugin`` modules are imported on every worker before a task is unpickled
(:func:`triplanar.plugins.ensure_plugins`; a ``.py`` plugin's source travels with the tasks).
"""

from __future__ import annotations

import os
from concurrent.futures import Future
from typing import Any, Callable, Iterable, Sequence

from .plugins import PluginSource, ensure_plugins, plugin_sources

LOOPBACK = "127.0.0.1"
OBJECT_STORE_BYTES = 150 * 1024 ** 2  # a sweep moves kilobytes per task: keep Ray's shared memory small
MAX_RETRIES = 3  # a task whose worker process dies (killed, out of memory, node lost) is run again


def loopback_only() -> None:
    """Make every Ray process started from here bind to 127.0.0.1 (Ray otherwise picks the machine's network
    address); a value the user set is kept."""
    os.environ.setdefault("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")


CONNECT_TIMEOUT_S = 10.0


def check_answers(address: str, timeout_s: float = CONNECT_TIMEOUT_S) -> None:
    """Refuse (ValueError) a cluster address ``HOST:PORT`` (or ``ray://HOST:PORT``) where nothing accepts a TCP
    connection within ``timeout_s`` seconds; ``auto`` and ``local`` are Ray's to resolve."""
    import socket
    text = address.removeprefix("ray://")
    if text in ("auto", "local"):
        return
    host, sep, port = text.rpartition(":")
    if not sep or not port.isdigit() or not 0 < int(port) < 65536 or not host:
        raise ValueError(f"--ray-address {address!r}: expected HOST:PORT (e.g. 10.0.0.5:6379) or auto")
    try:
        with socket.create_connection((host.strip("[]"), int(port)), timeout=timeout_s):
            pass
    except OSError as err:
        reason = "no answer" if isinstance(err, TimeoutError) else (err.strerror or type(err).__name__)
        raise ValueError(f"--ray-address {address}: nothing answers there within {timeout_s:g} s ({reason}); is "
                         "the cluster running (ray start --head)?") from None


def require_ray():
    loopback_only()  # read when Ray is imported and when it starts processes
    try:
        import ray
    except ImportError:
        raise ImportError("--executor ray needs Ray: pip install 'triplanar-shear[ray]' (or make, which "
                          "installs it)") from None
    return ray


def _run_task(plugins: tuple[PluginSource, ...], payload: bytes) -> Any:
    """On a Ray worker: import the user's plugins, then unpickle and run one task (the order matters: the task
    may hold objects of a plugin's classes)."""
    import cloudpickle  # comes with Ray
    ensure_plugins(plugins)
    fn, task = cloudpickle.loads(payload)
    return fn(task)


class RayExecutor:
    """Ray tasks behind ``map(fn, iterable)`` and ``submit(fn, task)``; use as a context manager (or call
    :meth:`start` and :meth:`shutdown`).

    Args:
        address: a running cluster (``"HOST:PORT"``, ``"auto"``); ``None``: ``RAY_ADDRESS`` if set, else a local
            Ray started here.
        num_cpus: CPUs of a local Ray started here (``None``: all of this machine's, as Ray counts them).
        plugins: ``--plugin`` values, imported on every worker.
        max_retries: how often a task whose worker died is run again.
    """

    def __init__(self, address: str | None = None, num_cpus: int | None = None, plugins: Sequence[str] = (),
                 max_retries: int = MAX_RETRIES):
        self.address = address
        self.num_cpus = num_cpus
        self.plugins = plugin_sources(plugins)
        self.max_retries = max_retries
        self._initialised_here = False
        self._watchdog = None   # the watchdog of a Ray started here (triplanar.ray_watchdog)
        self._remote = None
        self._pending: set[Any] = set()  # submitted and not finished: cancelled if the sweep fails

    # -- lifetime --------------------------------------------------------------------------------------
    def start(self) -> RayExecutor:
        address = self.address or os.environ.get("RAY_ADDRESS") or None
        if address:
            check_answers(address)   # before Ray, whose own connection attempts wait for minutes
        ray = require_ray()
        loopback_only()
        if not ray.is_initialized():
            if address:
                ray.init(address=address, log_to_driver=False)
            else:
                # "local": a new Ray even when another runs on this machine (plain init() would join that one)
                ray.init(address="local", num_cpus=self.num_cpus, object_store_memory=OBJECT_STORE_BYTES,
                         include_dashboard=False, _node_ip_address=LOOPBACK, log_to_driver=False)
                from . import ray_watchdog
                self._watchdog = ray_watchdog.start()
            self._initialised_here = True  # shutdown() stops a Ray started here, or only disconnects from a cluster
        self._remote = ray.remote(max_retries=self.max_retries, retry_exceptions=False, num_cpus=1)(_run_task)
        return self

    def shutdown(self, cancel: bool = False) -> None:
        ray = require_ray()
        if cancel:
            for ref in list(self._pending):
                try:
                    ray.cancel(ref, force=True)
                except Exception:  # already finished or gone
                    pass
        self._pending.clear()
        if self._initialised_here and ray.is_initialized():
            ray.shutdown()
        if self._watchdog is not None:   # Ray is down: nothing left to watch
            self._watchdog.terminate()
            self._watchdog.wait()
            self._watchdog = None
        self._initialised_here = False
        self._remote = None

    def __enter__(self) -> RayExecutor:
        return self.start()

    def __exit__(self, kind, value, traceback) -> None:
        self.shutdown(cancel=kind is not None)

    # -- the executor protocol -------------------------------------------------------------------------
    def _submit_ref(self, fn: Callable, task: Any):
        if self._remote is None:
            self.start()
        import cloudpickle
        ref = self._remote.remote(self.plugins, cloudpickle.dumps((fn, task)))
        self._pending.add(ref)
        return ref

    def submit(self, fn: Callable, task: Any) -> Future:
        """One task; its result as a :class:`concurrent.futures.Future` (so ``as_completed`` works)."""
        ref = self._submit_ref(fn, task)
        future = ref.future()
        future.add_done_callback(lambda _: self._pending.discard(ref))  # a finished result is not held here
        return future

    def map(self, fn: Callable, iterable: Iterable[Any]) -> list[Any]:
        """``[fn(t) for t in iterable]`` as Ray tasks, in order."""
        ray = require_ray()
        refs = [self._submit_ref(fn, task) for task in iterable]
        results = ray.get(refs)
        self._pending.difference_update(refs)
        return results

"""A pool's workers take Ctrl-C and SIGTERM as :func:`triplanar.executor.die_with_parent` sets them, whatever handler
the command had installed when the pool forked them: SIGINT ignored (the command handles it), SIGTERM at its
default, so that terminating the pool ends a worker in the middle of a task (the handler of ``pool_scope`` raises
an exception that the pool's worker loop would catch as the task's error, leaving the worker alive and the command
waiting for it at exit)."""

from __future__ import annotations

import os
import signal
import time

from triplanar.executor import _alive, pool_scope   # _alive: a zombie (killed, not yet reaped) is not alive


def _handlers(_: int) -> tuple[object, object]:
    return signal.getsignal(signal.SIGINT), signal.getsignal(signal.SIGTERM)


def _pid_then_sleep(seconds: float) -> int:
    time.sleep(seconds)
    return os.getpid()


def test_workers_ignore_ctrl_c_and_die_on_sigterm_although_the_pool_scope_handles_it() -> None:
    with pool_scope(2) as pool:
        assert signal.getsignal(signal.SIGTERM) is not signal.SIG_DFL   # the scope's own handler, inherited at fork
        assert list(pool.map(_handlers, range(2))) == [(signal.SIG_IGN, signal.SIG_DFL)] * 2


def test_sigterm_ends_a_worker_in_the_middle_of_a_task() -> None:
    with pool_scope(2) as pool:
        for _ in range(2):   # both workers busy: an idle one would die of the exception anyway
            pool.submit(_pid_then_sleep, 60.0)
        deadline = time.time() + 30
        while not any(p.is_alive() for p in pool._processes.values()):
            assert time.time() < deadline
            time.sleep(0.05)
        time.sleep(1.0)   # the tasks are running (each worker sleeps inside one)
        workers = [p.pid for p in pool._processes.values()]
        for pid in workers:   # what terminate_pool sends, without the shutdown that would also end an idle worker
            os.kill(pid, signal.SIGTERM)
        deadline = time.time() + 10
        while any(_alive(pid) for pid in workers):
            assert time.time() < deadline, "a worker outlived SIGTERM"
            time.sleep(0.05)

"""A task runs on one thread in a pool's worker, including the threads of a library the task itself loads (torch's
OpenMP for a policy's forward pass): before, a worker's torch ran two threads beside the other worker's on two
cores, and a shipped LSTM agent's episodes took twice as long."""

from __future__ import annotations

import os

from triplanar.executor import ONE_THREAD_ENV, run_tasks


def _threads(_: int) -> tuple[dict[str, str | None], int]:
    import torch   # (loaded by the task, as an episode loading a shipped agent does)
    return {name: os.environ.get(name) for name in ONE_THREAD_ENV}, torch.get_num_threads()


def test_a_worker_and_the_libraries_its_tasks_load_run_one_thread() -> None:
    for env, torch_threads in run_tasks(_threads, [0, 1], executor="local"):
        assert env == dict.fromkeys(ONE_THREAD_ENV, "1") and torch_threads == 1

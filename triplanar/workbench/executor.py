"""The executor layer lives in :mod:`triplanar.executor` (the core's paper reproduction and lab-data use it
too); this module keeps ``triplanar.workbench.executor`` importable with the same names."""

from ..executor import (BACKENDS, DEFAULT_WORKERS, Executor, ExecutorLike, SerialExecutor,  # noqa: F401 (re-exported)
                        TaskCheckpoint, Terminated, die_with_parent, executor_scope, new_pool, pool_scope,
                        run_tasks, terminate_pool)

"""Older name of the one trainer (:mod:`agents.trainer`) for ``TriPlanarShear-v1``, kept for the scripts and notes
that call it: ``python -m agents.train_robust ARGS`` is ``triplanar train --env TriPlanarShear-v1 ARGS``;
:class:`RobustTask` is a :class:`agents.trainer.TrainTask` on v1, :func:`train_robust` runs one, and the finished
runs load as controllers through :mod:`agents.robust_policy`. New code calls :mod:`agents.trainer` or
:func:`agents.training.train`.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import Any

from . import train_config, trainer
from .robust_policy import (FRAMES, RecurrentPolicy, RobustPolicy, evaluate_policy_on, load_policy,  # noqa: F401
                            run_config)
from .run_benches import CURVE_BENCHES  # noqa: F401 (re-exported)
from .train_config import (ALGOS, BATCH_KEYS, CONFIG_KEYS, EVALUATIONS, TRAIN_KEYS, default_eval_freq,  # noqa: F401
                           frame_stack_of)
from .trainer import train_run as train_robust  # noqa: F401 (re-exported)

ENV_ID = train_config.V1
DEFAULT_CONFIGS = train_config.PROFILES[ENV_ID].configs
ROBUST_CONFIG, RECURRENT_CONFIG = DEFAULT_CONFIGS["ppo"], DEFAULT_CONFIGS["recurrent"]


@dataclass(frozen=True)
class RobustTask(trainer.TrainTask):
    """A :class:`agents.trainer.TrainTask` on ``TriPlanarShear-v1`` (same fields, same order)."""

    env_id: str = ENV_ID


def load_robust_config(path: str | Path = ROBUST_CONFIG, overrides: dict[str, Any] | None = None) -> dict[str, Any]:
    """A v1 training YAML with ``overrides``, checked (:func:`agents.train_config.load_config`)."""
    return train_config.load_config(path, overrides, ENV_ID)


def check_robust_config(config: dict[str, Any], source: str = "config") -> None:
    train_config.check_config(config, source, ENV_ID)


def make_vec_env(config: dict[str, Any], seed: int, check_only: bool = False) -> Any:
    return train_config.make_vec_env(config, seed, ENV_ID, check_only)


seed_tasks = partial(trainer.seed_tasks, env_id=ENV_ID)
train_seeds = partial(trainer.train_seeds, env_id=ENV_ID)


if __name__ == "__main__":
    import sys

    from triplanar.cli import main
    sys.exit(main(["train", "--env", ENV_ID, *sys.argv[1:]]))

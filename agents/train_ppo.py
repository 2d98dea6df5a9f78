"""Older name of the one trainer (:mod:`agents.trainer`) for ``TriPlanarShear-v0``, kept for the scripts and notes
that call it: ``python -m agents.train_ppo ARGS`` is ``triplanar train --env TriPlanarShear-v0 ARGS``, and
:func:`train_ppo` / :func:`train_seeds` train v0 runs (the run folder: :mod:`agents.run_loads`) returning
:class:`TrainResult`. New code calls :mod:`agents.trainer` or :func:`agents.training.train`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Sequence

from triplanar.executor import ExecutorLike

from . import train_config
from .run_loads import checkpoints, latest_checkpoint  # noqa: F401 (re-exported)
from .train_config import CONFIG_KEYS, TRAIN_KEYS, eval_loads  # noqa: F401 (re-exported)
from .trainer import TrainResult, TrainTask, train_run, train_seeds as _train_seeds

DEFAULT_CONFIG = train_config.PROFILES[train_config.V0].configs["ppo"]
ENV_ID = train_config.V0


def load_config(path: str | Path = DEFAULT_CONFIG, overrides: dict[str, Any] | None = None) -> dict[str, Any]:
    """A v0 training YAML with ``overrides``, checked (:func:`agents.train_config.load_config`)."""
    return train_config.load_config(path, overrides, ENV_ID)


def check_config(config: dict[str, Any], source: str = "config") -> None:
    train_config.check_config(config, source, ENV_ID)


def env_config(config: dict[str, Any]) -> Any:
    return train_config.shear_config(config)


def train_ppo(config: str | Path | dict[str, Any] = DEFAULT_CONFIG, out_dir: str | Path = "runs/ppo", seed: int = 0,
              total_timesteps: int | None = None, resume: bool = True, verbose: int = 0, progress: bool = False,
              token: str = "", named: bool = True, tensorboard_log: str | Path = "") -> TrainResult:
    """Train (or resume) one v0 run (:func:`agents.trainer.train_run`)."""
    if total_timesteps is not None and total_timesteps <= 0:
        raise ValueError(f"timesteps must be positive, got {total_timesteps}")
    task = TrainTask(str(out_dir), int(seed), int(total_timesteps or 0), config=config if isinstance(config, dict)
                     else str(config), progress=progress, resume=resume, token=token, named=named, verbose=verbose,
                     tensorboard_log=str(tensorboard_log or ""), env_id=ENV_ID)
    return TrainResult.of(train_run(task))


def train_seeds(config: str | Path | dict[str, Any], out_dir: str | Path, seeds: Sequence[int],
                total_timesteps: int | None = None, resume: bool = True, verbose: int = 0,
                executor: ExecutorLike = "serial", progress: bool = False, token: str = "",
                named: bool = True, tensorboard_log: str | Path = "") -> list[TrainResult]:
    """:func:`train_ppo` for each seed through ``executor`` (:func:`agents.trainer.train_seeds`)."""
    if total_timesteps is not None and total_timesteps <= 0:
        raise ValueError(f"timesteps must be positive, got {total_timesteps}")
    summaries = _train_seeds(out_dir, seeds, total_timesteps or 0, executor=executor, progress=progress,
                             config=config, resume=resume, verbose=verbose, token=token, named=named,
                             tensorboard_log=tensorboard_log, env_id=ENV_ID)
    return [TrainResult.of(s) for s in summaries]


if __name__ == "__main__":
    import sys

    from triplanar.cli import main
    sys.exit(main(["train", "--env", ENV_ID, *sys.argv[1:]]))

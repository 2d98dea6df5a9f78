"""Train a controller on either env version from a plain request (what ``triplanar train`` builds from its options;
the command owns the argument parsing, the agents take this object), with the one trainer, :mod:`agents.trainer`
(the YAML's schema: :mod:`agents.train_config`; default YAMLs ``agents/ppo.yaml`` for v0, ``agents/robust.yaml``
or, with ``algo: recurrent``, ``agents/recurrent.yaml`` for v1).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from triplanar.executor import ExecutorLike

ENV_IDS = ("TriPlanarShear-v0", "TriPlanarShear-v1")
ALGOS = ("ppo", "recurrent")


@dataclass(frozen=True)
class TrainRequest:
    """What to train: the env id, the YAML (default: ``agents/ppo.yaml`` for v0, by ``algo`` for v1), env arguments and
    ``key.path=value`` overrides on top of it, seeds, steps (None: the YAML's), where to write, whether to resume
    and show progress (``progress=False``: no bar at all), SB3's ``verbose`` (1: its table of episode return,
    length, success, error and losses on stdout) and ``tensorboard_log`` (a folder for TensorBoard logs; "": v0's
    run directories' ``tb/``, none for v1). ``named``: the user named ``out_dir`` (``--out`` or ``--resume``), so
    a checkpoint found there may be resumed (SB3 unpickles its zip); otherwise only checkpoints stamped with
    ``token`` (this invocation's, after a worker was retried) are."""

    env_id: str = "TriPlanarShear-v0"
    config: str | None = None
    algo: str | None = None
    env_kwargs: dict[str, Any] = field(default_factory=dict)
    overrides: dict[str, Any] = field(default_factory=dict)
    seeds: tuple[int, ...] = (0,)
    timesteps: int | None = None
    out_dir: str = "runs/ppo"
    resume: bool = True
    verbose: int = 0
    progress: bool = True
    token: str = ""
    named: bool = True
    tensorboard_log: str = ""

    def check(self) -> None:
        if self.env_id not in ENV_IDS:
            raise ValueError(f"env id must be one of {', '.join(ENV_IDS)}, got {self.env_id!r}")
        if self.algo is not None and self.algo not in ALGOS:
            raise ValueError(f"algo must be one of {', '.join(ALGOS)}, got {self.algo!r}")
        if self.env_id == "TriPlanarShear-v0" and self.algo == "recurrent":
            raise ValueError("algo 'recurrent' trains on TriPlanarShear-v1 (give --env TriPlanarShear-v1)")
        if self.timesteps is not None and self.timesteps <= 0:
            raise ValueError(f"timesteps must be positive, got {self.timesteps}")
        if not self.seeds:
            raise ValueError("give at least one seed")
        if isinstance(self.verbose, bool) or not isinstance(self.verbose, int) or not 0 <= self.verbose <= 2:
            raise ValueError(f"verbose must be 0, 1 or 2 (SB3's), got {self.verbose!r}")


def refuse_leftovers(out_dir: str, seeds: tuple[int, ...]) -> None:
    """An output folder the user did not name (the default one) is nobody's choice: checkpoints found there (an
    earlier run's, or planted) are refused, not loaded."""
    from .checkpoint_files import leftovers
    for seed in seeds:
        run_dir = Path(out_dir) / f"seed_{seed}"
        found = leftovers(run_dir)
        if found:
            raise ValueError(f"{run_dir} holds checkpoints of an earlier run ({found[0].name}, ...): give --resume "
                             "to continue it (its SB3 zip is unpickled: only a run you made), --no-resume to replace "
                             "it, or another --out")


@dataclass(frozen=True)
class TrainedRun:
    seed: int
    timesteps: int
    wall_s: float
    run_dir: Path


def train(request: TrainRequest, executor: ExecutorLike = "serial") -> list[TrainedRun]:
    """Train (or resume) one run per seed of ``request`` through ``executor``; results in seed order."""
    request.check()
    if request.resume and not request.named:
        refuse_leftovers(request.out_dir, request.seeds)
    from .trainer import train_seeds
    summaries = train_seeds(request.out_dir, request.seeds, request.timesteps or 0, executor=executor,
                            progress=request.progress, env_id=request.env_id, config=request.config or "",
                            algo=request.algo or "", env_kwargs=request.env_kwargs, overrides=request.overrides,
                            resume=request.resume, token=request.token, named=request.named,
                            verbose=request.verbose, tensorboard_log=request.tensorboard_log)
    return [TrainedRun(s["seed"], s["timesteps"], s["wall_s"], Path(s["run_dir"])) for s in summaries]

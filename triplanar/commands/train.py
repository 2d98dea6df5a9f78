"""``triplanar train``: train PPO on TriPlanarShear-v0 (thin wrapper over :mod:`agents.train_ppo`).

The options are declared here and :mod:`agents` is imported only in :func:`run`, so building the CLI (and
``triplanar --help``) needs neither the agents nor torch; ``python -m agents.train_ppo`` uses the same options.
"""

from __future__ import annotations

import argparse

from ..cli_args import add_executor_arguments, executor_from_args
from . import require

NAME = "train"
HELP = "train PPO on TriPlanarShear-v0 (hyperparameters in a YAML file; resumes from checkpoints)"


def positive_int(text: str) -> int:
    """argparse type: an integer > 0."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}") from None
    if value <= 0:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}")
    return value


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--config", help="hyperparameter YAML (default agents/ppo.yaml)")
    parser.add_argument("--out", default="runs/ppo", help="output directory; the run goes to OUT/seed_S")
    parser.add_argument("--seed", type=int, action="append", help="seed (repeatable; default 0)")
    parser.add_argument("--timesteps", type=positive_int, help="total environment steps (default: the YAML's)")
    parser.add_argument("--no-resume", action="store_true",
                        help="start afresh even if checkpoints exist (the previous run's checkpoints are removed)")
    parser.add_argument("--verbose", type=int, default=0)
    add_executor_arguments(parser)  # the seeds are the tasks (each seed's run directory must be shared on a cluster)


def run(args: argparse.Namespace) -> int:
    require()
    from agents.train_ppo import run as train  # the RL stack, only when training
    with executor_from_args(args) as executor:
        return train(args, executor)

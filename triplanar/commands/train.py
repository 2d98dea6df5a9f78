"""``triplanar train``: train PPO on TriPlanarShear-v0 (thin wrapper over :mod:`agents.train_ppo`)."""

from __future__ import annotations

import argparse

NAME = "train"
HELP = "train PPO on TriPlanarShear-v0 (hyperparameters in a YAML file; resumes from checkpoints)"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from agents.train_ppo import add_arguments as add  # noqa: PLC0415
    add(parser)


def run(args: argparse.Namespace) -> int:
    from agents.train_ppo import run as train  # noqa: PLC0415
    return train(args)

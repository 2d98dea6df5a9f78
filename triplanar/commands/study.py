"""``triplanar study --out DIR``: the actuator design study (thin wrapper over :mod:`experiments.study`)."""

from __future__ import annotations

import argparse

NAME = "study"
HELP = "actuator design study: train PPO, evaluate every controller at the 12 loads, write tables, plots, report"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from experiments.study import add_arguments as add  # noqa: PLC0415
    add(parser)


def run(args: argparse.Namespace) -> int:
    from experiments.study import run as study  # noqa: PLC0415
    return study(args)

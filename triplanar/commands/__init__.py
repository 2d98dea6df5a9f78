"""CLI subcommands; each module: NAME, HELP, add_arguments(parser), run(args) -> int.

A command that needs the RL stack (``train``, ``study``) imports :mod:`agents`/:mod:`experiments` inside
``run()`` only, so ``triplanar --help`` and the physics and workbench commands work without torch.
"""

from __future__ import annotations

from ..cli_args import add_model_arguments, load_specimen, parse_effects

__all__ = ["add_model_arguments", "load_specimen", "parse_effects"]

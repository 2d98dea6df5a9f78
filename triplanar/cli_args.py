"""Command-line options shared by the core's commands and the workbench's (``--specimen``, ``--effect``).

They live here, below both :mod:`triplanar.commands` and :mod:`triplanar.workbench`, because the workbench
must not import the commands (data flows triplanar -> workbench -> commands).
"""

from __future__ import annotations

import argparse

from .effects import Effect, make_effect
from .specimen import Foundation, Specimen, load_toml, reference


def add_model_arguments(parser: argparse.ArgumentParser) -> None:
    """The options every command that builds a model shares: ``--specimen`` and repeated ``--effect``."""
    parser.add_argument("--specimen", metavar="S.toml", help="specimen and foundation TOML (default: the "
                        "reference specimen, triplanar/data/reference.toml)")
    parser.add_argument("--effect", action="append", default=[], metavar="NAME[:P=V,...]",
                        help="add an effect with fixed parameters, e.g. end_friction:phi_deg=8 (repeatable)")


def parse_effects(specs: list[str]) -> list[Effect]:
    """``--effect`` values as effects (a bad one raises :class:`triplanar.EffectError` naming it)."""
    return [make_effect(spec) for spec in specs]


def load_specimen(path: str | None) -> tuple[Specimen, Foundation]:
    """(specimen, foundation) from ``--specimen`` or the reference."""
    return load_toml(path) if path else reference()

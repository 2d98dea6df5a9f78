"""Command-line options shared by the core's commands and the workbench's (``--specimen``, ``--effect``).

They live here, below both :mod:`triplanar.commands` and :mod:`triplanar.workbench`, because the workbench
must not import the commands (data flows triplanar -> workbench -> commands).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from .effects import Effect, EffectError, make_effect
from .specimen import Foundation, Specimen, load_toml, reference


def add_model_arguments(parser: argparse.ArgumentParser) -> None:
    """The options every command that builds a model shares: ``--specimen`` and repeated ``--effect``."""
    parser.add_argument("--specimen", metavar="S.toml", help="specimen and foundation TOML (format: "
                        "docs/specimen-format.md; default: the reference specimen, triplanar/data/reference.toml)")
    parser.add_argument("--effect", action="append", default=[], metavar="NAME[:P=V,...]",
                        help="add an effect with fixed parameters, e.g. end_friction:phi_deg=8 (repeatable)")


def parse_effects(specs: list[str]) -> list[Effect]:
    """``--effect`` values as effects (a bad one raises :class:`triplanar.EffectError` naming it); an effect named
    twice is refused (which one would hold?)."""
    effects = [make_effect(spec) for spec in specs]
    names = [e.name for e in effects]
    for name in names:
        if names.count(name) > 1:
            raise EffectError(f"--effect {name} given {names.count(name)} times; give each effect once")
    return effects


def load_specimen(path: str | None) -> tuple[Specimen, Foundation]:
    """(specimen, foundation) from ``--specimen`` or the reference."""
    return load_toml(path) if path else reference()


def refuse_overwriting(outputs: list[tuple[str, str | None]], inputs: list[tuple[str, str | None]]) -> None:
    """A ValueError if an output option names the same file as an input option (``[(option, path), ...]``;
    ``None`` paths are skipped): nothing the user gave is overwritten."""
    for out_option, out in outputs:
        for in_option, given in inputs:
            if out and given:
                a, b = Path(out), Path(given)
                same = a.samefile(b) if a.exists() and b.exists() else a.resolve() == b.resolve()
                if same:
                    raise ValueError(f"{out_option} {out} is the input {in_option} {given}; it would be "
                                     "overwritten. Choose another output path")

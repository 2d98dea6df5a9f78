"""CLI subcommands; each module: NAME, HELP, add_arguments(parser), run(args) -> int."""

from __future__ import annotations

import argparse

from ..effects import Effect, make_effect


def add_model_arguments(parser: argparse.ArgumentParser) -> None:
    """The options every command that builds a model shares: ``--specimen`` and repeated ``--effect``."""
    parser.add_argument("--specimen", metavar="S.toml", help="specimen and foundation TOML (format: "
                        "docs/specimen-format.md; default: the reference specimen, triplanar/data/reference.toml)")
    parser.add_argument("--effect", action="append", default=[], metavar="NAME[:P=V,...]",
                        help="add an effect with fixed parameters, e.g. end_friction:phi_deg=8 (repeatable)")


def parse_effects(specs: list[str]) -> list[Effect]:
    """The ``--effect`` options as effects; an effect named twice is refused (which one would hold?)."""
    from ..effects import EffectError
    effects = [make_effect(spec) for spec in specs]
    names = [e.name for e in effects]
    for name in names:
        if names.count(name) > 1:
            raise EffectError(f"--effect {name} given {names.count(name)} times; give each effect once")
    return effects


def load_specimen(path: str | None):
    """(specimen, foundation) from ``--specimen`` or the reference."""
    from ..specimen import load_toml, reference
    return load_toml(path) if path else reference()


def refuse_overwriting(outputs: list[tuple[str, str | None]], inputs: list[tuple[str, str | None]]) -> None:
    """A ValueError if an output option names the same file as an input option (``[(option, path), ...]``;
    ``None`` paths are skipped): nothing the user gave is overwritten."""
    from pathlib import Path
    for out_option, out in outputs:
        for in_option, given in inputs:
            if out and given:
                a, b = Path(out), Path(given)
                same = a.samefile(b) if a.exists() and b.exists() else a.resolve() == b.resolve()
                if same:
                    raise ValueError(f"{out_option} {out} is the input {in_option} {given}; it would be "
                                     "overwritten. Choose another output path")

"""Shared plumbing of the workbench's commands, ``compare``, ``diagnose`` and ``fit``: their options, parsed into
the workbench's plain arguments."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

from ..effects import REGISTRY, EffectError
from ..measurement import MeasuredTest
from ..plugins import import_plugins  # re-exported: commands and tests import it from here
from ..executor import DEFAULT_WORKERS
from .options import (add_executor_arguments, add_model_arguments, executor_from_args, load_specimen, parse_effects,
                      refuse_idle_effects, refuse_overwriting)

if TYPE_CHECKING:  # (the workbench is imported when a command runs: building the parser needs none of it)
    from ..workbench.spec import ModelSpec


def add_data_arguments(parser: argparse.ArgumentParser, default_out: str) -> None:
    parser.add_argument("data", metavar="DATA.csv", help="measured traces (format: docs/measurement-format.md)")
    add_model_arguments(parser)
    parser.add_argument("--plugin", action="append", default=[], metavar="MODULE",
                        help="import this module (a name on the Python path, or a .py file) first, so that the "
                             "effects it registers can be used with --effect and become candidates (repeatable)")
    parser.add_argument("--out", metavar="DIR", default=default_out, help=f"output directory (default {default_out})")
    parser.add_argument("--no-plots", action="store_true",
                        help="write the report only, no figures (batch runs); figures an earlier run left in DIR are "
                             "removed, so that none disagrees with this report")


def add_start_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--start", action="append", default=[], metavar="NAME:P=V[,P=V...]",
                        help="start the fit of effect NAME's parameters P at V (repeatable), instead of the neutral "
                             "value where the effect does nothing (e.g. an oscillating force's amplitude)")
    parser.add_argument("--per-test", action="append", default=[], metavar="NAME:P[,P...]",
                        help="fit effect NAME's parameters P for each test separately (the others are shared by all "
                             "tests), e.g. the phase of a ripple that is not locked to the actuator's start "
                             "(repeatable; an effect may also declare them, Parameter(per_test=True))")


def parse_starts(specs: list[str]) -> dict[str, dict[str, float]]:
    """``--start`` values as ``{effect: {param: value}}``; a bad one raises :class:`EffectError` naming it."""
    from ..effects import make_effect
    out: dict[str, dict[str, float]] = {}
    for spec in specs:
        name, _, rest = spec.partition(":")
        if not rest.strip():
            raise EffectError(f"--start {spec!r}: give NAME:P=V[,P=V...]")
        effect = make_effect(spec)  # names the unknown effect, parameter, bad number or out-of-bounds value
        if effect.name in out:
            raise EffectError(f"--start {effect.name} given twice; give each effect once")
        keys = [item.partition("=")[0].strip() for item in rest.split(",") if item.strip()]
        out[effect.name] = {k: effect.values[k] for k in keys}
    return out


def parse_per_test(specs: list[str]) -> dict[str, list[str]]:
    """``--per-test`` values as ``{effect: [param, ...]}``; a bad one raises :class:`EffectError` naming it."""
    out: dict[str, list[str]] = {}
    for spec in specs:
        name, _, rest = spec.partition(":")
        name = name.strip()
        params = [p.strip() for p in rest.split(",") if p.strip()]
        if not params:
            raise EffectError(f"--per-test {spec!r}: give NAME:PARAM[,PARAM...]")
        if name not in REGISTRY:
            raise EffectError(f"--per-test {spec!r}: unknown effect {name!r}; known effects: "
                              f"{', '.join(sorted(REGISTRY))}")
        known = REGISTRY[name].parameters
        for p in params:
            if p not in known:
                raise EffectError(f"--per-test {spec!r}: effect {name!r} has no parameter {p!r} (its parameters: "
                                  f"{', '.join(known) or 'none'})")
            if "=" in p:
                raise EffectError(f"--per-test {spec!r}: give parameter names only, not values")
        if name in out:
            raise EffectError(f"--per-test {name} given twice; give each effect once")
        out[name] = params
    return out


def add_worker_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--workers", type=int, default=DEFAULT_WORKERS, metavar="N",
                        help=f"processes for the sweep (default {DEFAULT_WORKERS}; 1: in this process)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_executor_arguments(parser)


def model_and_tests(args: argparse.Namespace) -> tuple[ModelSpec, list[MeasuredTest]]:
    """The user's model (case B + ``--effect``s, ``--specimen``) and the validated tests."""
    from ..workbench.compare import load_tests
    from ..workbench.spec import ModelSpec
    import_plugins(args.plugin)
    effects = parse_effects(args.effect)
    specimen, foundation = load_specimen(args.specimen)
    if args.specimen:
        spec = ModelSpec.from_effects(effects, specimen, foundation)
    else:
        spec = ModelSpec.from_effects(effects)
    spec.build(30.0)  # an inconsistent model (e.g. an effect the specimen check refuses) fails here
    bare = ModelSpec.from_effects([], specimen, foundation) if args.specimen else ModelSpec()
    refuse_idle_effects(args.effect, effects, bare.build(30.0))
    tests = load_tests(args.data, specimen)
    return spec, tests


def check_effect_names(names: list[str]) -> list[str]:
    for name in names:
        if name not in REGISTRY:
            raise EffectError(f"unknown effect {name!r}; known effects: {', '.join(sorted(REGISTRY))}")
    return names


def executor_for(args: argparse.Namespace):
    """The ``--executor`` (default: the ``--workers`` pool, in this process for 1), shut down on exit."""
    return executor_from_args(args, max(1, int(args.workers)))


def refuse_overwriting_inputs(args: argparse.Namespace, outputs: list[tuple[str, Path | str]]) -> None:
    """Refuse (ValueError naming both) an output that would replace one of the command's input files
    (:func:`triplanar.commands.options.refuse_overwriting` over the data, ``--specimen`` and ``.py`` plugins)."""
    inputs = [("DATA.csv", args.data)]
    if getattr(args, "specimen", None):
        inputs.append(("--specimen", args.specimen))
    inputs += [("--plugin", p) for p in getattr(args, "plugin", []) if p.endswith(".py")]
    refuse_overwriting(outputs, inputs)


def drop_figures(out: Path, names: tuple[str, ...]) -> None:
    """``--no-plots``: remove the figures ``names`` an earlier run left in ``out`` (none may disagree with the report
    this run writes)."""
    for name in names:
        (out / name).unlink(missing_ok=True)


def out_dir(args: argparse.Namespace) -> Path:
    path = Path(args.out)
    path.mkdir(parents=True, exist_ok=True)
    return path

"""Command-line options shared by the commands (``--specimen``, ``--effect``, ``--executor``) and the one guard
against an output that would overwrite an input. The library takes plain arguments; this is where the flags become
them."""

from __future__ import annotations

import argparse
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Iterator

from ..effects import Effect, EffectError, make_effect
from ..specimen import Foundation, Specimen, load_toml, reference


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


def effects_help() -> str:
    """The registered effects and their parameters (unit, default, bounds), for ``--help``."""
    from ..effects import REGISTRY
    lines = ["effects (--effect NAME:P=V,...; angles in degrees):"]
    for name, cls in REGISTRY.items():
        kind = " [instrument]" if cls.acts_on == "instrument" else ""
        params = ", ".join(f"{k} ({p.unit or '-'}, default {p.default:g}, [{p.lower:g}, {p.upper:g}])"
                           for k, p in cls.parameters.items())
        lines.append(f"  {name}{kind}: {params or 'no parameters'}")
    lines.append("  (and those a --plugin module registers)")
    return "\n".join(lines)


def refuse_idle_effects(specs: list[str], effects: list[Effect], model: Any) -> None:
    """An ``--effect NAME`` given without values that would leave ``model`` unchanged (its defaults are neutral, e.g.
    ``rate_friction``, ``a = 0``) is refused with an example, rather than added silently. Effects with a force or
    that change what is recorded are not judged (that needs a simulation)."""
    import numpy as np
    for spec, effect in zip(specs, effects):
        if spec.partition(":")[2].strip() or effect.has_wrench or effect.reads:
            continue
        if np.array_equal(model.with_effects([effect]).kernel_params(), model.kernel_params()):
            example = type(effect).scenario or {k: p.upper / 4 for k, p in effect.parameters.items() if p.free}
            shown = ",".join(f"{k}={v:g}" for k, v in example.items())
            raise EffectError(f"--effect {spec.strip()}: without values it changes nothing in this model (its "
                              f"defaults: {effect!r}); give its parameters, e.g. --effect {effect.name}:{shown}")


def load_specimen(path: str | None) -> tuple[Specimen, Foundation]:
    """(specimen, foundation) from ``--specimen`` or the reference."""
    return load_toml(path) if path else reference()


def same_file(a: str | Path, b: str | Path) -> bool:
    """True if ``a`` and ``b`` name the same file (also through links, or both missing but the same path)."""
    a, b = Path(a), Path(b)
    try:
        if a.exists() and b.exists():
            return a.samefile(b)
    except OSError:
        pass
    return a.resolve() == b.resolve()


def refuse_overwriting(outputs: list[tuple[str, str | Path | None]],
                       inputs: list[tuple[str, str | Path | None]]) -> None:
    """A ValueError if an output option names the same file as an input option (``[(option, path), ...]``;
    ``None`` paths are skipped): nothing the user gave is overwritten. The one such guard of the commands."""
    for out_option, out in outputs:
        for in_option, given in inputs:
            if out and given and same_file(out, given):
                raise ValueError(f"{out_option} {out} is the input {in_option} {given}; it would be "
                                 "overwritten. Choose another output path")


def add_executor_arguments(parser: argparse.ArgumentParser) -> None:
    """``--executor local|serial|ray`` and ``--ray-address ADDR``: where a command's sweep runs
    (``docs/scaling.md``)."""
    parser.add_argument("--executor", choices=["local", "serial", "ray"], default="local",
                        help="where the sweep runs: local (a process pool on this machine, default), serial (in "
                             "this process), ray (Ray tasks: the cluster at --ray-address or RAY_ADDRESS, else a "
                             "Ray started for this command on 127.0.0.1)")
    parser.add_argument("--ray-address", metavar="ADDR", default=None,
                        help="with --executor ray: the Ray cluster to join, e.g. 10.0.0.5:6379 or auto")


@contextmanager
def executor_from_args(args: argparse.Namespace, workers: int | None = None) -> Iterator[Any]:
    """The executor the flags ask for, shut down on exit: ``workers`` processes (``None``: the default pool) for
    local, this process for serial, Ray tasks for ray (a local Ray gets ``workers`` CPUs); ``--plugin`` modules
    reach Ray workers."""
    import importlib.util

    from ..executor import open_executor
    backend = getattr(args, "executor", "local") or "local"
    address = getattr(args, "ray_address", None)
    if address is not None and backend != "ray":
        raise ValueError(f"--ray-address {address}: give --executor ray too (the executor is {backend})")
    if workers is not None and workers < 1:
        raise ValueError(f"--workers {workers}: give at least 1")
    if backend == "ray" and importlib.util.find_spec("ray") is None:
        raise ValueError("--executor ray: Ray is not installed; pip install 'triplanar-shear[ray]' (or `make` "
                         "in a clone)")
    with open_executor(backend, address, workers, getattr(args, "plugin", None) or ()) as executor:
        yield executor

"""CLI subcommands; each module: NAME, HELP, add_arguments(parser), run(args) -> int.

A command that needs the RL stack (``train``, ``study``, ``evaluate``) imports :mod:`agents`/:mod:`experiments` inside
``run()`` only, so ``triplanar --help`` and the physics and workbench commands work without torch.
"""

from __future__ import annotations

import importlib.util

from .options import add_model_arguments, load_specimen, parse_effects, refuse_overwriting

#: What ``agents`` and ``experiments`` import beyond the core (the ``rl`` extra of ``pyproject.toml``).
RL_MODULES = ("torch", "stable_baselines3", "yaml")


class MissingDependency(ImportError):
    """A command needs packages this installation lacks; ``triplanar`` prints the message, no traceback."""


def require(modules: tuple[str, ...] | None = None, extra: str = "rl") -> None:
    """Raise :class:`MissingDependency` naming the missing ``modules`` (default :data:`RL_MODULES`) and how to
    install them: without it a lab user who installed only the core would get a traceback from deep inside."""
    missing = [m for m in (RL_MODULES if modules is None else modules) if importlib.util.find_spec(m) is None]
    if missing:
        raise MissingDependency(f"this command needs the '{extra}' extra ({', '.join(missing)} not installed): "
                                f"pip install 'triplanar-shear[{extra}]' (or `make` in a clone)")


__all__ = ["add_model_arguments", "load_specimen", "parse_effects", "refuse_overwriting", "MissingDependency", "require",
           "RL_MODULES"]

"""``triplanar`` command line: one subcommand per module in :mod:`triplanar.commands`.

A command module defines ``NAME``, ``HELP``, ``add_arguments(parser)`` and ``run(args) -> int``. Listing
it in ``COMMANDS`` is all it takes to appear here.
"""

from __future__ import annotations

import argparse
import importlib
import signal
import sys
import threading
from typing import Any

from .commands import MissingDependency

COMMANDS = ("simulate", "lab_data", "paper", "compare", "diagnose", "fit", "train", "study", "evaluate", "demo")


def command_modules() -> list[Any]:
    """The modules of :data:`COMMANDS` this installation has, in order."""
    modules = []
    for module_name in COMMANDS:
        try:
            modules.append(importlib.import_module(f"triplanar.commands.{module_name}"))
        except ModuleNotFoundError as err:
            if err.name != f"triplanar.commands.{module_name}":
                raise
            # (not written yet)
    return modules


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="triplanar", description="Tri-planar shear model of Galic, Glaser & "
                                     "Goodman (2008): simulate, reproduce the paper, compare with measurements.")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for module in command_modules():
        cmd = sub.add_parser(module.NAME, help=module.HELP, description=module.HELP)
        module.add_arguments(cmd)
        cmd.set_defaults(handler=module.run)
    return parser


def _terminated(signum, frame) -> None:
    raise SystemExit(128 + signum)


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    previous = None
    if threading.current_thread() is threading.main_thread():
        # SIGTERM unwinds like Ctrl-C: temporary files are removed and pools terminated on the way out.
        previous = signal.signal(signal.SIGTERM, _terminated)
    try:
        return int(args.handler(args) or 0)
    except (ValueError, OSError, MissingDependency) as err:  # bad input or installation: say what, no traceback
        print(f"triplanar {args.command}: error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:  # Ctrl-C: the pools and Ray were stopped on the way out (their scopes); no traceback
        print(f"triplanar {args.command}: interrupted", file=sys.stderr)
        return 130
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


if __name__ == "__main__":
    sys.exit(main())

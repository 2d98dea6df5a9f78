"""Command-line code lives in ``triplanar/commands/`` (and ``triplanar/cli.py``): the library (``triplanar``,
``envs``, ``agents``) takes plain arguments and never imports argparse; the ``python -m`` mains listed below parse
their own few options. Read from the sources, as ``tests/test_layering.py`` reads the imports."""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LIBRARY = ("triplanar", "envs", "agents")
COMMAND_LINE = (ROOT / "triplanar" / "commands", ROOT / "triplanar" / "cli.py")
# `python -m triplanar.warmup`: compiles the kernels after an install (Makefile), its --no-envs flag parsed in main()
SCRIPT_MAINS = {"triplanar/warmup.py"}


def imports_argparse(source: str) -> bool:
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import) and any(a.name == "argparse" for a in node.names):
            return True
        if isinstance(node, ast.ImportFrom) and node.module == "argparse":
            return True
    return False


def test_the_checker_sees_an_argparse_import():
    assert imports_argparse("def f():\n    from argparse import Namespace\n")
    assert not imports_argparse("import argparser_like\n")


def test_only_the_commands_import_argparse():
    found = []
    for package in LIBRARY:
        for path in sorted((ROOT / package).rglob("*.py")):
            rel = path.relative_to(ROOT).as_posix()
            if any(path == c or path.is_relative_to(c) for c in COMMAND_LINE) or rel in SCRIPT_MAINS:
                continue
            if imports_argparse(path.read_text()):
                found.append(rel)
    assert not found, f"argparse outside triplanar/commands/: {found} (take plain arguments; parse in a command)"

"""Function length: no function of the project over 100 lines, compiled kernels excepted (DEVELOPERS.md).

Read from the sources (nothing is imported), like tests/test_layering.py, and run with it by ``make lint``. A
function's length is from its ``def`` line (decorators excluded) to its last line, docstring and comments included,
nested functions counted in their enclosing one too. A numba-compiled function (decorated ``njit``/``jit``) is
exempt: splitting it can cost speed, and the ones over the limit say so in their docstring.
"""

from __future__ import annotations

import ast
from pathlib import Path
from typing import NamedTuple

ROOT = Path(__file__).resolve().parents[1]
FOLDERS = ("triplanar", "envs", "agents", "experiments", "benchmarks", "tests")
MAX_LINES = 100
COMPILERS = {"njit", "jit", "vectorize", "guvectorize", "cfunc"}


class Long(NamedTuple):
    path: str
    function: str
    lines: int


def _compiled(node: ast.FunctionDef | ast.AsyncFunctionDef) -> bool:
    for dec in node.decorator_list:
        target = dec.func if isinstance(dec, ast.Call) else dec
        name = target.attr if isinstance(target, ast.Attribute) else getattr(target, "id", "")
        if name in COMPILERS:
            return True
    return False


def long_functions(paths: list[Path], root: Path, limit: int = MAX_LINES) -> list[Long]:
    """The functions of ``paths`` longer than ``limit`` lines that are not compiled kernels."""
    out = []
    for path in paths:
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and not _compiled(node):
                lines = node.end_lineno - node.lineno + 1
                if lines > limit:
                    out.append(Long(str(path.relative_to(root)), node.name, lines))
    return out


def _sources() -> list[Path]:
    return sorted(p for folder in FOLDERS for p in (ROOT / folder).rglob("*.py"))


def test_no_function_is_over_100_lines_outside_compiled_kernels() -> None:
    assert long_functions(_sources(), ROOT) == []


def test_the_length_check_sees_a_long_function_and_exempts_a_compiled_one(tmp_path: Path) -> None:
    lines = [f"    x{i} = {i}\n" for i in range(MAX_LINES)]
    body, half = "".join(lines), "".join(lines[:MAX_LINES // 2])
    (tmp_path / "m.py").write_text(f"from numba import njit\n\ndef long():\n{body}\n\n"
                                   f"@njit(cache=True)\ndef kernel():\n{body}\n\n"
                                   f"def short():\n{half}\n")
    found = long_functions([tmp_path / "m.py"], tmp_path)
    assert found == [Long("m.py", "long", MAX_LINES + 1)]

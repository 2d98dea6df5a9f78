"""The envs' state is read through their public API (``get_state``/``set_state``, ``episode_bench``, ``contact_points``,
``reference_path``...): no module outside ``envs/`` reads an attribute of an env whose name starts with ``_``.

Read from the sources, as ``tests/test_layering.py`` reads the imports: the private names are those the classes in
``envs/`` define (``self._name = ...``, ``def _name``); a read of one of them on anything but ``self``/``cls`` outside
``envs/`` fails. ``tests/envs/`` tests the envs from the inside and is not checked.
"""

from __future__ import annotations

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CHECKED = ("agents", "experiments", "triplanar", "benchmarks", "examples", "tests")
INSIDE = (ROOT / "envs", ROOT / "tests" / "envs")
# Private names that the envs share with other classes, read here on those classes, not on an env: the estimator's
# own ``SpecimenBank._start`` (tests/agents/test_estimator.py).
NOT_ENV = {("tests/agents/test_estimator.py", "_start")}


def env_private_names() -> set[str]:
    names: set[str] = set()
    for path in sorted((ROOT / "envs").glob("*.py")):
        for cls in (n for n in ast.walk(ast.parse(path.read_text())) if isinstance(n, ast.ClassDef)):
            for node in ast.walk(cls):
                if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)) and node.name.startswith("_"):
                    names.add(node.name)
                elif isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store) \
                        and isinstance(node.value, ast.Name) and node.value.id == "self":
                    names.add(node.attr)
    return {n for n in names if n.startswith("_") and not n.endswith("__")}


def private_reads(source: str, names: set[str]) -> list[tuple[int, str]]:
    """(line, attribute) of every ``X._name`` in ``source`` with ``_name`` in ``names`` and ``X`` not self/cls."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Attribute) and node.attr in names \
                and not (isinstance(node.value, ast.Name) and node.value.id in ("self", "cls")):
            found.append((node.lineno, node.attr))
    return found


def test_the_checker_sees_a_private_read():
    names = env_private_names()
    assert {"_y", "_bs", "_queue", "_control_step"} <= names
    assert private_reads("s = env.unwrapped._y.copy()\nself._y = 1\n", names) == [(1, "_y")]


def test_no_module_outside_envs_reads_an_env_private_attribute():
    names = env_private_names()
    offences = []
    for package in CHECKED:
        for path in sorted((ROOT / package).rglob("*.py")):
            if any(path.is_relative_to(inside) for inside in INSIDE):
                continue
            rel = path.relative_to(ROOT).as_posix()
            offences += [f"{rel}:{line} reads {attr}" for line, attr in private_reads(path.read_text(), names)
                         if (rel, attr) not in NOT_ENV]
    assert not offences, "use the env's public API (get_state, set_state, ...):\n" + "\n".join(offences)

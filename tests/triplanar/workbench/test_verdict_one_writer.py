"""The verdict is made in one place: no workbench module writes a verdict attribute on a diagnoser, and a ``Verdict``
is constructed only by ``rules.decide`` (read from the sources, after importing every workbench module)."""

from __future__ import annotations

import ast
import dataclasses
import importlib
import pkgutil
from pathlib import Path

import pytest

import triplanar.workbench as workbench

#: attributes that carried (parts of) the verdict when several modules wrote them on the diagnoser
VERDICT_ATTRIBUTES = {"verdict_", "reason_", "missing_effect_", "missing_effects_", "confidence_", "unexplained_mm_",
                      "combination_", "experiments_", "combined_spec_", "best_label_", "after_",
                      "time_domain_after_", "growth_after_", "systematic_after_", "best_", "lookalikes_", "report_"}
#: the two results ``Diagnoser.fit`` owns, and the one place each is written
OWNED = {"evidence_": ("diagnose", "fit"), "decision_": ("diagnose", "fit")}


def _modules() -> dict[str, ast.Module]:
    out = {}
    for info in pkgutil.iter_modules(workbench.__path__):
        module = importlib.import_module(f"triplanar.workbench.{info.name}")
        out[info.name] = ast.parse(Path(module.__file__).read_text(encoding="utf-8"))
    return out


def _functions(tree: ast.Module):
    """``(function name, node)`` for every node, with the innermost enclosing function's name."""
    def walk(node: ast.AST, name: str):
        for child in ast.iter_child_nodes(node):
            inner = child.name if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)) else name
            yield inner, child
            yield from walk(child, inner)
    yield from walk(tree, "<module>")


def _written(node: ast.AST) -> list[str]:
    """Attribute names ``node`` assigns (``x.attr = ...``, ``x.attr += ...``, ``setattr(x, "attr", ...)``)."""
    targets: list[ast.AST] = []
    if isinstance(node, ast.Assign):
        targets = list(node.targets)
    elif isinstance(node, (ast.AugAssign, ast.AnnAssign)):
        targets = [node.target]
    elif isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id == "setattr" \
            and len(node.args) >= 2 and isinstance(node.args[1], ast.Constant):
        return [str(node.args[1].value)]
    names = []
    for t in targets:
        for sub in ast.walk(t):
            if isinstance(sub, ast.Attribute):
                names.append(sub.attr)
    return names


def test_every_workbench_module_is_read() -> None:
    modules = _modules()
    assert {"diagnose", "rules", "verdict", "combine", "experiment", "alternatives"} <= set(modules)


def test_no_module_writes_a_verdict_attribute() -> None:
    offences = []
    for name, tree in _modules().items():
        for function, node in _functions(tree):
            for attr in _written(node):
                if attr in VERDICT_ATTRIBUTES:
                    offences.append(f"{name}.{function} writes .{attr}")
                elif attr in OWNED and OWNED[attr] != (name, function):
                    offences.append(f"{name}.{function} writes .{attr} (only diagnose.fit may)")
    assert not offences, offences


def test_a_verdict_is_constructed_only_by_decide() -> None:
    makers = []
    for name, tree in _modules().items():
        for function, node in _functions(tree):
            if isinstance(node, ast.Call):
                called = node.func.id if isinstance(node.func, ast.Name) else \
                    node.func.attr if isinstance(node.func, ast.Attribute) else None
                if called == "Verdict":
                    makers.append(f"{name}.{function}")
    assert makers == ["rules.decide"]


def test_the_verdict_is_a_frozen_value() -> None:
    from triplanar.workbench.verdict import Reason, Verdict, VerdictKind
    verdict = Verdict(VerdictKind.NONE_MISSING, (), None, "none", (Reason("nothing", "QUIET_FACTOR", 0.4, 0.6),), 0.4)
    with pytest.raises(dataclasses.FrozenInstanceError):
        verdict.kind = VerdictKind.LIBRARY_EFFECT      # type: ignore[misc]
    assert verdict.reason == "nothing"

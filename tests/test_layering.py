"""Layering: triplanar -> envs -> agents -> experiments, and triplanar -> workbench -> commands.

Two kinds of check. The import graph, read from the sources (every ``import`` statement of the project's packages,
those inside functions and under ``if TYPE_CHECKING:`` included: a type-only import is still a dependency a reader
follows): no module imports one that imports it back, directly or through others, and no module imports a layer
above its own. And, each in a fresh interpreter,
``sys.modules`` after an import: the physics and workbench must work for a lab user who installed the package
without the ``rl`` extra (no torch, no stable-baselines3).
"""

from __future__ import annotations

import ast
import json
import os
import subprocess
import sys
from pathlib import Path
from typing import NamedTuple

import pytest

ROOT = Path(__file__).resolve().parents[1]
RL = ("torch", "stable_baselines3", "tensorboard")
PACKAGES = ("triplanar", "envs", "agents", "experiments")
# Each package may import only the packages listed here (besides itself): data flows left to right.
MAY_IMPORT = {"triplanar": (), "envs": ("triplanar",), "agents": ("triplanar", "envs"),
              "experiments": ("triplanar", "envs", "agents")}
# Imports of a higher layer that are part of the design, as (module, enclosing function): the `train`, `study` and
# `evaluate` commands load the RL stack inside run() after checking that the `rl` extra is installed, and the warm-up compiles
# the environments' kernels through their public API when Gymnasium is installed.
ALLOWED_UPWARD = {("triplanar.commands.train", "run"), ("triplanar.commands.study", "run"),
                  ("triplanar.commands.evaluate", "run"), ("triplanar.warmup", "warm_envs"),
                  ("triplanar.commands.demo", "_rendered_episode"),   # the demo renders one episode
                  # the `python -m experiments.distill_labels` script takes the commands' --executor options
                  ("experiments.distill_labels", "parse_args"), ("experiments.distill_labels", "main")}
# The import circles left, each with its reason (a new one goes here, with its reason):
KNOWN_CIRCLES: list[set[str]] = [
    # Type-only (model -> effects at run time; effects -> model under TYPE_CHECKING): an effect's `apply` takes the
    # model that will hold it and returns the model with itself added, and a user effect's `wrench` reads the
    # model's BlockState. The Effect protocol is defined by the model it changes; splitting it would leave the
    # annotations saying less than they do.
    {"triplanar.effects", "triplanar.model"},
]


class Import(NamedTuple):
    source: str     # the importing module
    target: str     # the imported module of the project
    function: str   # the enclosing function's qualified name, "" at module level
    line: int


def _module_name(path: Path, root: Path) -> str:
    parts = list(path.relative_to(root).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


class _Imports(ast.NodeVisitor):
    """The project imports of one module. ``from X import name`` counts as an import of ``X.name`` when that is a
    module, else of ``X``. A package's ``__init__`` also runs when one of its modules is imported; those implicit
    imports are not counted (a package that re-exports its modules would otherwise circle with each of them)."""

    def __init__(self, module: str, is_package: bool, modules: set[str], packages: tuple[str, ...]):
        self.module, self.modules, self.packages = module, modules, packages
        self.base = module if is_package else module.rpartition(".")[0]
        self.scope: list[str] = []
        self.found: list[Import] = []

    def _add(self, target: str, node: ast.stmt) -> None:
        if target in self.modules and target != self.module:
            self.found.append(Import(self.module, target, ".".join(self.scope), node.lineno))

    def _visit_scope(self, node: ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef) -> None:
        self.scope.append(node.name)
        self.generic_visit(node)
        self.scope.pop()

    visit_FunctionDef = visit_AsyncFunctionDef = visit_ClassDef = _visit_scope

    def visit_Import(self, node: ast.Import) -> None:
        for alias in node.names:
            self._add(alias.name, node)

    def visit_ImportFrom(self, node: ast.ImportFrom) -> None:
        if node.level:
            base = self.base.split(".")
            base = base[:len(base) - node.level + 1]
            source = ".".join(base + ([node.module] if node.module else []))
        else:
            source = node.module or ""
        if source.split(".")[0] not in self.packages:
            return
        for alias in node.names:
            sub = f"{source}.{alias.name}"
            self._add(sub if sub in self.modules else source, node)


def import_graph(root: Path = ROOT, packages: tuple[str, ...] = PACKAGES) -> list[Import]:
    """Every import, between modules of ``packages`` under ``root``, written in their sources."""
    files = {_module_name(path, root): path for package in packages for path in sorted((root / package).rglob("*.py"))}
    found: list[Import] = []
    for module, path in files.items():
        visitor = _Imports(module, path.name == "__init__.py", set(files), packages)
        visitor.visit(ast.parse(path.read_text(encoding="utf-8"), str(path)))
        found += visitor.found
    return found


def circles(imports: list[Import]) -> list[set[str]]:
    """The groups of modules that import each other, directly or through others (strongly connected components of
    more than one module, Tarjan's algorithm)."""
    graph: dict[str, set[str]] = {}
    for imp in imports:
        graph.setdefault(imp.source, set()).add(imp.target)
        graph.setdefault(imp.target, set())
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    out: list[set[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            group = set()
            while True:
                w = stack.pop()
                group.add(w)
                if w == v:
                    break
            if len(group) > 1:
                out.append(group)

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return out


def upward_imports(imports: list[Import], may_import: dict[str, tuple[str, ...]] = MAY_IMPORT) -> list[Import]:
    """Imports of a layer above the importer's, and imports of the commands from outside the CLI."""
    bad = []
    for imp in imports:
        source, target = imp.source.split(".")[0], imp.target.split(".")[0]
        upward = target != source and target not in may_import[source]
        commands = (imp.target.startswith("triplanar.commands") and imp.source != "triplanar.cli"
                    and not imp.source.startswith("triplanar.commands"))
        if (upward or commands) and (imp.source, imp.function.split(".")[0]) not in ALLOWED_UPWARD:
            bad.append(imp)
    return bad


def _known(imp: Import) -> bool:
    return any({imp.source, imp.target} <= group for group in KNOWN_CIRCLES)


@pytest.fixture(scope="module")
def project_imports() -> list[Import]:
    """The project's import graph, read once for the tests below (parsing every source costs ~1.5 s of CPU)."""
    return import_graph()


def test_no_module_imports_one_that_imports_it_back(project_imports) -> None:
    found = circles(project_imports)
    assert [c for c in found if c not in KNOWN_CIRCLES] == []


def test_no_module_imports_a_layer_above_its_own(project_imports) -> None:
    assert [imp for imp in upward_imports(project_imports) if not _known(imp)] == []


def test_the_known_circles_are_still_there(project_imports) -> None:
    """When a known circle is gone, its exception goes too (so that it cannot come back unnoticed)."""
    found = circles(project_imports)
    assert all(group in found for group in KNOWN_CIRCLES)


def test_the_import_checks_see_circles_function_imports_and_upward_imports(tmp_path: Path) -> None:
    files = {
        "low/__init__.py": "from .a import f\n",
        "low/a.py": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from .c import C\ndef f():\n"
                    "    from . import b\n",
        "low/b.py": "import low.a\n",
        "low/c.py": "from low import a\n",
        "high/__init__.py": "",
        "high/d.py": "import low.b\n",
        "low/e.py": "def g():\n    from high import d\n",
    }
    for name, text in files.items():
        (tmp_path / name).parent.mkdir(exist_ok=True)
        (tmp_path / name).write_text(text)
    imports = import_graph(tmp_path, ("low", "high"))
    # a -> b inside a function; a -> c only for type checking: both count
    assert sorted(map(sorted, circles(imports))) == [["low.a", "low.b", "low.c"]]
    assert upward_imports(imports, {"low": (), "high": ("low",)}) == [Import("low.e", "high.d", "g", 2)]


def _loaded_after(code: str) -> set[str]:
    """Top-level package names in ``sys.modules`` after running ``code`` in a fresh interpreter."""
    script = f"{code}\nimport json, sys\nprint(json.dumps(sorted(sys.modules)))"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    out = subprocess.run([sys.executable, "-c", script], cwd=ROOT, env=env, capture_output=True, text=True,
                         check=True).stdout
    return set(json.loads(out.strip().splitlines()[-1]))


def _top(modules: set[str]) -> set[str]:
    return {m.split(".")[0] for m in modules}


@pytest.mark.parametrize("code", [
    "import triplanar",
    "import triplanar.workbench.compare, triplanar.workbench.diagnose, triplanar.workbench.fit, triplanar.paper, "
    "triplanar.labdata",
    "import triplanar.cli; triplanar.cli.build_parser()",
])
def test_the_core_imports_neither_gymnasium_nor_the_rl_stack(code: str) -> None:
    loaded = _loaded_after(code)
    assert not _top(loaded) & {*RL, "gymnasium", "envs", "agents", "experiments"}
    if "workbench" in code:     # the library takes plain arguments: none of the command line (one interpreter for both)
        assert "triplanar.commands" not in loaded
    if "build_parser" in code:
        # every command starts by building the parser: the workbench (scipy.stats, its compiled comparison) cost
        # 2.6 s of CPU there, for commands that never use it; its commands import it when they run
        assert "triplanar.workbench" not in loaded and "scipy.stats" not in loaded


def test_envs_and_make_vec_need_no_rl_stack() -> None:
    loaded = _loaded_after("import gymnasium as gym, envs\n"
                           "gym.make_vec('TriPlanarShear-v0', num_envs=2).close()")
    assert "envs.vector" in loaded
    assert not _top(loaded) & {*RL, "agents", "experiments"}


def test_a_command_needing_a_missing_extra_says_how_to_install_it(monkeypatch, capsys) -> None:
    from triplanar import cli, commands
    monkeypatch.setattr(commands, "RL_MODULES", ("no_such_module_for_this_test",))
    assert cli.main(["train", "--timesteps", "1", "--out", "unused"]) == 2
    err = capsys.readouterr().err
    assert "no_such_module_for_this_test not installed" in err and "triplanar-shear[rl]" in err

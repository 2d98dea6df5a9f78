"""User plugins (``--plugin``): modules that register effects, imported here and on every remote worker.

A plugin is a module name on the Python path or a ``.py`` file. A file is imported as the module
``triplanar_plugin_<stem>``, so that objects of its classes pickle by reference; for Ray workers on other
machines the file's source travels with each sweep (:func:`plugin_sources`) and is imported there under the same
name (:func:`ensure_plugins`), so a user's effect works on a cluster without copying files to the nodes. A
plugin given by module name must be installed on every node (or shipped with Ray's ``runtime_env``).
"""

from __future__ import annotations

import importlib
import importlib.util
import sys
import types
from pathlib import Path
from typing import Sequence

PluginSource = tuple[str, str | None, str]  # (module name, source text of a .py plugin or None, what the user gave)


def plugin_module_name(path: str | Path) -> str:
    """The module name a ``.py`` plugin is imported as."""
    return f"triplanar_plugin_{Path(path).stem}"


def import_plugins(plugins: Sequence[str]) -> None:
    """Import user modules that register effects (``--plugin``); an OSError names a missing one."""
    for plugin in plugins:
        path = Path(plugin)
        if plugin.endswith(".py"):
            if not path.is_file():
                raise OSError(f"--plugin {plugin}: no such file")
            name = plugin_module_name(path)
            spec = importlib.util.spec_from_file_location(name, path)
            module = importlib.util.module_from_spec(spec)
            sys.modules[name] = module
            spec.loader.exec_module(module)
        else:
            try:
                importlib.import_module(plugin)
            except ModuleNotFoundError as err:
                raise OSError(f"--plugin {plugin}: {err}") from None


def plugin_sources(plugins: Sequence[str]) -> tuple[PluginSource, ...]:
    """What a remote worker needs to import ``plugins``: a ``.py`` file's source text, a module's name."""
    sources = []
    for plugin in plugins:
        if plugin.endswith(".py"):
            try:
                text = Path(plugin).read_text(encoding="utf-8")
            except OSError as err:
                raise OSError(f"--plugin {plugin}: {err.strerror or err}") from None
            sources.append((plugin_module_name(plugin), text, plugin))
        else:
            sources.append((plugin, None, plugin))
    return tuple(sources)


def ensure_plugins(sources: Sequence[PluginSource]) -> None:
    """Import ``sources`` in this (worker) process, once each: a file's source under its plugin module name."""
    for name, text, given in sources:
        if name in sys.modules:
            continue
        if text is None:
            importlib.import_module(name)
            continue
        module = types.ModuleType(name)
        module.__file__ = given
        sys.modules[name] = module
        try:
            exec(compile(text, given, "exec"), module.__dict__)  # the user's own plugin, as on the driver
        except BaseException:
            del sys.modules[name]
            raise

"""The one way YAML input is read (training configurations, ``--set`` and ``--env-arg`` values): PyYAML's safe
loader (no Python objects), with the input's size and the size of what it expands to bounded before any use.

Bounds: a file of at most ``MAX_BYTES``; a value of at most ``MAX_NODES`` entries once its anchors and aliases
(``&a``/``*a``) are expanded (a few hundred bytes of nested aliases can otherwise stand for billions of entries) and
at most ``MAX_DEPTH`` levels deep. Numbers follow YAML 1.2: ``3e-4`` and ``1E5`` are numbers as ``3.0e-4`` is (YAML
1.1, PyYAML's default, reads the first two as strings); a quoted ``"3e-4"`` stays a string, which the checks of the
key refuse, naming it. PyYAML is the ``rl`` extra's: imported when a YAML is read.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

MAX_BYTES = 1_000_000
MAX_NODES = 100_000
MAX_DEPTH = 32
_FLOAT_12 = re.compile(r"^[-+]?(\.[0-9]+|[0-9]+(\.[0-9]*)?)([eE][-+]?[0-9]+)?$")


class YAMLInputError(ValueError):
    """YAML that is not read: invalid, too large, or expanding too far (the message names the source)."""


_LOADER: Any = None


def _loader() -> Any:
    global _LOADER
    if _LOADER is None:
        import yaml

        class Loader(yaml.SafeLoader):
            """Safe loader with YAML 1.2's float syntax added."""

        Loader.add_implicit_resolver("tag:yaml.org,2002:float", _FLOAT_12, list("-+0123456789."))
        _LOADER = Loader
    return _LOADER


def check_size(value: Any, source: str) -> None:
    """Refuse ``value`` if it has more than ``MAX_NODES`` entries (aliases counted each time they are used) or more
    than ``MAX_DEPTH`` levels."""
    stack, seen = [(value, 0)], 0
    while stack:
        node, depth = stack.pop()
        seen += 1
        if seen > MAX_NODES:
            raise YAMLInputError(f"{source}: more than {MAX_NODES} entries once its aliases are expanded")
        if depth > MAX_DEPTH:
            raise YAMLInputError(f"{source}: nested more than {MAX_DEPTH} levels deep")
        if isinstance(node, dict):
            stack.extend((x, depth + 1) for pair in node.items() for x in pair)
        elif isinstance(node, (list, tuple)):
            stack.extend((x, depth + 1) for x in node)


def load_text(text: str, source: str) -> Any:
    """The value of the YAML ``text`` (``source`` names it in errors)."""
    import yaml
    if len(text.encode("utf-8", "surrogatepass")) > MAX_BYTES:
        raise YAMLInputError(f"{source}: larger than {MAX_BYTES} bytes")
    try:
        value = yaml.load(text, Loader=_loader())  # a SafeLoader subclass: no Python objects
    except yaml.YAMLError as err:
        raise YAMLInputError(f"{source}: invalid YAML: {err}") from None
    except RecursionError:
        raise YAMLInputError(f"{source}: nested more than {MAX_DEPTH} levels deep") from None
    check_size(value, source)
    return value


def load_file(path: str | Path) -> Any:
    """The value of the YAML file at ``path``."""
    try:
        with open(path, "rb") as f:
            data = f.read(MAX_BYTES + 1)
    except OSError as err:
        raise YAMLInputError(f"{path}: cannot read it ({err.strerror})") from None
    if len(data) > MAX_BYTES:
        raise YAMLInputError(f"{path}: larger than {MAX_BYTES} bytes")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as err:
        raise YAMLInputError(f"{path}: not UTF-8 text ({err})") from None
    return load_text(text, str(path))

"""Results kept on disk between runs in a data format that cannot run code (never pickle): one ``.npz`` file
(read with ``allow_pickle=False``) holding the value's structure as JSON and its arrays as arrays.

What it stores: ``None``, booleans, integers, floats (non-finite ones too), strings, lists, tuples, dicts (any of
these as keys), NumPy arrays of numbers or booleans and NumPy scalars, and dataclasses of the project's own packages
(``triplanar``, ``envs``, ``agents``, ``experiments``, ``benchmarks``) whose fields are such values. Reading builds a
dataclass only if its module is already imported and the name is a dataclass there: a file names no code to run.
:func:`encode` raises :class:`PlainDataError` for anything else (callers that can do without, such as a task
checkpoint, then keep no file).
"""

from __future__ import annotations

import dataclasses
import io
import json
import math
import sys
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from .atomic import write_atomic

PACKAGES = ("triplanar", "envs", "agents", "experiments", "benchmarks")
_STRUCTURE = "__structure__"
_SCALARS = (bool, int, str, type(None))


class PlainDataError(ValueError):
    """A value that the plain-data format cannot hold, or a file that is not one of its files."""


def encode(value: Any, arrays: list[np.ndarray]) -> Any:
    """``value`` as JSON-compatible data; its arrays are appended to ``arrays`` and referred to by index."""
    if isinstance(value, _SCALARS):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else {"$float": repr(value)}
    if isinstance(value, np.generic):
        return {"$scalar": _array_ref(np.asarray(value), arrays)}
    if isinstance(value, np.ndarray):
        return {"$array": _array_ref(value, arrays)}
    if isinstance(value, list):
        return [encode(v, arrays) for v in value]
    if isinstance(value, tuple) and not hasattr(value, "_fields"):
        return {"$tuple": [encode(v, arrays) for v in value]}
    if isinstance(value, dict) and type(value) is dict:
        return {"$dict": [[encode(k, arrays), encode(v, arrays)] for k, v in value.items()]}
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        cls = type(value)
        if cls.__module__.split(".")[0] not in PACKAGES:
            raise PlainDataError(f"a {cls.__module__}.{cls.__qualname__} is not one of the project's dataclasses")
        return {"$dataclass": f"{cls.__module__}:{cls.__qualname__}",
                "fields": {f.name: encode(getattr(value, f.name), arrays) for f in dataclasses.fields(value)
                           if f.init}}
    raise PlainDataError(f"cannot store a {type(value).__module__}.{type(value).__qualname__} as plain data")


def _array_ref(array: np.ndarray, arrays: list[np.ndarray]) -> int:
    if array.dtype.kind not in "biufc":
        raise PlainDataError(f"cannot store an array of {array.dtype} as plain data")
    arrays.append(array)
    return len(arrays) - 1


def _dataclass(name: Any) -> type:
    module_name, _, qualname = str(name).partition(":")
    module = sys.modules.get(module_name)   # never imported on a file's say-so
    if module is None or module_name.split(".")[0] not in PACKAGES or "." in qualname:
        raise PlainDataError(f"unknown dataclass {name!r}")
    cls = getattr(module, qualname, None)
    if not (isinstance(cls, type) and dataclasses.is_dataclass(cls)):
        raise PlainDataError(f"unknown dataclass {name!r}")
    return cls


def decode(data: Any, arrays: dict[str, np.ndarray]) -> Any:
    """The value :func:`encode` turned into ``data`` (``arrays``: the file's arrays by name)."""
    if isinstance(data, (*_SCALARS, float)):
        return data
    if isinstance(data, list):
        return [decode(v, arrays) for v in data]
    if not isinstance(data, dict) or len(data) not in (1, 2):
        raise PlainDataError(f"unexpected entry {str(data)[:80]!r}")
    if "$float" in data:
        return float(data["$float"])
    if "$array" in data or "$scalar" in data:
        key = f"a{data.get('$array', data.get('$scalar'))}"
        if key not in arrays:
            raise PlainDataError(f"missing array {key}")
        return arrays[key].copy() if "$array" in data else arrays[key][()]
    if "$tuple" in data:
        return tuple(decode(v, arrays) for v in data["$tuple"])
    if "$dict" in data:
        return {_hashable(decode(k, arrays)): decode(v, arrays) for k, v in data["$dict"]}
    if "$dataclass" in data:
        cls = _dataclass(data["$dataclass"])
        names = {f.name for f in dataclasses.fields(cls) if f.init}
        # a field the class gained after the file was written reads as its default (kept results stay readable);
        # a field the class does not have, or a missing one without a default, is refused
        required = {f.name for f in dataclasses.fields(cls) if f.init and f.default is dataclasses.MISSING
                    and f.default_factory is dataclasses.MISSING}
        given = data.get("fields")
        if not isinstance(given, dict) or not required <= set(given) <= names:
            raise PlainDataError(f"{data['$dataclass']}: the fields do not match the class's")
        return cls(**{k: decode(v, arrays) for k, v in given.items()})
    raise PlainDataError(f"unexpected entry {str(data)[:80]!r}")


def _hashable(key: Any) -> Any:
    if isinstance(key, (list, dict)):
        raise PlainDataError(f"unhashable key {key!r}")
    return key


def dumps(value: Any) -> bytes:
    """``value`` as the bytes of an ``.npz`` file (:class:`PlainDataError` if it cannot be held)."""
    arrays: list[np.ndarray] = []
    structure = json.dumps(encode(value, arrays), allow_nan=False)
    buffer = io.BytesIO()
    np.savez(buffer, **{_STRUCTURE: np.frombuffer(structure.encode(), dtype=np.uint8)},
             **{f"a{i}": a for i, a in enumerate(arrays)})
    return buffer.getvalue()


def save(path: str | Path, value: Any) -> None:
    """Write ``value`` to ``path`` (an ``.npz`` file), completely or not at all."""
    data = dumps(value)
    write_atomic(path, lambda p: Path(p).write_bytes(data))


def load(path: str | Path) -> Any:
    """The value saved at ``path``; :class:`PlainDataError` (naming the file) if it is not such a file."""
    try:
        with np.load(path, allow_pickle=False) as npz:
            arrays = {k: npz[k] for k in npz.files}
        structure = json.loads(arrays.pop(_STRUCTURE).tobytes().decode())
        return decode(structure, arrays)
    except FileNotFoundError:
        raise
    except (PlainDataError, OSError, ValueError, KeyError, TypeError, EOFError, RecursionError,
            zipfile.BadZipFile) as err:
        raise PlainDataError(f"{path}: not a readable results file ({err})") from None

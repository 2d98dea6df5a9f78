"""Array layouts defined once: the named fields of a flat float64 array, their offsets computed from their sizes.

The compiled code keeps its state, parameters and scratch in flat arrays and indexes them by module-level integer
constants, which numba freezes in at compile time. Writing those offsets by hand (``S_V = 7``, ``P_C = 20``, ...)
let a field grow without its neighbours moving. A :class:`Layout` lists each field once, with its size and
meaning; the module that defines it names the plain integers (``PREFIX + NAME`` = offset, and the total size)
explicitly, so that the compiled code still sees integers and a reader or a linter sees every name, and asserts that
the names match the layout (a field added, removed or reordered without its name fails at import)::

    STATE = Layout("S_", "N_STATE", [("R", 3, "mass-centre position, m"), ("Q", 4, "unit quaternion"), ...])
    S_R, S_Q, ..., N_STATE = STATE.offsets()
    assert STATE.named_in(globals())
"""

from __future__ import annotations

from typing import Any, Iterable, NamedTuple


class Field(NamedTuple):
    name: str
    offset: int
    size: int
    doc: str


class Layout:
    """Consecutive named fields; ``start`` places the first one after another layout (a workspace extended by a
    module that owns more scratch rows)."""

    def __init__(self, prefix: str, size_name: str, fields: Iterable[tuple[str, int, str]], start: int = 0):
        self.prefix, self.size_name = prefix, size_name
        self.fields: dict[str, Field] = {}
        offset = start
        for name, size, doc in fields:
            if name in self.fields:
                raise ValueError(f"layout {prefix}*: field {name!r} defined twice")
            if size < 1:
                raise ValueError(f"layout {prefix}*: field {name!r} has size {size}")
            self.fields[name] = Field(name, offset, size, doc)
            offset += size
        self.size = offset

    def __getitem__(self, name: str) -> slice:
        """The field's slice of an array in this layout."""
        f = self.fields[name]
        return slice(f.offset, f.offset + f.size)

    def constants(self) -> dict[str, int]:
        """``{PREFIX + NAME: offset, size_name: size}``."""
        out = {self.prefix + f.name: f.offset for f in self.fields.values()}
        out[self.size_name] = self.size
        return out

    def offsets(self) -> tuple[int, ...]:
        """Every field's offset in order, then the total size: the right-hand side of the explicit assignment."""
        return (*(f.offset for f in self.fields.values()), self.size)

    def named_in(self, namespace: dict[str, Any]) -> bool:
        """Whether ``namespace`` (a module's ``globals()``) holds every one of :meth:`constants` under its name."""
        return all(key in namespace and namespace[key] == value for key, value in self.constants().items())

    def describe(self, array: Any) -> dict[str, Any]:
        """An array in this layout as ``{field: value or list}``, for people and tests."""
        return {f.name: float(array[f.offset]) if f.size == 1 else [float(v) for v in array[self[f.name]]]
                for f in self.fields.values()}

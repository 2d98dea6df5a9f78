"""Laboratory measured-trace CSV files: reading (strictly validated) and writing (atomic).

The format is specified in ``docs/measurement-format.md``. One CSV file holds any number of
constant-force shear tests, one row per sample::

    test_id, shear_force_N, [t_s], cp1_x1_m, [cp1_x2_m], cp1_x3_m, cp2_x1_m, ..., cp3_x3_m

Positions are in metres in the foundation frame of ``docs/specimen-format.md`` (origin where the three
foundation planes meet, ``x1`` forward, ``x2`` up, ``x3`` lateral). Laboratory users bring these
files, so the reader is strict: every problem raises :class:`MeasurementError` naming the file, the
(1-based) line number and the column, nothing read is silently dropped or altered, and a refused
file is refused whole (no partial result is returned).

Rules enforced by :func:`read_measurements`:

* the file is valid UTF-8 (a leading UTF-8 byte-order mark is accepted), not empty, and has at least
  one data row after the header;
* the header holds every required column, no column name twice; unknown extra columns are ignored
  (their values are not checked);
* every data row has as many fields as the header; ``test_id`` is not empty; two ids that differ only
  by surrounding whitespace (``" F1"`` and ``"F1"``) are refused (they would be two tests and fake a repeat
  scatter); an id does not start with ``=``, ``+``, ``@`` or a tab/carriage return (spreadsheets would run it
  as a formula when the results are opened);
* every numeric value is a finite decimal number written with ASCII digits (``nan``/``inf``, Arabic-Indic or
  full-width digits are refused); an optional ``x2``
  value may be empty (read as NaN), every other numeric value must be present;
* ``|position| <= 2`` m (larger values look like millimetres);
* ``shear_force_N`` is the same on all rows of a test; ``t_s`` strictly increases within a test;
* ``t_s`` is seconds from the moment the shear force is applied (the model's clock): each test's first time
  lies within ``MAX_START_TIME_S`` (1 s) of zero (a clock offset, e.g. a Unix time stamp, is refused rather
  than compared with the model) and a test lasts at most ``MAX_DURATION_S`` (60 s; longer looks like
  milliseconds);
* each test has at least 3 samples;
* blank lines are allowed only at the end of the file (a blank line between data rows is refused);
* optionally, each test's first sample lies within ``tolerance_m`` (horizontally) of the
  specimen's rest position of each contact point.
"""

from __future__ import annotations

import csv
import math
import re
from array import array
import os
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .atomic import remove_stale_temporaries, write_atomic

__all__ = [
    "MeasurementError",
    "MeasuredTest",
    "read_measurements",
    "write_measurements",
    "REQUIRED_COLUMNS",
    "OPTIONAL_COLUMNS",
    "POSITION_COLUMNS",
    "MAX_ABS_POSITION_M",
    "MIN_SAMPLES",
    "MAX_START_TIME_S",
    "MAX_DURATION_S",
]

#: Largest plausible |position| in metres; anything larger is taken to be millimetres.
MAX_ABS_POSITION_M = 2.0
#: Fewest samples a test may have.
MIN_SAMPLES = 3
#: First characters a test_id may not have (spreadsheet formula injection).
FORMULA_STARTS = ("=", "+", "@", "\t", "\r")
#: Largest |first t_s| of a test: times are seconds from load onset (the model's t = 0).
MAX_START_TIME_S = 1.0
#: Longest test in seconds; a longer one looks like milliseconds (the model's tests last about a second).
MAX_DURATION_S = 60.0

_AXES = ("x1", "x2", "x3")
#: POSITION_COLUMNS[k][a] is the column of contact point k+1, coordinate axis a (x1, x2, x3).
POSITION_COLUMNS: tuple[tuple[str, str, str], ...] = tuple(
    tuple(f"cp{k}_{ax}_m" for ax in _AXES) for k in (1, 2, 3)
)
_HORIZONTAL_COLUMNS = tuple(c for cp in POSITION_COLUMNS for c in (cp[0], cp[2]))
_VERTICAL_COLUMNS = tuple(cp[1] for cp in POSITION_COLUMNS)

REQUIRED_COLUMNS: tuple[str, ...] = ("test_id", "shear_force_N") + _HORIZONTAL_COLUMNS
OPTIONAL_COLUMNS: tuple[str, ...] = ("t_s",) + _VERTICAL_COLUMNS
_KNOWN_COLUMNS = frozenset(REQUIRED_COLUMNS + OPTIONAL_COLUMNS)


# --------------------------------------------------------------------------------------------------
# Error type
# --------------------------------------------------------------------------------------------------
class MeasurementError(ValueError):
    """A measured-trace file that cannot be read (or a test set that cannot be written).

    Attributes
    ----------
    path:
        The file concerned, as given by the caller.
    row:
        1-based line number in the file (the header is line 1), or ``None`` when the problem is not
        tied to one line.
    column:
        The column concerned, or ``None``.
    detail:
        The message without the location prefix.

    ``str(err)`` reads like ``"data.csv, row 17, column cp2_x3_m: value 'abc' is not a number"``.
    """

    def __init__(self, path: str | os.PathLike[str], row: int | None, column: str | None,
                 detail: str) -> None:
        self.path: str = os.fspath(path)
        self.row: int | None = row
        self.column: str | None = column
        self.detail: str = detail
        parts = [self.path]
        if row is not None:
            parts.append(f"row {row}")
        if column is not None:
            parts.append(f"column {column}")
        super().__init__(f"{', '.join(parts)}: {detail}")

    def __reduce__(self):  # keep pickling (e.g. multiprocessing) working with the custom __init__
        return (type(self), (self.path, self.row, self.column, self.detail))


# --------------------------------------------------------------------------------------------------
# Data container
# --------------------------------------------------------------------------------------------------
@dataclass(frozen=True, eq=False)
class MeasuredTest:
    """One measured constant-force shear test.

    ``positions[i, k, a]`` is coordinate ``a`` (x1, x2, x3) of contact point CP(k+1) at sample ``i``,
    metres, foundation frame; ``x2`` is NaN where the file has no value. ``rows[i]`` is the file line
    of sample ``i`` (0 for tests not read from a file). Arrays are stored as read-only copies.
    ``eq=False``: tests compare by identity (element-wise array comparison has no single truth value).
    """

    test_id: str
    shear_force_N: float
    positions: np.ndarray
    t_s: np.ndarray | None = None
    rows: np.ndarray = field(default=None)  # type: ignore[assignment]  # None -> zeros

    def __post_init__(self) -> None:
        if not isinstance(self.test_id, str):
            raise TypeError(f"test_id must be a str, got {type(self.test_id).__name__}")
        positions = np.array(self.positions, dtype=np.float64, copy=True)
        if positions.ndim != 3 or positions.shape[1:] != (3, 3):
            raise ValueError(
                f"test {self.test_id!r}: positions must have shape (n, 3, 3), got {positions.shape}")
        n = positions.shape[0]
        t_s = None
        if self.t_s is not None:
            t_s = np.array(self.t_s, dtype=np.float64, copy=True)
            if t_s.shape != (n,):
                raise ValueError(f"test {self.test_id!r}: t_s must have shape ({n},), got {t_s.shape}")
        if self.rows is None:
            rows = np.zeros(n, dtype=np.int64)
        else:
            rows = np.array(self.rows, copy=True)
            if rows.shape != (n,):
                raise ValueError(f"test {self.test_id!r}: rows must have shape ({n},), got {rows.shape}")
            if rows.size and not np.issubdtype(rows.dtype, np.integer):
                raise ValueError(f"test {self.test_id!r}: rows must be integers, got {rows.dtype}")
            rows = rows.astype(np.int64)
        object.__setattr__(self, "shear_force_N", float(self.shear_force_N))
        object.__setattr__(self, "positions", positions)
        object.__setattr__(self, "t_s", t_s)
        object.__setattr__(self, "rows", rows)
        self._freeze_arrays()

    def __setstate__(self, state: dict) -> None:
        """Unpickled (a pool worker's or Ray's copy of a test): numpy gives the arrays back writable; they stay
        read-only, as made (and as the workbench's compiled comparison is compiled for: a writable array made numba
        compile it a second time)."""
        for name, value in state.items():
            object.__setattr__(self, name, value)
        self._freeze_arrays()

    def _freeze_arrays(self) -> None:
        """Make the test's own arrays read-only (they are copies: nobody else holds them)."""
        for arr in (self.positions, self.t_s, self.rows):
            if arr is not None:
                arr.flags.writeable = False

    @property
    def n_samples(self) -> int:
        """Number of samples."""
        return int(self.positions.shape[0])

    @property
    def horizontal(self) -> np.ndarray:
        """(n, 3, 2) view of the horizontal coordinates (x1, x3) of CP1..CP3."""
        return self.positions[:, :, ::2]

    @property
    def has_time(self) -> bool:
        """Whether the test has a time column."""
        return self.t_s is not None

    @property
    def travel(self) -> np.ndarray:
        """(n,) forward travel of CP1: its x1 minus its first x1, metres."""
        x1 = self.positions[:, 0, 0]
        return x1 - x1[0]

    def __repr__(self) -> str:
        return (f"MeasuredTest(test_id={self.test_id!r}, shear_force_N={self.shear_force_N!r}, "
                f"n_samples={self.n_samples}, has_time={self.has_time})")


# --------------------------------------------------------------------------------------------------
# Reading
# --------------------------------------------------------------------------------------------------
_LINE = re.compile(r"[^\r\n]*(?:\r\n|\r|\n)|[^\r\n]+")


def _lines(text: str) -> Iterator[str]:
    """The lines of ``text`` with their ends, split at LF, CR and CRLF as ``io.StringIO(text, newline="")``
    splits them, one at a time (a StringIO would hold a 4-byte-per-character copy of the whole file)."""
    for match in _LINE.finditer(text):
        yield match.group()


def _is_blank(fields: list[str]) -> bool:
    return all(not f.strip() for f in fields)


def _describe(text: str) -> str:
    return repr(text if len(text) <= 40 else text[:37] + "...")


def _parse_number(path: str, row: int, column: str, text: str, *, allow_empty: bool) -> float:
    stripped = text.strip()
    if not stripped:
        if allow_empty:
            return math.nan
        raise MeasurementError(path, row, column, "value is empty; a number is required")
    try:
        if "_" in stripped:  # float() accepts '1_000'; a CSV number never should
            raise ValueError
        if not stripped.isascii():  # float() reads Arabic-Indic and full-width digits; a CSV number never has them
            raise ValueError
        value = float(stripped)
    except ValueError:
        hint = ""
        if ";" in stripped:
            hint = " (the file may use ';' as separator; this format is comma-separated)"
        raise MeasurementError(path, row, column,
                               f"value {_describe(text)} is not a number{hint}") from None
    if not math.isfinite(value):
        hint = "; leave the field empty where x2 is unknown" if column in _VERTICAL_COLUMNS else ""
        raise MeasurementError(path, row, column,
                               f"value {_describe(text)} is not a finite number{hint}")
    return value


def _decode(path: str, data: bytes) -> str:
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = data[: exc.start].count(b"\n") + 1
        hint = ""
        if data[:2] in (b"\xff\xfe", b"\xfe\xff"):
            hint = " (it looks like UTF-16; save it as UTF-8 CSV)"
        raise MeasurementError(
            path, line, None,
            f"file is not valid UTF-8 (byte 0x{data[exc.start]:02x} at byte offset {exc.start}){hint}",
        ) from None


def _check_header(path: str, header: list[str]) -> dict[str, int]:
    names = [h.strip() for h in header]
    seen: dict[str, int] = {}
    for i, name in enumerate(names):
        if not name:
            continue  # unnamed extra column (e.g. a trailing comma); ignored like any unknown column
        if name in seen:
            raise MeasurementError(
                path, 1, name,
                f"column name {name!r} appears twice in the header (fields {seen[name] + 1} and {i + 1})")
        seen[name] = i
    missing = [c for c in REQUIRED_COLUMNS if c not in seen]
    if missing:
        found = [n for n in names if n]
        hints = []
        lower = {n.lower(): n for n in found}
        for m in missing:
            if m.lower() in lower:
                hints.append(f"{lower[m.lower()]!r} differs from {m!r} only in case")
        if len(header) == 1 and any(sep in header[0] for sep in (";", "\t")):
            sep = "';'" if ";" in header[0] else "tab"
            hints.append(f"the header looks {sep}-separated; this format is comma-separated")
        hint = ("; " + "; ".join(hints)) if hints else ""
        raise MeasurementError(
            path, 1, missing[0],
            f"missing required column(s) {', '.join(missing)}; found {', '.join(found) or 'none'}{hint}",
        )
    return {name: i for name, i in seen.items() if name in _KNOWN_COLUMNS}


class _TestBuilder:
    __slots__ = ("test_id", "shear", "shear_row", "pos", "t", "rows")

    def __init__(self, test_id: str, shear: float, row: int) -> None:
        self.test_id = test_id
        self.shear = shear
        self.shear_row = row
        self.pos = array("d")  # 9 values per sample (CP1 x1 x2 x3, CP2 ..., CP3 ...): compact, no float objects
        self.t = array("d")
        self.rows = array("q")

    def add(self, path: str, row: int, force: float, t: float | None, sample: list[float]) -> None:
        """Append one sample; refuse a shear force that differs from the test's or a time that does not increase."""
        if force != self.shear:
            raise MeasurementError(
                path, row, "shear_force_N",
                f"shear force {force!r} N of test {self.test_id!r} differs from {self.shear!r} N on row "
                f"{self.shear_row}; the shear force must be the same on all rows of a test")
        if t is not None:
            if self.t and not t > self.t[-1]:
                raise MeasurementError(
                    path, row, "t_s",
                    f"time {t!r} s of test {self.test_id!r} does not increase (previous sample of the test, "
                    f"row {self.rows[-1]}, has t_s = {self.t[-1]!r} s); time must strictly increase within a test")
            self.t.append(t)
        self.pos.extend(sample)
        self.rows.append(row)

    def check(self, path: str) -> None:
        """Refuse a test with too few samples or an implausible time base (after the whole file is read)."""
        if len(self.rows) < MIN_SAMPLES:
            raise MeasurementError(
                path, self.rows[0], "test_id",
                f"test {self.test_id!r} has {len(self.rows)} sample(s) (rows {', '.join(map(str, self.rows))}); "
                f"at least {MIN_SAMPLES} are required")

    def check_time(self, path: str) -> None:
        if self.t:
            problem = _time_problem(self.test_id, self.t[0], self.t[-1])
            if problem:
                raise MeasurementError(path, self.rows[0] if "first" in problem else self.rows[-1], "t_s", problem)

    def build(self, has_time: bool) -> MeasuredTest:
        return MeasuredTest(test_id=self.test_id, shear_force_N=self.shear,
                            positions=np.frombuffer(self.pos, dtype=np.float64).reshape(-1, 3, 3),
                            t_s=np.asarray(self.t, dtype=np.float64) if has_time else None,
                            rows=np.asarray(self.rows, dtype=np.int64))


@dataclass(frozen=True)
class _Columns:
    """Where each known column stands in a file's rows (x2 entries may be None: the vertical is optional)."""

    n_fields: int
    test_id: int
    force: int
    t: int | None
    positions: list[list[int | None]]


def _checked_rest(rest_positions: np.ndarray | None, tolerance_m: float) -> np.ndarray | None:
    if rest_positions is None:
        return None
    rest = np.asarray(rest_positions, dtype=np.float64)
    if rest.shape != (3, 3) or not np.all(np.isfinite(rest)):
        raise ValueError(f"rest_positions must be a finite (3, 3) array, got shape {rest.shape}")
    if not (math.isfinite(tolerance_m) and tolerance_m > 0):
        raise ValueError(f"tolerance_m must be a positive finite number, got {tolerance_m!r}")
    return rest


def _open_csv(path: str, data: bytes) -> tuple[Any, _Columns]:
    """The CSV reader positioned after the header, and where the columns stand; refuses an empty file or header."""
    text = _decode(path, data)
    if not text.strip():
        raise MeasurementError(path, None, None, "file is empty (expected a header row and data rows)")
    reader = csv.reader(_lines(text), strict=True)
    try:
        header = next(reader)
    except csv.Error as exc:
        raise MeasurementError(path, 1, None, f"header row is not valid CSV: {exc}") from None
    if _is_blank(header):
        raise MeasurementError(path, 1, None, "line 1 is blank; the header row must be the first line of the file")
    col = _check_header(path, header)
    return reader, _Columns(len(header), col["test_id"], col["shear_force_N"], col.get("t_s"),
                            [[col.get(c) for c in cp] for cp in POSITION_COLUMNS])


def _records(path: str, reader: Any, n_fields: int) -> Iterator[tuple[int, list[str]]]:
    """(first line, fields) of every data record; refuses invalid CSV, a wrong field count, or blank lines between
    data rows (blank lines are allowed only at the end)."""
    pending_blank: int | None = None  # line of the first blank line not yet followed by data
    line_end = reader.line_num
    while True:
        row = line_end + 1  # first line of the next record (records may span lines inside quotes)
        try:
            fields = next(reader)
        except StopIteration:
            return
        except csv.Error as exc:
            raise MeasurementError(path, row, None, f"not valid CSV: {exc}") from None
        line_end = reader.line_num
        if _is_blank(fields):
            if pending_blank is None:
                pending_blank = row
            continue
        if pending_blank is not None:
            raise MeasurementError(
                path, pending_blank, None,
                f"blank line between data rows (data continues at row {row}); "
                "blank lines are allowed only at the end of the file")
        if len(fields) != n_fields:
            raise MeasurementError(path, row, None, f"row has {len(fields)} field(s) but the header has {n_fields}")
        yield row, fields


def _test_id(path: str, row: int, test_id: str) -> str:
    if not test_id.strip():
        raise MeasurementError(path, row, "test_id", "test_id is empty")
    if test_id.strip()[0] in FORMULA_STARTS or test_id[0] in FORMULA_STARTS:
        raise MeasurementError(path, row, "test_id", f"test_id {_describe(test_id)} starts with "
                               f"{test_id[0]!r}, which spreadsheets run as a formula; rename the test")
    return test_id


def _sample(path: str, row: int, fields: list[str], columns: _Columns) -> list[float]:
    """The row's nine positions (CP1 x1 x2 x3, CP2 ..., CP3 ...), NaN for an absent vertical; millimetres refused."""
    sample = []
    for k in range(3):
        for a in range(3):
            idx = columns.positions[k][a]
            if idx is None:
                sample.append(math.nan)
                continue
            name = POSITION_COLUMNS[k][a]
            v = _parse_number(path, row, name, fields[idx], allow_empty=(a == 1))
            if abs(v) > MAX_ABS_POSITION_M:
                raise MeasurementError(
                    path, row, name,
                    f"value {fields[idx].strip()} cannot be a position in metres "
                    f"(|value| > {MAX_ABS_POSITION_M:g} m); it looks like millimetres - "
                    "positions must be given in metres")
            sample.append(v)
    return sample


def _builder(path: str, row: int, test_id: str, force: float, tests: dict[str, _TestBuilder],
             stripped_ids: dict[str, tuple[str, int]]) -> _TestBuilder:
    """The test's builder, new on its first row; refuses two spellings of one id that differ by white space."""
    b = tests.get(test_id)
    if b is None:
        twin = stripped_ids.setdefault(test_id.strip(), (test_id, row))
        if twin[0] != test_id:
            raise MeasurementError(
                path, row, "test_id",
                f"test_id {test_id!r} differs from {twin[0]!r} (row {twin[1]}) only by surrounding "
                "whitespace; use one spelling (two spellings would be two tests)")
        b = tests[test_id] = _TestBuilder(test_id, force, row)
    return b


def read_measurements(path: str | os.PathLike[str], rest_positions: np.ndarray | None = None,
                      tolerance_m: float = 0.005) -> list[MeasuredTest]:
    """Read a measured-trace CSV file; return its tests in order of first appearance.

    Rows of one test need not be contiguous; within a test, samples keep file order.

    Parameters
    ----------
    path:
        The CSV file.
    rest_positions:
        Optional (3, 3) rest positions of CP1..CP3 (foundation frame, metres) of the specimen. When
        given, a test whose first sample puts any contact point farther than ``tolerance_m``
        horizontally (in x1, x3) from that point's rest position is refused.
    tolerance_m:
        Horizontal tolerance of the first-sample check, metres (default 5 mm).

    Raises
    ------
    MeasurementError
        On any violation of the format (see the module docstring); the whole file is refused.
    OSError
        If the file cannot be opened.
    """
    spath = os.fspath(path)
    rest = _checked_rest(rest_positions, tolerance_m)
    reader, columns = _open_csv(spath, Path(path).read_bytes())
    tests: dict[str, _TestBuilder] = {}
    stripped_ids: dict[str, tuple[str, int]] = {}
    for row, fields in _records(spath, reader, columns.n_fields):
        test_id = _test_id(spath, row, fields[columns.test_id])
        force = _parse_number(spath, row, "shear_force_N", fields[columns.force], allow_empty=False)
        if force < 0:  # as the model refuses a negative load (``simulate --force``)
            raise MeasurementError(spath, row, "shear_force_N", f"value {force!r} is negative; a shear force is "
                                   "non-negative (N)")
        t = (_parse_number(spath, row, "t_s", fields[columns.t], allow_empty=False)
             if columns.t is not None else None)
        sample = _sample(spath, row, fields, columns)
        _builder(spath, row, test_id, force, tests, stripped_ids).add(spath, row, force, t, sample)
    if not tests:
        raise MeasurementError(spath, None, None, "file has a header row but no data rows")
    for b in tests.values():
        b.check(spath)
    for b in tests.values():
        b.check_time(spath)
    result = [b.build(columns.t is not None) for b in tests.values()]
    if rest is not None:
        for mt in result:
            _check_rest(spath, mt, rest, tolerance_m)
    return result


def _time_problem(test_id: str, first: float, last: float) -> str | None:
    """Why a test's times cannot be seconds from load onset, or None."""
    if abs(first) > MAX_START_TIME_S:
        return (f"first time {first!r} s of test {test_id!r} is not near 0; t_s must be seconds from the moment "
                f"the shear force is applied (|first t_s| <= {MAX_START_TIME_S:g} s): subtract the clock's offset")
    if last - first > MAX_DURATION_S:
        return (f"test {test_id!r} lasts {last - first:.6g} s (t_s from {first!r} to {last!r}); more than "
                f"{MAX_DURATION_S:g} s looks like milliseconds - t_s must be in seconds")
    return None


def _check_rest(path: str, mt: MeasuredTest, rest: np.ndarray, tol: float) -> None:
    first = mt.horizontal[0]                 # (3, 2)
    d = first - rest[:, ::2]                 # (3, 2) offsets in (x1, x3)
    dist = np.hypot(d[:, 0], d[:, 1])
    bad = [k for k in range(3) if not dist[k] <= tol]
    if not bad:
        return
    k = bad[0]
    column = POSITION_COLUMNS[k][0] if abs(d[k, 0]) >= abs(d[k, 1]) else POSITION_COLUMNS[k][2]
    others = "".join(f"; CP{j + 1} is also off by {dist[j] * 1e3:.1f} mm" for j in bad[1:])
    raise MeasurementError(
        path, int(mt.rows[0]), column,
        f"first sample of test {mt.test_id!r} puts CP{k + 1} at (x1, x3) = "
        f"({first[k, 0]:.4f}, {first[k, 1]:.4f}) m, {dist[k] * 1e3:.1f} mm from its rest position "
        f"({rest[k, 0]:.4f}, {rest[k, 2]:.4f}) m (offset dx1 = {d[k, 0] * 1e3:+.1f} mm, "
        f"dx3 = {d[k, 1] * 1e3:+.1f} mm; tolerance {tol * 1e3:g} mm){others}; "
        "wrong frame (origin where the three foundation planes meet, x1 forward, x3 lateral) "
        "or wrong specimen?")


# --------------------------------------------------------------------------------------------------
# Writing
# --------------------------------------------------------------------------------------------------
def _fmt(value: float) -> str:
    """Shortest text that reads back to exactly the same float64."""
    return repr(float(value))


def _validate_for_write(path: str, tests: list[MeasuredTest]) -> bool:
    """Refuse what the reader would refuse (so that every written file reads back). Returns has_time."""
    if not tests:
        raise MeasurementError(path, None, None, "no tests to write")
    timed = [t.has_time for t in tests]
    if any(timed) and not all(timed):
        without = [t.test_id for t in tests if not t.has_time]
        raise MeasurementError(
            path, None, "t_s",
            f"some tests have time and some do not (without: {', '.join(map(repr, without))}); "
            "one file has a t_s value on every row or none, and time is not dropped silently")
    seen: set[str] = set()
    for mt in tests:
        tid = mt.test_id
        if not tid.strip():
            raise MeasurementError(path, None, "test_id", "a test has an empty test_id")
        if tid.strip()[0] in FORMULA_STARTS or tid[0] in FORMULA_STARTS:
            raise MeasurementError(path, None, "test_id", f"test_id {tid!r} starts with a spreadsheet formula "
                                   "character (=, +, @, tab, CR); the reader would refuse it")
        if any(tid != o and tid.strip() == o.strip() for o in seen):
            raise MeasurementError(path, None, "test_id", f"test_id {tid!r} differs from another only by "
                                   "surrounding whitespace; the reader would refuse it")
        if tid in seen:
            raise MeasurementError(path, None, "test_id",
                                   f"test_id {tid!r} is used by more than one test")
        seen.add(tid)
        if mt.n_samples < MIN_SAMPLES:
            raise MeasurementError(path, None, "test_id",
                                   f"test {tid!r} has {mt.n_samples} sample(s); at least {MIN_SAMPLES} are required")
        if not math.isfinite(mt.shear_force_N):
            raise MeasurementError(path, None, "shear_force_N",
                                   f"test {tid!r}: shear force {mt.shear_force_N!r} is not finite")
        for k in range(3):
            for a in range(3):
                name = POSITION_COLUMNS[k][a]
                v = mt.positions[:, k, a]
                bad = ~np.isfinite(v) if a != 1 else np.isinf(v)
                if bad.any():
                    i = int(np.flatnonzero(bad)[0])
                    raise MeasurementError(path, None, name,
                                           f"test {tid!r}, sample {i}: value {v[i]!r} is not finite")
                big = np.abs(v) > MAX_ABS_POSITION_M
                if big.any():
                    i = int(np.flatnonzero(big)[0])
                    raise MeasurementError(
                        path, None, name,
                        f"test {tid!r}, sample {i}: value {v[i]!r} exceeds {MAX_ABS_POSITION_M:g} m "
                        "(millimetres instead of metres?)")
        if mt.t_s is not None:
            t = mt.t_s
            if not np.all(np.isfinite(t)):
                i = int(np.flatnonzero(~np.isfinite(t))[0])
                raise MeasurementError(path, None, "t_s",
                                       f"test {tid!r}, sample {i}: time {t[i]!r} is not finite")
            dec = ~(np.diff(t) > 0)
            if dec.any():
                i = int(np.flatnonzero(dec)[0]) + 1
                raise MeasurementError(path, None, "t_s",
                                       f"test {tid!r}, sample {i}: time {t[i]!r} does not increase")
            problem = _time_problem(tid, float(t[0]), float(t[-1]))
            if problem:
                raise MeasurementError(path, None, "t_s", problem)
    return all(timed)


def write_measurements(path: str | os.PathLike[str], tests: Iterable[MeasuredTest]) -> None:
    """Write tests to a measured-trace CSV file, atomically.

    All columns are written: ``t_s`` when every test has time (a mix of timed and untimed tests is
    refused rather than dropping time), the ``x2`` columns always (empty where NaN). Floats are
    written with ``repr`` so that reading the file back gives bitwise-identical values. Tests are
    written one after another in the given order (their ``rows`` are not used).

    The file is written to a temporary file in the same directory and moved into place with
    ``os.replace``; if anything fails, the temporary file is removed and an existing file at
    ``path`` is left unchanged.

    Raises
    ------
    MeasurementError
        If the tests could not be read back (non-finite values, |position| > 2 m, time not
        increasing, fewer than 3 samples, empty or duplicate test_id, mixed time).
    """
    spath = os.fspath(path)
    tests = list(tests)
    has_time = _validate_for_write(spath, tests)

    header = ["test_id", "shear_force_N"] + (["t_s"] if has_time else [])
    header += [c for cp in POSITION_COLUMNS for c in cp]

    directory, name = os.path.split(os.path.abspath(spath))
    if not os.path.isdir(directory):
        raise MeasurementError(spath, None, None, f"folder {directory} does not exist")
    remove_stale_temporaries(spath)

    def write(tmp: Path) -> None:
        # os.open with mode 0o666 lets the umask decide permissions, as for an ordinary new file.
        fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
        with os.fdopen(fd, "w", encoding="utf-8", newline="") as fh:
            writer = csv.writer(fh, lineterminator="\n")
            writer.writerow(header)
            for mt in tests:
                _write_rows(writer, mt, has_time)
            fh.flush()
            os.fsync(fh.fileno())
    write_atomic(spath, write)


def _write_rows(writer: Any, mt: MeasuredTest, has_time: bool) -> None:
    force = _fmt(mt.shear_force_N)
    for i in range(mt.n_samples):
        rec = [mt.test_id, force]
        if has_time:
            rec.append(_fmt(mt.t_s[i]))  # type: ignore[index]
        for k in range(3):
            for a in range(3):
                v = mt.positions[i, k, a]
                rec.append("" if math.isnan(v) else _fmt(v))
        writer.writerow(rec)

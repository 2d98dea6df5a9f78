"""Tests of the measured-trace CSV reader/writer (triplanar.measurement)."""

from __future__ import annotations

import os
import pickle

import numpy as np
import pytest

import triplanar.measurement as m
from triplanar.measurement import (
    MeasuredTest,
    MeasurementError,
    read_measurements,
    write_measurements,
)

REST = np.array([[-0.14, 0.0, 0.24], [0.0, 0.0, 0.24], [0.0, 0.0, 0.0]])

FULL_HEADER = ("test_id,shear_force_N,t_s,cp1_x1_m,cp1_x2_m,cp1_x3_m,cp2_x1_m,cp2_x2_m,cp2_x3_m,"
               "cp3_x1_m,cp3_x2_m,cp3_x3_m")
MIN_HEADER = "test_id,shear_force_N,cp1_x1_m,cp1_x3_m,cp2_x1_m,cp2_x3_m,cp3_x1_m,cp3_x3_m"


def _row(tid="A", f=30.0, t=None, dx=0.0, x2="", full=True):
    """One data row near rest, CP1..CP3 shifted by dx along x1."""
    c1 = (-0.14 + dx, 0.24)
    c2 = (0.0 + dx, 0.24)
    c3 = (0.0 + dx, 0.0)
    if full:
        vals = [tid, f, t, c1[0], x2, c1[1], c2[0], x2, c2[1], c3[0], x2, c3[1]]
    else:
        vals = [tid, f, c1[0], c1[1], c2[0], c2[1], c3[0], c3[1]]
    return ",".join("" if v is None else str(v) for v in vals)


def _good_lines(full=True):
    hdr = FULL_HEADER if full else MIN_HEADER
    rows = [_row("A", 30.0, i * 0.01, i * 0.001, full=full) for i in range(3)]
    return [hdr] + rows


def _write(tmp_path, lines, name="data.csv", newline="\n", raw=None):
    p = tmp_path / name
    if raw is not None:
        p.write_bytes(raw)
    else:
        p.write_text(newline.join(lines) + newline, encoding="utf-8", newline="")
    return p


def _make_test(tid, n, f=30.0, time=True, x2="partial", seed=0):
    rng = np.random.default_rng(seed)
    pos = np.empty((n, 3, 3))
    pos[:] = REST
    pos += rng.normal(scale=1e-3, size=pos.shape)
    pos[:, :, 0] += np.linspace(0, 0.08, n)[:, None] * (1 + 1e-9 * np.pi)
    if x2 == "none":
        pos[:, :, 1] = np.nan
    elif x2 == "partial":
        pos[::2, 1, 1] = np.nan
        pos[1, :, 1] = np.nan
    t = np.cumsum(rng.uniform(1e-4, 1e-2, n)) / 3.0 if time else None
    return MeasuredTest(tid, f, pos, t, np.zeros(n, dtype=int))


def _same(a: MeasuredTest, b: MeasuredTest):
    assert a.test_id == b.test_id
    assert np.float64(a.shear_force_N).tobytes() == np.float64(b.shear_force_N).tobytes()
    assert a.positions.tobytes() == b.positions.tobytes()  # bitwise, NaN pattern included
    assert (a.t_s is None) == (b.t_s is None)
    if a.t_s is not None:
        assert a.t_s.tobytes() == b.t_s.tobytes()


def _raises(path, row, column, *fragments, **kw):
    with pytest.raises(MeasurementError) as ei:
        read_measurements(path, **kw)
    err = ei.value
    msg = str(err)
    assert err.path == os.fspath(path)
    assert err.row == row, msg
    assert err.column == column, msg
    assert msg.startswith(os.fspath(path)), msg
    if row is not None:
        assert f"row {row}" in msg
    if column is not None:
        assert f"column {column}" in msg
    for frag in fragments:
        assert frag in msg, msg
    return err


# ---------------------------------------------------------------------------------------------
# Round trips
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("time", [True, False])
@pytest.mark.parametrize("x2", ["partial", "none", "full"])
def test_round_trip_bitwise(tmp_path, time, x2):
    tests = [_make_test("T1", 50, 27.8, time, x2, seed=1),
             _make_test("run 2, repeat \"b\"", 7, 55.6, time, x2, seed=2),
             _make_test(" spaced ", 3, 0.1 + 0.2, time, x2, seed=3)]
    p = tmp_path / "out.csv"
    write_measurements(p, tests)
    back = read_measurements(p, rest_positions=REST)
    assert len(back) == len(tests)
    for a, b in zip(tests, back):
        _same(a, b)
    # header: t_s only with time; x2 columns always present
    header = p.read_text(encoding="utf-8").splitlines()[0].split(",")
    assert ("t_s" in header) == time
    assert {"cp1_x2_m", "cp2_x2_m", "cp3_x2_m"} <= set(header)
    # rows are the file lines: header is line 1, contiguous tests
    assert back[0].rows.tolist() == list(range(2, 52))
    assert back[1].rows[0] == 52
    # write -> read -> write gives an identical file
    p2 = tmp_path / "out2.csv"
    write_measurements(p2, back)
    assert p2.read_bytes() == p.read_bytes()


def test_round_trip_extreme_floats(tmp_path):
    pos = np.zeros((3, 3, 3))
    pos[:] = REST
    pos[0, 0, 1] = -0.0
    pos[1, 0, 1] = 5e-324
    pos[2, 0, 1] = 2.0
    pos[2, 1, 1] = -2.0
    pos[1, 2, 0] = 1e-300
    t = np.array([0.0, np.nextafter(0.0, 1.0), np.nextafter(60.0, 0.0)])  # up to MAX_DURATION_S
    mt = MeasuredTest("x", 1.0000000000000002, pos, t, np.zeros(3, int))
    p = tmp_path / "e.csv"
    write_measurements(p, [mt])
    (back,) = read_measurements(p)
    _same(mt, back)
    assert np.signbit(back.positions[0, 0, 1])


def test_properties_and_read_only(tmp_path):
    p = _write(tmp_path, _good_lines())
    (t,) = read_measurements(p)
    assert t.n_samples == 3 and t.has_time
    assert t.horizontal.shape == (3, 3, 2)
    assert np.shares_memory(t.horizontal, t.positions)
    np.testing.assert_array_equal(t.horizontal[..., 1], t.positions[..., 2])
    np.testing.assert_allclose(t.travel, [0.0, 0.001, 0.002], atol=1e-15)
    assert np.isnan(t.positions[:, :, 1]).all()
    assert t.rows.tolist() == [2, 3, 4]
    assert t.shear_force_N == 30.0
    with pytest.raises(ValueError):
        t.positions[0, 0, 0] = 1.0
    with pytest.raises(ValueError, match="shape"):
        MeasuredTest("a", 1.0, np.zeros((3, 3)), None, np.zeros(3, int))


def test_minimal_columns_no_time(tmp_path):
    p = _write(tmp_path, _good_lines(full=False))
    (t,) = read_measurements(p, rest_positions=REST)
    assert t.t_s is None and not t.has_time
    assert np.isnan(t.positions[:, :, 1]).all()
    assert t.positions.dtype == np.float64 and t.positions.shape == (3, 3, 3)


# ---------------------------------------------------------------------------------------------
# Accepted variations
# ---------------------------------------------------------------------------------------------
def test_non_contiguous_rows_grouped_in_order(tmp_path):
    lines = [FULL_HEADER,
             _row("B", 40, 0.0, 0.000),   # line 2
             _row("A", 30, 0.0, 0.001),   # 3
             _row("B", 40, 0.1, 0.002),   # 4
             _row("C", 50, 0.0, 0.003),   # 5
             _row("A", 30, 0.2, 0.004),   # 6
             _row("B", 40, 0.3, 0.005),   # 7
             _row("A", 30, 0.3, 0.006),   # 8
             _row("C", 50, 0.1, 0.007),   # 9
             _row("C", 50, 0.2, 0.008)]   # 10
    tests = read_measurements(_write(tmp_path, lines), rest_positions=REST)
    assert [t.test_id for t in tests] == ["B", "A", "C"]
    assert tests[0].rows.tolist() == [2, 4, 7]
    assert tests[1].rows.tolist() == [3, 6, 8]
    assert tests[2].rows.tolist() == [5, 9, 10]
    np.testing.assert_allclose(tests[1].positions[:, 0, 0], -0.14 + np.array([0.001, 0.004, 0.006]))
    np.testing.assert_allclose(tests[0].t_s, [0.0, 0.1, 0.3])
    assert [t.shear_force_N for t in tests] == [40.0, 30.0, 50.0]


def test_bom_crlf_extra_columns_trailing_blanks_partial_x2(tmp_path):
    hdr = FULL_HEADER + ",operator,notes"
    rows = [_row("A", 30, 0.0, 0.0, x2="0.001") + ",jd,anything at all",
            _row("A", 30, 0.1, 0.001) + ",jd,not a number",
            _row("A", 30, 0.2, 0.002, x2="0.003") + ",,"]
    raw = ("\ufeff" + "\r\n".join([hdr] + rows) + "\r\n\r\n\r\n,,,,,,,,,,,,,\r\n").encode("utf-8")
    p = _write(tmp_path, None, raw=raw)
    (t,) = read_measurements(p, rest_positions=REST)
    assert t.n_samples == 3
    assert t.rows.tolist() == [2, 3, 4]
    assert np.isnan(t.positions[1, :, 1]).all()
    np.testing.assert_array_equal(t.positions[2, :, 1], [0.003, 0.003, 0.003])
    # a row where only some x2 values are empty
    lines = _good_lines()
    lines[2] = lines[2].replace("-0.139,,0.24", "-0.139,0.002,0.24")
    (t,) = read_measurements(_write(tmp_path, lines, "b.csv"))
    assert t.positions[1, 0, 1] == 0.002 and np.isnan(t.positions[1, 1:, 1]).all()


def test_quoted_multiline_test_id_keeps_line_numbers(tmp_path):
    lines = [MIN_HEADER] + [_row('"multi\nline"', 30, dx=0.001 * i, full=False) for i in range(3)]
    (t,) = read_measurements(_write(tmp_path, lines))
    assert t.test_id == "multi\nline"
    assert t.rows.tolist() == [2, 4, 6]
    lines.append(_row("B", "x", full=False))
    _raises(_write(tmp_path, lines, "b.csv"), 8, "shear_force_N", "'x' is not a number")


# ---------------------------------------------------------------------------------------------
# Refusals: each names the file, the row and the column
# ---------------------------------------------------------------------------------------------
def test_missing_required_columns_listed(tmp_path):
    hdr = "test_id,shear_force_N,t_s,cp1_x1_m,cp1_x3_m,cp2_x1_m,cp3_x1_m,cp3_x3_m"
    lines = [hdr, "A,30,0,-0.14,0.24,0,0,0"]
    err = _raises(_write(tmp_path, lines), 1, "cp2_x3_m", "missing", "cp2_x3_m", "found", "t_s")
    assert "cp3_x3_m" in str(err).split("found")[1]
    # several missing, and a case hint
    lines = ["test_id,Shear_Force_N,cp1_x1_m", "A,30,0"]
    err = _raises(_write(tmp_path, lines, "b.csv"), 1, "shear_force_N", "cp1_x3_m", "cp3_x3_m",
                  "only in case")
    # semicolon-separated file
    lines = [MIN_HEADER.replace(",", ";"), "A;30;-0.14;0.24;0;0.24;0;0"]
    _raises(_write(tmp_path, lines, "c.csv"), 1, "test_id", "';'-separated")


def test_duplicate_column(tmp_path):
    lines = [MIN_HEADER + ",cp2_x1_m", _row(full=False) + ",0"]
    _raises(_write(tmp_path, lines), 1, "cp2_x1_m", "appears twice")


@pytest.mark.parametrize("text,fragment", [
    ("abc", "'abc' is not a number"),
    ("1_0", "is not a number"),
    ("nan", "not a finite number"),
    ("-inf", "not a finite number"),
    ("", "empty"),
])
def test_bad_number_in_position(tmp_path, text, fragment):
    lines = _good_lines()
    fields = lines[3].split(",")
    fields[FULL_HEADER.split(",").index("cp2_x3_m")] = text
    lines[3] = ",".join(fields)
    _raises(_write(tmp_path, lines), 4, "cp2_x3_m", fragment)


@pytest.mark.parametrize("column", ["shear_force_N", "t_s", "cp1_x2_m"])
def test_non_finite_other_columns(tmp_path, column):
    lines = _good_lines()
    fields = lines[2].split(",")
    fields[FULL_HEADER.split(",").index(column)] = "inf"
    lines[2] = ",".join(fields)
    _raises(_write(tmp_path, lines), 3, column, "'inf' is not a finite number")


def test_empty_time_refused(tmp_path):
    lines = _good_lines()
    lines[3] = lines[3].replace("A,30.0,0.02,", "A,30.0,,")
    _raises(_write(tmp_path, lines), 4, "t_s", "empty")


def test_shear_force_changes(tmp_path):
    lines = _good_lines() + [_row("A", 30.5, 0.05, 0.003)]
    _raises(_write(tmp_path, lines), 5, "shear_force_N", "'A'", "30.5", "30.0", "row 2")


@pytest.mark.parametrize("t_bad", [0.01, 0.005])
def test_time_not_strictly_increasing(tmp_path, t_bad):
    lines = _good_lines() + [_row("A", 30.0, t_bad, 0.003)]
    _raises(_write(tmp_path, lines), 5, "t_s", "does not increase", "row 4")


def test_time_checked_per_test_not_across_tests(tmp_path):
    lines = _good_lines() + [_row("B", 30.0, 0.0, 0.0), _row("B", 30.0, 0.1, 0.0),
                             _row("B", 30.0, 0.2, 0.0)]
    assert len(read_measurements(_write(tmp_path, lines))) == 2


def test_fewer_than_three_samples(tmp_path):
    lines = _good_lines() + [_row("B", 30.0, 0.0), _row("B", 30.0, 0.1)]
    _raises(_write(tmp_path, lines), 5, "test_id", "'B'", "2 sample", "rows 5, 6", "at least 3")


def test_millimetres_refused(tmp_path):
    lines = [MIN_HEADER] + [f"A,30,{-140 + i},240,{i},240,{i},0" for i in range(3)]
    _raises(_write(tmp_path, lines), 2, "cp1_x1_m", "millimetres", "-140")
    lines = _good_lines()
    lines[3] = lines[3].replace(",,0.24,", ",2.5,0.24,", 1)
    _raises(_write(tmp_path, lines, "b.csv"), 4, "cp1_x2_m", "millimetres")


def test_first_sample_far_from_rest(tmp_path):
    lines = [FULL_HEADER] + [_row("A", 30.0, 0.1 * i, 0.002 * i) for i in range(3)]
    lines += [_row("B", 40.0, 0.1 * i, 0.002 * i) for i in range(3)]
    p = _write(tmp_path, lines)
    assert len(read_measurements(p, rest_positions=REST)) == 2
    # shift test B's CP2 by 6 mm in x3 on its first row (line 5)
    f = lines[4].split(",")
    f[8] = str(0.24 + 0.006)
    lines[4] = ",".join(f)
    p = _write(tmp_path, lines, "b.csv")
    err = _raises(p, 5, "cp2_x3_m", "'B'", "CP2", "6.0 mm", "wrong frame", "wrong specimen",
                  rest_positions=REST)
    assert "+6.0 mm" in str(err)
    assert len(read_measurements(p)) == 2  # no rest given: no check
    assert len(read_measurements(p, rest_positions=REST, tolerance_m=0.007)) == 2
    # a file in a frame with another origin: every point off
    lines = [FULL_HEADER] + [_row("A", 30.0, 0.1 * i, 0.14 + 0.002 * i) for i in range(3)]
    _raises(_write(tmp_path, lines, "c.csv"), 2, "cp1_x1_m", "140.0 mm", "CP2 is also off",
            rest_positions=REST)


def test_empty_file_and_header_only(tmp_path):
    _raises(_write(tmp_path, None, raw=b""), None, None, "empty")
    _raises(_write(tmp_path, None, "b.csv", raw=b"\xef\xbb\xbf\n\n  \n"), None, None, "empty")
    _raises(_write(tmp_path, [MIN_HEADER, "", ""], "c.csv"), None, None, "no data rows")
    _raises(_write(tmp_path, ["", MIN_HEADER, _row(full=False)], "d.csv"), 1, None, "blank")


def test_blank_line_in_middle(tmp_path):
    lines = _good_lines()
    lines.insert(3, "")
    err = _raises(_write(tmp_path, lines), 4, None, "blank line", "row 5")
    assert "end of the file" in str(err)


def test_wrong_number_of_fields(tmp_path):
    lines = _good_lines()
    lines[2] += ",extra"
    _raises(_write(tmp_path, lines), 3, None, "13 field(s)", "header has 12")
    lines = _good_lines()
    lines[3] = lines[3].rsplit(",", 1)[0]
    _raises(_write(tmp_path, lines, "b.csv"), 4, None, "11 field(s)")


@pytest.mark.parametrize("tid", ["", "   "])
def test_empty_test_id(tmp_path, tid):
    lines = _good_lines()
    lines[2] = tid + lines[2][1:]
    _raises(_write(tmp_path, lines), 3, "test_id", "test_id is empty")


def test_invalid_utf8_and_nul(tmp_path):
    raw = ("\n".join(_good_lines()) + "\n").encode()
    raw = raw.replace(b"A,30.0,0.01", b"\xe9,30.0,0.01")
    _raises(_write(tmp_path, None, raw=raw), 3, None, "UTF-8")
    raw16 = ("\n".join(_good_lines()) + "\n").encode("utf-16")
    _raises(_write(tmp_path, None, "b.csv", raw=raw16), 1, None, "UTF-16")
    raw = ("\n".join(_good_lines()) + "\n").encode().replace(b"A,30.0,0.02", b"A,30.0,0.0\x002")
    p = _write(tmp_path, None, "c.csv", raw=raw)
    with pytest.raises(MeasurementError) as ei:
        read_measurements(p)
    assert ei.value.row == 4


def test_error_message_format_and_pickle():
    e = MeasurementError("data.csv", 17, "cp2_x3_m", "value 'abc' is not a number")
    assert str(e) == "data.csv, row 17, column cp2_x3_m: value 'abc' is not a number"
    assert isinstance(e, ValueError)
    e2 = pickle.loads(pickle.dumps(e))
    assert (e2.path, e2.row, e2.column, str(e2)) == (e.path, e.row, e.column, str(e))
    assert str(MeasurementError("d.csv", None, None, "x")) == "d.csv: x"


def test_refused_file_returns_nothing(tmp_path):
    # an error in the last row refuses the whole file (no partial list)
    lines = _good_lines() + [_row("B", 30.0, 0.0), _row("B", 30.0, 0.1), _row("B", "?", 0.2)]
    with pytest.raises(MeasurementError):
        read_measurements(_write(tmp_path, lines))


# ---------------------------------------------------------------------------------------------
# Writing
# ---------------------------------------------------------------------------------------------
def _listing(d):
    return sorted(os.listdir(d))


@pytest.mark.parametrize("mutate,column", [
    (lambda p, t: p.__setitem__((1, 2, 0), np.inf), "cp3_x1_m"),
    (lambda p, t: p.__setitem__((1, 0, 1), -np.inf), "cp1_x2_m"),
    (lambda p, t: p.__setitem__((0, 0, 2), np.nan), "cp1_x3_m"),
    (lambda p, t: p.__setitem__((2, 1, 2), 240.0), "cp2_x3_m"),
    (lambda p, t: t.__setitem__(2, t[1]), "t_s"),
])
def test_write_refuses_unreadable_and_leaves_no_file(tmp_path, mutate, column):
    good = _make_test("A", 5)
    pos, t = good.positions.copy(), good.t_s.copy()
    mutate(pos, t)
    bad = MeasuredTest("B", 30.0, pos, t, good.rows)
    with pytest.raises(MeasurementError) as ei:
        write_measurements(tmp_path / "o.csv", [good, bad])
    assert ei.value.column == column and "'B'" in str(ei.value)
    assert _listing(tmp_path) == []


def test_write_refuses_bad_sets(tmp_path):
    a, b = _make_test("A", 4), _make_test("A", 4, time=False)
    for tests, column in [([a, _make_test("A", 3)], "test_id"),   # duplicate id
                          ([a, _make_test("B", 3, time=False)], "t_s"),  # mixed time
                          ([_make_test("C", 2)], "test_id"),      # too short
                          ([_make_test(" ", 3)], "test_id")]:     # empty id
        with pytest.raises(MeasurementError) as ei:
            write_measurements(tmp_path / "o.csv", tests)
        assert ei.value.column == column
    with pytest.raises(MeasurementError):
        write_measurements(tmp_path / "o.csv", [])
    assert _listing(tmp_path) == []
    write_measurements(tmp_path / "o.csv", iter([b]))  # any iterable
    assert _listing(tmp_path) == ["o.csv"]


def test_atomic_write_failure_midway(tmp_path, monkeypatch):
    target = tmp_path / "keep.csv"
    original = [_make_test("old", 5)]
    write_measurements(target, original)
    before = target.read_bytes()

    calls = {"n": 0}
    real_fmt = m._fmt

    def failing_fmt(v):
        calls["n"] += 1
        if calls["n"] > 200:
            raise OSError("disk full (simulated)")
        return real_fmt(v)

    monkeypatch.setattr(m, "_fmt", failing_fmt)
    with pytest.raises(OSError, match="disk full"):
        write_measurements(target, [_make_test("new", 100)])
    assert calls["n"] > 200  # it did fail midway, after writing some rows
    assert target.read_bytes() == before  # old file untouched
    assert _listing(tmp_path) == ["keep.csv"]  # no temporary left behind
    with pytest.raises(OSError, match="disk full"):
        calls["n"] = 0
        write_measurements(tmp_path / "new.csv", [_make_test("new", 100)])
    assert _listing(tmp_path) == ["keep.csv"]

    monkeypatch.setattr(m, "_fmt", real_fmt)
    monkeypatch.setattr(m.os, "replace", lambda *a: (_ for _ in ()).throw(OSError("no replace")))
    with pytest.raises(OSError, match="no replace"):
        write_measurements(target, [_make_test("new", 10)])
    assert target.read_bytes() == before
    assert _listing(tmp_path) == ["keep.csv"]

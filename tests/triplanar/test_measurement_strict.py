"""The CSV reader is strict: time plausibility, ids, non-ASCII digits; fuzzed: a named MeasurementError or a
valid result, never another exception."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from triplanar.cli import main
from triplanar.labdata import generate_lab_data
from triplanar.measurement import MeasuredTest, MeasurementError, read_measurements, write_measurements

HEADER = "test_id,shear_force_N,t_s,cp1_x1_m,cp1_x3_m,cp2_x1_m,cp2_x3_m,cp3_x1_m,cp3_x3_m"


def row(tid="A", f="30.0", t="0.0", dx=0.0) -> str:
    return f"{tid},{f},{t},{-0.14 + dx},0.24,{dx},0.24,{dx},0.0"


def write(tmp_path, rows: list[str]):
    path = tmp_path / "d.csv"
    path.write_text("\n".join([HEADER] + rows) + "\n", encoding="utf-8")
    return path


@pytest.mark.parametrize("times, message", [
    (["0", "5", "10"], None),  # 10 s: accepted
    (["0", "200", "400"], "looks like milliseconds"),
    (["1e12", "1000000000000.005", "1000000000000.01"], "not near 0"),
    (["-5", "-4.9", "-4.8"], "not near 0"),
])
def test_time_column_must_be_seconds_from_load_onset(tmp_path, times, message) -> None:
    path = write(tmp_path, [row(t=t, dx=i * 1e-3) for i, t in enumerate(times)])
    if message is None:
        (test,) = read_measurements(path)
        assert test.t_s[-1] == 10.0
        return
    with pytest.raises(MeasurementError, match=message) as err:
        read_measurements(path)
    assert err.value.column == "t_s" and err.value.row in (2, 4)


def test_milliseconds_in_a_real_dataset_are_refused_by_compare(tmp_path, capsys) -> None:
    tests, _ = generate_lab_data(loads=(40.0,), repeats=1, seed=1)
    ms = [MeasuredTest(t.test_id, t.shear_force_N, t.positions, t.t_s * 1000.0) for t in tests]
    path = tmp_path / "ms.csv"
    with pytest.raises(MeasurementError, match="milliseconds"):  # the writer refuses what the reader would
        write_measurements(path, ms)
    lines = ["test_id,shear_force_N,t_s," + ",".join(f"cp{k}_x{a}_m" for k in (1, 2, 3) for a in (1, 2, 3))]
    t = tests[0]
    for i in range(t.n_samples):
        lines.append(",".join([t.test_id, repr(t.shear_force_N), repr(float(t.t_s[i]) * 1000.0)]
                              + [repr(float(v)) for v in t.positions[i].ravel()]))
    path.write_text("\n".join(lines) + "\n")
    code = main(["compare", str(path), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2 and "milliseconds" in err and "column t_s" in err
    assert not (tmp_path / "out" / "compare.csv").exists()


def test_ids_differing_only_by_whitespace_are_refused(tmp_path) -> None:
    path = write(tmp_path, [row("F1", t="0"), row("F1", t="0.1", dx=1e-3), row(" F1", t="0"),
                            row("F1", t="0.2", dx=2e-3), row(" F1", t="0.1", dx=1e-3), row(" F1", t="0.2", dx=2e-3)])
    with pytest.raises(MeasurementError, match="only by surrounding whitespace") as err:
        read_measurements(path)
    assert err.value.row == 4 and err.value.column == "test_id"


@pytest.mark.parametrize("tid", ["=HYPERLINK(\"http://x\")", "+cmd", "@SUM(A1)", " =1+1"])
def test_formula_like_ids_are_refused(tmp_path, tid) -> None:
    path = write(tmp_path, [row(f'"{tid}"', t=str(i * 0.1), dx=i * 1e-3) for i in range(3)])
    with pytest.raises(MeasurementError, match="formula") as err:
        read_measurements(path)
    assert err.value.row == 2


@pytest.mark.parametrize("text", ["\u0663\u0660.\u0660", "\uff13\uff10", "3\u0660"])
def test_non_ascii_digits_are_not_numbers(tmp_path, text) -> None:
    path = write(tmp_path, [row(f=text, t=str(i * 0.1), dx=i * 1e-3) for i in range(3)])
    with pytest.raises(MeasurementError, match="is not a number") as err:
        read_measurements(path)
    assert err.value.column == "shear_force_N" and err.value.row == 2


# -- fuzz --------------------------------------------------------------------------------------------------

GOOD = [HEADER] + [row("A", "30.0", f"{i * 0.01}", i * 1e-3) for i in range(4)] + \
       [row("B", "40.0", f"{i * 0.01}", i * 1e-3) for i in range(3)]
cells = st.one_of(st.text(max_size=8), st.sampled_from(["nan", "inf", "-0", "1e308", "1e-320", "", " ", "\ufeff",
                                                        "\u0663", "3.0", "2.5", "1000", "=1", '"', "A", "B", ","]),
                  st.floats().map(repr))


@st.composite
def csv_texts(draw):
    lines = [line.split(",") for line in GOOD]
    for _ in range(draw(st.integers(1, 4))):
        i = draw(st.integers(0, len(lines) - 1))
        action = draw(st.sampled_from(["cell", "cell", "drop_line", "dup_line", "drop_cell", "add_cell"]))
        if action == "cell" and lines[i]:
            lines[i][draw(st.integers(0, len(lines[i]) - 1))] = draw(cells)
        elif action == "drop_line" and len(lines) > 1:
            del lines[i]
        elif action == "dup_line":
            lines.insert(i, list(lines[i]))
        elif action == "drop_cell" and lines[i]:
            del lines[i][draw(st.integers(0, len(lines[i]) - 1))]
        elif action == "add_cell":
            lines[i].append(draw(cells))
    sep = draw(st.sampled_from(["\n", "\r\n", "\r"]))
    text = sep.join(",".join(line) for line in lines) + draw(st.sampled_from(["", sep, sep * 2]))
    return draw(st.sampled_from(["", "\ufeff"])) + text


@pytest.mark.slow
@settings(deadline=None, suppress_health_check=list(HealthCheck))  # inputs: the profile (tests/conftest.py)
@given(text=st.one_of(csv_texts(), st.text(max_size=300), st.binary(max_size=300)))
def test_fuzz_csv_reader_gives_a_named_error_or_a_valid_result(tmp_path_factory, text) -> None:
    path = tmp_path_factory.mktemp("fuzz", numbered=True) / "f.csv"
    path.write_bytes(text if isinstance(text, bytes) else text.encode("utf-8", "surrogatepass"))
    try:
        tests = read_measurements(path, rest_positions=np.array([[-0.14, 0.0, 0.24], [0.0, 0.0, 0.24],
                                                                 [0.0, 0.0, 0.0]]))
    except MeasurementError as err:
        assert err.path == str(path) and str(err).startswith(str(path))
        return
    assert tests
    for t in tests:
        assert t.n_samples >= 3 and np.all(np.isfinite(t.horizontal)) and np.all(np.abs(t.positions[~np.isnan(
            t.positions)]) <= 2.0)
        if t.t_s is not None:
            assert np.all(np.diff(t.t_s) > 0) and abs(t.t_s[0]) <= 1.0 and t.t_s[-1] - t.t_s[0] <= 60.0
    out = tmp_path_factory.mktemp("fuzz_out", numbered=True) / "back.csv"
    write_measurements(out, tests)  # everything read can be written and read back
    assert len(read_measurements(out)) == len(tests)

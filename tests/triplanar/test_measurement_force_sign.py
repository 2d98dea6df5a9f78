"""A negative shear force in a measured CSV is refused naming file, row and column (the model refuses it too)."""

from __future__ import annotations

import pytest

from triplanar.measurement import MeasurementError, read_measurements

HEADER = "test_id,shear_force_N,t_s,cp1_x1_m,cp1_x3_m,cp2_x1_m,cp2_x3_m,cp3_x1_m,cp3_x3_m"


def test_a_negative_shear_force_is_refused_by_row_and_column(tmp_path) -> None:
    path = tmp_path / "d.csv"
    rows = [f"A,-27.8,{i * 0.1},{-0.14 + i * 1e-3},0.24,{i * 1e-3},0.24,{i * 1e-3},0.0" for i in range(3)]
    path.write_text("\n".join([HEADER, *rows]) + "\n", encoding="utf-8")
    with pytest.raises(MeasurementError) as err:
        read_measurements(path)
    text = str(err.value)
    assert "d.csv" in text and "row 2" in text and "shear_force_N" in text and "negative" in text

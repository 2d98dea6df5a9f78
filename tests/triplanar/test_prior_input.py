"""A prior (``fit.json``) is checked where it enters: a tip friction of 1e308, -30 deg or ``true`` and a malformed
``param_ci95`` are refused naming the field; fuzzed: a named PriorError or a specimen."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from envs.core import make_config
from triplanar.prior import PriorError, drawing_record, fitted_intervals, load_prior

SPECIMEN, FOUNDATION = make_config(None).base_specimen()
DRAWING = drawing_record(SPECIMEN, FOUNDATION)


def fit_json(path: Path, effects, ci=None) -> Path:
    step = {"added": "end_friction", "effects": effects}
    if ci is not None:
        step["param_ci95"] = ci
    path.write_text(json.dumps({"steps": [step], "drawing": DRAWING}))
    return path


@pytest.mark.parametrize("value", [1e308, -30.0, True, 45.0, "8"])
def test_a_tip_friction_out_of_range_or_of_another_type_is_refused(value, tmp_path) -> None:
    with pytest.raises(PriorError, match=r"steps\[-1\]\.effects\.end_friction\.phi_deg: expected a friction angle "
                                         r"in \[0, 45\) deg"):
        load_prior(fit_json(tmp_path / "fit.json", {"end_friction": {"phi_deg": value}}), SPECIMEN, FOUNDATION)


@pytest.mark.parametrize("ci, field", [
    ("bad", r"steps\[-1\]\.param_ci95: expected an object"),
    ({"end_friction": "bad"}, r"param_ci95\.end_friction: expected an object"),
    ({"end_friction": {"phi_deg": [9.0, 7.0]}}, r"param_ci95\.end_friction\.phi_deg: expected \[low, high\]"),
    ({"end_friction": {"phi_deg": [True, 9.0]}}, r"param_ci95\.end_friction\.phi_deg"),
])
def test_a_malformed_interval_is_refused_naming_the_field(ci, field, tmp_path) -> None:
    path = fit_json(tmp_path / "fit.json", {"end_friction": {"phi_deg": 8.0}}, ci)
    with pytest.raises(PriorError, match=field):
        fitted_intervals(path)


def test_a_missing_interval_is_no_interval(tmp_path) -> None:
    path = fit_json(tmp_path / "fit.json", {"end_friction": {"phi_deg": 8.0}}, {"end_friction": {"phi_deg": None}})
    assert fitted_intervals(path) == {}


JSON_VALUES = st.recursive(st.one_of(st.none(), st.booleans(), st.floats(), st.integers(), st.text(max_size=5)),
                           lambda inner: st.lists(inner, max_size=3) | st.dictionaries(
                               st.sampled_from(["phi_deg", "end_friction", "contact_friction", "phi1_deg", "x"]),
                               inner, max_size=3), max_leaves=6)


@pytest.mark.slow
@settings(deadline=None, suppress_health_check=list(HealthCheck))   # inputs: the profile (tests/conftest.py)
@given(effects=JSON_VALUES, ci=JSON_VALUES)
def test_fuzz_priors_give_a_named_error_or_a_specimen(effects, ci, tmp_path_factory) -> None:
    path = tmp_path_factory.getbasetemp() / "fuzz_fit.json"   # one file, rewritten: a folder per input is slow
    path.write_text(json.dumps({"steps": [{"effects": effects, "param_ci95": ci}], "drawing": DRAWING}))
    for read in (lambda: load_prior(path, SPECIMEN, FOUNDATION), lambda: fitted_intervals(path)):
        try:
            read()
        except PriorError as err:
            assert str(err).startswith(str(path))

"""A combination's step that does nothing beside the others (every parameter's interval in the joint fit holds its
neutral value) is not named, as long as two remain (``rules._drop_idle``)."""

from __future__ import annotations

from triplanar.workbench import rules


def step(effect: str, ci95: dict) -> dict:
    return {"effect": effect, "kind": "candidate", "params": {k: sum(v) / 2 for k, v in ci95.items()},
            "param_ci95": ci95}


def test_an_idle_first_step_beside_two_instrument_gains_is_not_named():
    # the calibration's s6003: a time offset came first, then the two true gains; beside them dt_s is 0
    steps = [step("time_offset", {"dt_s": [-0.00079, 0.00145]}), step("load_cell_gain", {"gain": [0.885, 0.902]}),
             step("rangefinder_gain", {"gain_x1": [1.207, 1.262], "gain_x3": [0.998, 1.033]})]
    named, reasons = rules._drop_idle(steps)
    assert [s["effect"] for s in named] == ["load_cell_gain", "rangefinder_gain"]
    assert len(reasons) == 1 and reasons[0].text.startswith("time_offset is not named: beside the others its dt_s")


def test_a_step_is_kept_when_one_parameter_moves_or_when_fewer_than_two_would_remain():
    moved = [step("time_offset", {"dt_s": [0.002, 0.004]}), step("load_cell_gain", {"gain": [0.885, 0.902]}),
             step("rangefinder_gain", {"gain_x1": [0.99, 1.01], "gain_x3": [1.05, 1.08]})]
    assert rules._drop_idle(moved) == (moved, [])
    pair = [step("time_offset", {"dt_s": [-0.001, 0.001]}), step("load_cell_gain", {"gain": [0.885, 0.902]})]
    assert rules._drop_idle(pair) == (pair, [])

"""Identify, then control: a fitted specimen as the controller's prior and v1's nominal specimen; the tutorial."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from envs.core import make_config
from triplanar.prior import PriorError, drawing_record, load_prior
from triplanar.specimen import Foundation, Plane, to_toml

ROOT = Path(__file__).resolve().parents[2]


def _drawing():
    return make_config(None).base_specimen()


def _fit_json(tmp_path: Path, effects: dict, drawing: dict | None = None) -> Path:
    path = tmp_path / "fit.json"
    path.write_text(json.dumps({"model": "case B", "steps": [{"added": None, "effects": {}},
                                                             {"added": "x", "effects": effects}],
                                "drawing": drawing_record(*_drawing()) if drawing is None else drawing}))
    return path


def test_fit_json_of_another_drawing_or_without_one_refused(tmp_path):
    specimen, foundation = _drawing()
    record = drawing_record(specimen, foundation)
    moved = json.loads(json.dumps(record))
    moved["specimen"]["load_point_A_m"] += 0.005
    with pytest.raises(PriorError, match=r"drawing\.specimen\.load_point_A_m"):
        load_prior(_fit_json(tmp_path, {"end_friction": {"phi_deg": 6.5}}, moved), specimen, foundation)
    tilted = json.loads(json.dumps(record))
    tilted["foundation_normals"][1] = [0.0, 1.0, 0.0]
    with pytest.raises(PriorError, match=r"drawing\.foundation_normals\[1\]"):
        load_prior(_fit_json(tmp_path, {"end_friction": {"phi_deg": 6.5}}, tilted), specimen, foundation)
    with pytest.raises(PriorError, match="drawing: missing"):
        load_prior(_fit_json(tmp_path, {"end_friction": {"phi_deg": 6.5}}, {}), specimen, foundation)


def test_fit_json_becomes_the_specimen(tmp_path):
    specimen, foundation = _drawing()
    prior = load_prior(_fit_json(tmp_path, {"end_friction": {"phi_deg": 6.5},
                                            "contact_friction": {"phi1_deg": 16.0, "phi2_deg": 15.0,
                                                                 "phi3_deg": 10.0}}), specimen, foundation)
    assert prior.tip_friction_deg == 6.5 and tuple(prior.friction_deg) == (16.0, 15.0, 10.0)
    np.testing.assert_array_equal(prior.mass_centre_m, specimen.mass_centre_m)


@pytest.mark.parametrize("effects, field", [
    ({"plane_tilt": {"plane": 2, "dip_deg": 1.0}}, "steps[-1].effects.plane_tilt"),
    ({"end_friction": {}}, "steps[-1].effects.end_friction.phi_deg"),
    ({"contact_friction": {"phi1_deg": 16.0, "phi2_deg": None, "phi3_deg": 10.0}},
     "steps[-1].effects.contact_friction.phi2_deg")])
def test_fit_json_refused_naming_the_field(tmp_path, effects, field):
    specimen, foundation = _drawing()
    with pytest.raises(PriorError, match=field.replace("[", r"\[").replace("]", r"\]")):
        load_prior(_fit_json(tmp_path, effects), specimen, foundation)


def test_fit_json_without_steps_refused(tmp_path):
    path = tmp_path / "fit.json"
    path.write_text(json.dumps({"model": "case B"}))
    with pytest.raises(PriorError, match="steps"):
        load_prior(path, *_drawing())


def test_toml_of_another_foundation_or_specimen_refused(tmp_path):
    specimen, foundation = _drawing()
    other = Foundation((foundation.planes[0], Plane(12.0, 180.0), foundation.planes[2]))
    path = tmp_path / "s.toml"
    path.write_text(to_toml(specimen, other))
    with pytest.raises(PriorError, match=r"foundation.planes\[1\]"):
        load_prior(path, specimen, foundation)
    points = np.array(specimen.contact_points_m) * 1.1
    path.write_text(to_toml(replace(specimen, contact_points_m=points), foundation))
    with pytest.raises(PriorError, match="specimen.contact_points_m"):
        load_prior(path, specimen, foundation)
    path.write_text(to_toml(replace(specimen, tip_friction_deg=5.0), foundation))
    assert load_prior(path, specimen, foundation).tip_friction_deg == 5.0


@pytest.mark.slow
def test_tutorial_identify_then_control(tmp_path):
    """Fit the laboratory dataset (``triplanar fit data/lab_traces.csv --add end_friction``), take the
    fit as v1's nominal specimen and as the prior of ``mpc`` (its interval of the tip friction bounds the controller's
    hypotheses), and run ``mpc`` on a bench drawn around the fitted
    specimen with the laboratory's tip with the fit's prior; the drawing's prior, on the same bench, draws the tip
    from v1's whole range (its bank is made at the controller's reset; an episode with the drawing's prior runs in
    ``test_mpc.py``). (With the fit's interval not passed to the bank, the check of the bank's range fails; the
    estimates alone, the check before, stayed inside it with either prior.)"""
    from agents.heldout import random_benches, run_episode, summarise, with_tip
    from agents.mpc import MPCController
    from envs.triplanar_shear_v1 import TriPlanarShearV1Env
    from triplanar.cli import main
    from triplanar.prior import fitted_intervals
    assert main(["fit", str(ROOT / "data" / "lab_traces.csv"), "--add", "end_friction", "--no-progress",
                 "--out", str(tmp_path), "--executor", "serial", "--no-plots"]) == 0
    fit = tmp_path / "fit.json"
    specimen, foundation = _drawing()
    fitted = load_prior(fit, specimen, foundation)
    truth = json.loads((ROOT / "data" / "lab_traces.csv.truth.json").read_text())["effects"][0]["parameters"]
    low, high = fitted_intervals(fit)["tip_friction_deg"]
    assert low <= truth["phi_deg"] <= high and low <= fitted.tip_friction_deg <= high
    env_kwargs = {"nominal_specimen": str(fit)}   # v1's nominal specimen: the fitted one
    # one bench: what is asserted holds for every hypothesis of the bank, not only for a mean over benches (two
    # benches per prior cost 53 s of CPU, one 20 s)
    bench = with_tip(random_benches(1, 30_030, {"specimen": fitted})[0], truth["phi_deg"])
    controller = MPCController(prior=str(fit), bank_size=16, samples=16, iterations=2)
    row = summarise([run_episode(controller, bench, env_kwargs=env_kwargs, seed=0, index=0)])
    assert row["n_episodes"] == 1 and np.isfinite(row["score"])
    # the fit's prior keeps every hypothesis of the tip, and so the estimate, inside the fit's interval, after the
    # moves and refinements of a whole episode
    fitted_bank = controller.bank
    assert (fitted_bank.low[0], fitted_bank.high[0]) == (low, high)
    assert np.all((low <= fitted_bank.theta[:, 0]) & (fitted_bank.theta[:, 0] <= high)), fitted_bank.theta[:, 0]
    assert low <= controller.info["estimate"]["tip_friction_deg"] <= high
    # the drawing's prior draws the tip from v1's whole range
    env = TriPlanarShearV1Env(**env_kwargs)
    env.reset(seed=0, options={"bench": bench})
    drawing = MPCController(prior=specimen, bank_size=16, samples=16, iterations=2)
    drawing.reset(bench.load_N, env.config)
    assert drawing.bank.low[0] < low and high < drawing.bank.high[0]


def test_v1_takes_a_fit_as_its_nominal_specimen(tmp_path):
    import gymnasium as gym

    import envs  # noqa: F401  (registers the environments)
    path = _fit_json(tmp_path, {"end_friction": {"phi_deg": 6.5}})
    env = gym.make("TriPlanarShear-v1", nominal_specimen=str(path))
    env.reset(seed=0)
    assert env.unwrapped.episode_bench.specimen.tip_friction_deg == 6.5
    with pytest.raises(PriorError, match="plane_tilt"):
        gym.make("TriPlanarShear-v1", nominal_specimen=str(_fit_json(tmp_path, {"plane_tilt": {"dip_deg": 1.0}})))

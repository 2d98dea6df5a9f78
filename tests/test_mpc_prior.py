"""Identify, then control: a fitted specimen as the controller's prior and v1's nominal specimen; the tutorial."""

from __future__ import annotations

import json
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from envs.triplanar_shear import make_config
from triplanar.prior import PriorError, load_prior
from triplanar.specimen import Foundation, Plane, to_toml

ROOT = Path(__file__).resolve().parents[1]


def _drawing():
    return make_config(None).base_specimen()


def _fit_json(tmp_path: Path, effects: dict) -> Path:
    path = tmp_path / "fit.json"
    path.write_text(json.dumps({"model": "case B", "steps": [{"added": None, "effects": {}},
                                                             {"added": "x", "effects": effects}]}))
    return path


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
    """Fit the laboratory dataset, take the fit as the prior of ``mpc`` and as v1's nominal specimen, and run
    ``mpc`` on benches drawn around the fitted specimen, with the fit's prior and with the drawing's."""
    from agents.heldout import random_benches, run_episode, summarise
    from agents.mpc import MPCController
    subprocess.run([sys.executable, "-m", "triplanar.cli", "fit", str(ROOT / "data" / "lab_traces.csv"), "--add",
                    "end_friction", "--out", str(tmp_path / "fit"), "--workers", "1", "--no-progress"],
                   check=True, cwd=ROOT, capture_output=True)
    specimen, foundation = _drawing()
    fitted = load_prior(tmp_path / "fit" / "fit.json", specimen, foundation)
    assert 6.0 < fitted.tip_friction_deg < 10.0   # the dataset's tip: 8 deg (data/lab_traces.csv.truth.json)
    env_kwargs = {"specimen": fitted}             # v1's nominal specimen: the fitted one
    benches = random_benches(2, 30_030, env_kwargs)
    rows = {}
    for name, prior in (("fitted prior", fitted), ("drawing's prior", specimen)):
        outcomes = [run_episode(MPCController(prior=prior, bank_size=16, samples=16, iterations=2), bench,
                                env_kwargs=env_kwargs, seed=i, index=i) for i, bench in enumerate(benches)]
        rows[name] = summarise(outcomes)
    for row in rows.values():
        assert row["n_episodes"] == 2 and np.isfinite(row["score"])


def test_v1_takes_a_fit_as_its_nominal_specimen(tmp_path):
    import gymnasium as gym

    import envs  # noqa: F401
    path = _fit_json(tmp_path, {"end_friction": {"phi_deg": 6.5}})
    env = gym.make("TriPlanarShear-v1", nominal_specimen=str(path))
    env.reset(seed=0)
    assert env.unwrapped.episode_bench.specimen.tip_friction_deg == 6.5
    with pytest.raises(PriorError, match="plane_tilt"):
        gym.make("TriPlanarShear-v1", nominal_specimen=str(_fit_json(tmp_path, {"plane_tilt": {"dip_deg": 1.0}})))

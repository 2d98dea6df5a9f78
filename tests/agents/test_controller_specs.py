"""Controllers are built from typed specs (``agents.controller_specs``): every kind round-trips through its canonical
string (the string an ``EpisodeBatch`` holds, so task checkpoint keys stay as they were) and builds an
``agents.controller_base.Controller``; a bad string is refused naming the field."""

from __future__ import annotations

import pickle

import pytest

import agents.ppo_controller as ppo_controller
import agents.robust_policy as robust_policy
from agents import controller_specs as cs
from agents.controller_base import Controller
from agents.zoo import read_card
from experiments.episodes import EpisodeBatch, controller_of

SPECS = [cs.ScriptedSpec("pi_feedback", (("kp", -20.0), ("ki", 200.0))), cs.ScriptedSpec("mpc"),
         cs.PPOSpec("/runs/ppo/seed_0"), cs.PPOSpec("/runs/rec/seed_1", "ppo_recurrent"),
         cs.PPOSpec("/runs/v0", "ppo_state"), cs.ShippedSpec("ppo_robust", 2, "/zoo"), cs.StudentSpec("/s/student"),
         cs.EstimatedSpec("/e/estimator"), cs.BankedSpec("/d/run"),
         cs.BankedSpec("/d/run", "ppo_recurrent", 20, 2)]


@pytest.mark.parametrize("spec", SPECS, ids=lambda s: type(s).__name__ + ":" + s.text)
def test_a_spec_round_trips_through_its_string_and_its_batch(spec):
    extra = {"params": getattr(spec, "params", ()), "seed": getattr(spec, "seed", 0),
             "zoo_dir": getattr(spec, "zoo_dir", None)}
    assert cs.parse_controller(spec.text, **extra) == spec
    assert EpisodeBatch.of(spec, "row", seed=getattr(spec, "seed", 5)).spec == spec


def test_a_batch_from_a_spec_pickles_as_the_batch_written_by_hand_did():
    # the bench study's TaskCheckpoint keys hash the pickled batch: a spec must not change them
    old = [EpisodeBatch("pi", "pi_feedback", (("kp", 1.0),), "tuning", 9),
           EpisodeBatch("d|ppo_robust", "ppo:/r/s0", (), "heldout", 9, 3.0, (("latency_s", 0.1),), 2),
           EpisodeBatch("x", "shipped:ppo_robust", (), "stress", 4, 8.0, (), 1, "/zoo")]
    new = [EpisodeBatch.of(cs.ScriptedSpec("pi_feedback", (("kp", 1.0),)), "pi", "tuning", 9),
           EpisodeBatch.of(cs.PPOSpec("/r/s0"), "d|ppo_robust", "heldout", 9, 3.0, (("latency_s", 0.1),), 2),
           EpisodeBatch.of(cs.ShippedSpec("ppo_robust", 1, "/zoo"), "x", "stress", 4, 8.0)]
    assert [pickle.dumps(b, protocol=5) for b in new] == [pickle.dumps(b, protocol=5) for b in old]


@pytest.mark.parametrize("text, field", [("ppo:", "path"), ("shipped:", "name"), ("student:", "folder"), ("banked:", "run"),
                                         ("no_such_controller", "ScriptedSpec.name"), ("sac:/run", "kind")])
def test_a_bad_string_is_refused_naming_the_field(text, field):
    with pytest.raises(cs.ControllerSpecError, match=field):
        cs.parse_controller(text)


def test_a_bad_field_is_refused_naming_it():
    with pytest.raises(cs.ControllerSpecError, match="PPOSpec.kind"):
        cs.PPOSpec("/run", "sac")
    with pytest.raises(cs.ControllerSpecError, match="ShippedSpec.seed"):
        cs.ShippedSpec("ppo_robust", -1)
    with pytest.raises(cs.ControllerSpecError, match="params"):
        cs.parse_controller("ppo:/run", params=(("kp", 1.0),))
    for text in ("banked:/run?starter=ppo_recurrent", "banked:/run?starter=ppo_recurrent&periods=-2",
                 "banked:/run?periods=3&seed=1"):
        with pytest.raises(cs.ControllerSpecError, match="expected starter=NAME&periods=N"):
            cs.parse_controller(text)
    for args, field in (((None, 3), "give the starter"), (("", 3), "BankedSpec.starter"),
                        (("ppo_recurrent", 0), "BankedSpec.start_periods"), (("ppo_recurrent", True), "start_periods")):
        with pytest.raises(cs.ControllerSpecError, match=field):
            cs.BankedSpec("/run", *args)


def test_scripted_and_shipped_specs_build_controllers():
    built = cs.ScriptedSpec("pi_feedback", (("kp", -20.0), ("ki", 200.0))).build("row", {})
    assert isinstance(built.controller, Controller) and built.controller.name == "row" and not built.learned
    seed = read_card("ppo_robust")["seeds"][0]
    controller, env_kwargs, learned = controller_of(EpisodeBatch.of(cs.ShippedSpec("ppo_robust", seed), "agent"))
    assert isinstance(controller, Controller) and learned and controller.name == "agent"


class _Model:
    def predict(self, obs, **_):
        return obs[:2], None


class _Normalizer:
    def normalize_obs(self, obs):
        return obs


@pytest.mark.parametrize("kind", cs.PPO_KINDS)
def test_ppo_specs_build_controllers(kind, tmp_path, monkeypatch):
    # the run's files are stood in for (loading real runs: tests/agents/test_train_robust.py, test_evaluate.py)
    monkeypatch.setattr(robust_policy, "load_untrusted_sb3_zip", lambda path, algo="ppo": _Model())
    monkeypatch.setattr(robust_policy, "load_untrusted_vecnormalize", lambda path: _Normalizer())
    monkeypatch.setattr(ppo_controller.PPOController, "load",
                        classmethod(lambda cls, *a, name="ppo": cls.__new__(cls)))
    built = cs.PPOSpec(str(tmp_path), kind).build("row", {})
    assert isinstance(built.controller, Controller) and built.controller.name == "row" and built.learned
    assert (built.env_kwargs == {"observation_mode": "state"}) == (kind == "ppo_state")


def test_a_student_spec_builds_a_controller(tmp_path, student_files):
    import numpy as np

    from agents.student import tensor_shapes
    spec = {"format": 1, "frames": 2, "hidden": [4], "aux_names": ["tip"], "env_kwargs": {}}
    student_files.write(tmp_path, spec, {k: np.ones(shape, dtype=np.float32) for k, shape in tensor_shapes(spec).items()})
    built = cs.StudentSpec(str(tmp_path)).build("row", {})
    assert isinstance(built.controller, Controller) and built.controller.name == "row" and built.learned

"""One controller contract and one episode loop: every controller, scripted, model-based and learned, on v0 and v1,
is an ``agents.controller_base.Controller`` and runs through ``play`` (a few steps each)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from agents import SCRIPTED
from agents.bench_controllers import make_controller
from agents.controller_base import Controller, play
from agents.heldout import nominal_benches
from agents.ppo_controller import PPOController
from envs.triplanar_shear import TriPlanarShearEnv
from envs.triplanar_shear_v1 import TriPlanarShearV1Env

STEPS = 3
# Model-based controllers with a small search: the loop, not their quality, is under test.
SMALL = {"mpc": {"bank_size": 4, "start_periods": 1, "horizon": 8, "samples": 8, "iterations": 1, "elites": 2,
                 "refine_every": 0},
         "limit": {"horizon": 8, "samples": 8, "iterations": 1, "elites": 2}}


class _ZeroModel:
    """A stand-in for an SB3 model (PPOController needs only ``predict``)."""

    def predict(self, obs, deterministic=True):
        return np.zeros(2, dtype=np.float32), None


def _runs(controller: Controller, env, obs, load_N: float) -> None:
    assert isinstance(controller, Controller)
    total, steps, info = play(controller, env, obs, load_N, max_steps=STEPS)
    assert steps == STEPS and math.isfinite(total) and "reason" in info
    action, _ = controller.predict(obs)   # SB3's (action, state)
    assert np.asarray(action).shape == (2,)


@pytest.mark.parametrize("controller", [cls() for cls in SCRIPTED] + [PPOController(_ZeroModel())],
                         ids=lambda c: c.name)
def test_every_v0_controller_runs_through_the_loop(controller):
    env = TriPlanarShearEnv(load_N=41.7)
    obs, _ = env.reset(seed=0)
    _runs(controller, env, obs, 41.7)


@pytest.mark.parametrize("name", ["fixed_tip", "frictionless_tip", "tracking_tip", "moment_matching", "pi_feedback",
                                  "adaptive", "mpc", "limit", "information_bound"])
def test_every_v1_bench_controller_runs_through_the_loop(name):
    from experiments.evaluate import ADAPTIVE_GAINS, BUILTIN, PI_GAINS
    assert {factory for factory, _, _ in BUILTIN.values()} <= {"fixed_tip", "frictionless_tip", "tracking_tip",
                                                               "moment_matching", "pi_feedback", "adaptive", "mpc",
                                                               "limit", "information_bound"}
    params = {"pi_feedback": PI_GAINS, "adaptive": ADAPTIVE_GAINS}.get(name, SMALL.get(name, {}))
    bench = nominal_benches([40.0])[0]
    env = TriPlanarShearV1Env()
    obs, _ = env.reset(seed=0, options={"bench": bench})
    _runs(make_controller(name, **params), env, obs, bench.load_N)


@pytest.mark.slow   # loads torch and each shipped agent's policy
def test_every_shipped_agent_runs_through_the_loop():
    from agents.zoo import load_shipped, read_card, shipped_names
    for name in shipped_names():
        agent = load_shipped(name, read_card(name)["seeds"][0])
        env = agent.make_env()
        bench = nominal_benches([40.0])[0]
        obs, _ = env.reset(seed=0, options={"bench": bench})
        _runs(agent, env, obs, bench.load_N)


def test_a_student_runs_through_the_loop(tmp_path, student_files):
    from agents.student import StudentController
    folder = student_files.write(tmp_path / "s", {"format": 1, "frames": 2, "hidden": [4], "aux_names": [],
                                                  "env_kwargs": {}})
    bench = nominal_benches([40.0])[0]
    env = TriPlanarShearV1Env()
    obs, _ = env.reset(seed=0, options={"bench": bench})
    _runs(StudentController.load(folder), env, obs, bench.load_N)


def test_on_decision_sees_each_decision_before_the_env_steps():
    """``play``'s ``on_decision(obs, action)``: the observation decided on and the action, with the env still in
    the state decided on (a study reads the truth there), once per step, before ``on_step``."""
    bench = nominal_benches([40.0])[0]
    env = TriPlanarShearV1Env()
    obs, _ = env.reset(seed=0, options={"bench": bench})
    first, at_reset = obs.copy(), env.unwrapped.get_state().y
    events, decided, stepped = [], [], []

    def on_decision(decided_on, action):
        events.append("decision")
        decided.append((decided_on.copy(), action.copy(), env.unwrapped.get_state().y))

    def on_step(action, info):
        events.append("step")
        stepped.append(env.unwrapped.get_state().y)

    _, steps, _ = play(make_controller("pi_feedback"), env, obs, bench.load_N, on_decision=on_decision,
                       on_step=on_step, max_steps=3)
    assert events == ["decision", "step"] * steps
    assert np.array_equal(decided[0][0], first)
    for i, (_, action, y) in enumerate(decided):
        assert np.array_equal(y, at_reset if i == 0 else stepped[i - 1])   # the state decided in ...
        assert not np.array_equal(y, stepped[i])                           # ... not the one after its step
        assert action.dtype == np.float32 and action.shape == (2,)

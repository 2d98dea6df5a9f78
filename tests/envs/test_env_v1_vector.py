"""The batched TriPlanarShear-v1 runs the single v1 env exactly (its SB3 adapter: tests/agents/test_sb3_vec_env.py)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode
from gymnasium.wrappers import FrameStackObservation

import envs  # noqa: F401  (registers the environments)
from envs.triplanar_shear_v1 import TriPlanarShearV1Env
from envs.vector_v1 import BANK_STREAM, BenchBatch, TriPlanarShearV1VectorEnv
from triplanar.outcome import Outcome

N = 3


def actions(steps: int, seed: int = 0) -> np.ndarray:
    # Mostly sliding, sometimes wild: episodes end in several ways, so autoresets happen.
    rng = np.random.default_rng(seed)
    return np.clip(rng.normal(0.0, 0.9, (steps, N, 2)), -1, 1).astype(np.float32)


def _same_info(info: dict, i: int, inf: dict, te: bool, tr: bool) -> None:
    assert info["load_cell_N"][i] == inf["load_cell_N"]
    assert info["reward_action_rate"][i] == inf["reward_action_rate"]
    if te or tr:
        assert info["reason_code"][i] == Outcome.from_label(inf["reason"])
        assert info["mimicry_error_mm"][i] == inf["mimicry_error_mm"]


@pytest.fixture
def compare_with_singles(beside_singles):
    def compare(steps: int, frame_stack: int = 1, **kwargs) -> set[str]:
        """Step the batch and N single envs (seeded s + i) with the same actions; every output bitwise equal.
        Returns the episode ends seen."""
        vec = gym.make_vec("TriPlanarShear-v1", num_envs=N, vectorization_mode="vector_entry_point",
                           frame_stack=frame_stack, **kwargs)
        singles = [TriPlanarShearV1Env(**kwargs) for _ in range(N)]
        if frame_stack > 1:
            singles = [FrameStackObservation(env, frame_stack) for env in singles]
        return beside_singles(vec, singles, actions(steps), 40, _same_info)
    return compare


def test_declares_its_autoreset_mode_and_spaces() -> None:
    vec = gym.make_vec("TriPlanarShear-v1", num_envs=2, vectorization_mode="vector_entry_point", frame_stack=4,
                       randomize=True)
    assert isinstance(vec, TriPlanarShearV1VectorEnv)
    assert vec.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
    single = FrameStackObservation(TriPlanarShearV1Env(randomize=True), 4)
    assert vec.single_observation_space == single.observation_space
    obs, _ = vec.reset(seed=0)
    assert obs.shape == (2, 4, 15) and vec.observation_space.contains(obs)


def test_equals_single_envs_bench_mode_randomised_with_latency(compare_with_singles) -> None:
    reasons = compare_with_singles(300, randomize=True, latency_s=0.01)
    assert len(reasons) >= 2   # several kinds of episode end, hence autoresets, were compared


def test_equals_single_envs_state_mode_randomised(compare_with_singles) -> None:
    assert len(compare_with_singles(400, observation_mode="state", randomize=True)) >= 2


def test_equals_framestacked_single_envs(compare_with_singles) -> None:
    assert len(compare_with_singles(200, frame_stack=4, randomize=True, load_N=40.0)) >= 2


def test_equals_single_envs_short(compare_with_singles) -> None:
    compare_with_singles(30, randomize=True, latency_s=0.01, frame_stack=2)


def test_bad_arguments_are_named() -> None:
    with pytest.raises(ValueError, match="frame_stack"):
        TriPlanarShearV1VectorEnv(2, frame_stack=0)
    with pytest.raises(ValueError, match="latency_s"):
        TriPlanarShearV1VectorEnv(2, latency_s=0.003)
    with pytest.raises(ValueError, match="num_envs"):
        TriPlanarShearV1VectorEnv(0)
    vec = TriPlanarShearV1VectorEnv(2)
    with pytest.raises(gym.error.ResetNeeded):
        vec.step(np.zeros((2, 2)))
    vec.reset(seed=0)
    with pytest.raises(ValueError, match="shape"):
        vec.step(np.zeros((3, 2)))
    with pytest.raises(ValueError, match="unknown reset options"):
        vec.reset(options={"load": 3})


def test_start_bank_reuses_each_specimen_and_never_holds_a_heldout_one() -> None:
    from agents.heldout import HELDOUT_SEED, TUNING_SEED, heldout_benches, random_benches
    assert BANK_STREAM not in (HELDOUT_SEED, TUNING_SEED)
    config, bench = TriPlanarShearV1Env(randomize=True).config, TriPlanarShearV1Env(randomize=True).bench
    batch = BenchBatch(4, config, bench, start_bank=8, bank_reuse=3)
    batch.seed([0, 1, 2, 3])
    seen = []
    for _ in range(12):  # 48 episodes: the first reset fills the bank (8), each serves 3, then 8 fresh ones x 3
        batch.reset_rows(np.arange(4))
        seen += [(b.specimen.mass_kg, b.specimen.tip_friction_deg) for b in batch.benches]
    assert batch._bank_drawn == 16 and len(set(seen)) == 16
    assert all(seen.count(key) == 3 for key in set(seen))
    names = set(seen)
    protected = heldout_benches(200) + random_benches(10, TUNING_SEED + 1)
    assert not names & {(b.specimen.mass_kg, b.specimen.tip_friction_deg) for b in protected}


def test_banked_vector_env_autoresets_within_its_spaces() -> None:
    vec = TriPlanarShearV1VectorEnv(4, randomize=True, frame_stack=2, start_bank=3, bank_reuse=2)
    obs, _ = vec.reset(seed=9)
    assert vec.batch._bank_drawn == 3   # the first reset filled the bank
    ends = 0
    for batch in np.clip(np.random.default_rng(1).normal(0.0, 0.9, (150, 4, 2)), -1, 1):
        obs, rewards, terminated, truncated, _ = vec.step(batch)
        assert vec.observation_space.contains(obs) and np.all(np.isfinite(rewards))
        ends += int(np.count_nonzero(terminated | truncated))
    assert ends >= 8 and vec.batch._bank_drawn > 3   # entries that served their episodes were replaced

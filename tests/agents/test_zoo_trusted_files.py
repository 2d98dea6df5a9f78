"""The shipped agents load without unpickling, from the list pinned in agents/zoo/__init__.py only: a planted pickle
(its payload writes a marker file) never runs, in an added zoo folder or as a replaced file; symlinks are refused."""

from __future__ import annotations

import hashlib
import json
import pickle
import shutil
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import envs  # noqa: F401  (registers the ids)
from agents import zoo
from agents.ppo_controller import load_untrusted_vecnormalize
from agents.zoo import ShippedAgentError, load_shipped, model_files, read_card


class _Payload:
    def __init__(self, marker: Path):
        self.marker = marker

    def __reduce__(self):
        return Path.touch, (self.marker,)


def _plant(path: Path, marker: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(pickle.dumps(_Payload(marker)))


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.fixture
def copied_zoo(tmp_path):
    """A copy of the shipped ppo_robust (seed 0 only is needed) in a zoo of its own."""
    root = tmp_path / "zoo"
    shutil.copytree(zoo.ZOO_DIR / "ppo_robust", root / "ppo_robust")
    return root


def test_the_planted_payload_is_live(tmp_path):
    """What the other tests plant does run when unpickled, through the one call that says it unpickles."""
    marker = tmp_path / "ran"
    _plant(tmp_path / "vecnormalize.pkl", marker)
    load_untrusted_vecnormalize(tmp_path / "vecnormalize.pkl")
    assert marker.exists()
    assert "UNPICKLES" in load_untrusted_vecnormalize.__doc__


def test_an_added_agent_folder_is_neither_listed_nor_loaded(copied_zoo, tmp_path, monkeypatch, capsys):
    from triplanar import cli
    marker = tmp_path / "ran"
    evil = copied_zoo / "evil"
    for rel in ("seed_0/model.zip", "seed_0/vecnormalize.pkl", *model_files(0)):
        _plant(evil / rel, marker)
    card = dict(read_card("ppo_robust", copied_zoo), name="evil", seeds=[0])
    card["files"] = {rel: _sha(evil / rel) for rel in ("seed_0/model.zip", "seed_0/vecnormalize.pkl",
                                                        *model_files(0))}
    (evil / "card.json").write_text(json.dumps(card))
    monkeypatch.setattr(zoo, "ZOO_DIR", copied_zoo)
    assert "evil" not in zoo.shipped_names() and "ppo_robust" in zoo.shipped_names()
    with pytest.raises(ShippedAgentError, match="no shipped agent 'evil'"):
        load_shipped("evil", 0)
    with pytest.raises(ShippedAgentError, match="no shipped agent 'evil'"):
        read_card("evil")
    assert cli.main(["evaluate", "--controller", "evil", "--n", "1", "--out", str(tmp_path / "out")]) == 2
    assert "unknown controller 'evil'" in capsys.readouterr().err
    assert not marker.exists()


@pytest.mark.parametrize("rel", ["card.json", *model_files(0)])
def test_a_replaced_file_is_refused_and_never_unpickled(copied_zoo, tmp_path, rel):
    marker = tmp_path / "ran"
    _plant(copied_zoo / "ppo_robust" / rel, marker)
    with pytest.raises(ShippedAgentError, match="SHA-256 differs"):
        load_shipped("ppo_robust", 0, copied_zoo)
    # Even pinned (someone edited the code's pins too), the formats are data: refused as not JSON / safetensors.
    pins = {"ppo_robust": dict(zoo.SHIPPED["ppo_robust"], **{rel: _sha(copied_zoo / "ppo_robust" / rel)})}
    with pytest.raises(ShippedAgentError, match="not JSON|not a safetensors"):
        load_shipped("ppo_robust", 0, copied_zoo, pins)
    assert not marker.exists()


def test_symlinked_folders_and_files_are_refused(copied_zoo, tmp_path):
    real = tmp_path / "elsewhere"
    shutil.move(copied_zoo / "ppo_robust", real)
    (copied_zoo / "ppo_robust").symlink_to(real, target_is_directory=True)
    with pytest.raises(ShippedAgentError, match="symlink"):
        load_shipped("ppo_robust", 0, copied_zoo)
    (copied_zoo / "ppo_robust").unlink()
    shutil.copytree(real, copied_zoo / "ppo_robust")
    policy = copied_zoo / "ppo_robust" / model_files(0)[0]
    policy.unlink()
    policy.symlink_to(real / model_files(0)[0])   # the very same bytes, through a link
    with pytest.raises(ShippedAgentError, match="symlink"):
        load_shipped("ppo_robust", 0, copied_zoo)


def test_the_shipped_agents_load_with_every_unpickler_disabled(monkeypatch):
    import cloudpickle
    import torch

    def refuse(*args, **kwargs):
        raise AssertionError("a shipped agent was unpickled")

    # numba reads its compile cache (the project's own, written by `make install`) with pickle: the env and the
    # specimen bank's compiled functions are loaded first, so that what follows loads only the agents' own files
    from agents.deviation_bank import DeviationBank
    env = gym.make("TriPlanarShear-v1", observation_mode="bench")
    obs, _ = env.reset(seed=0)
    bank = DeviationBank.of_size(2)
    bank.reset(env.unwrapped.episode_bench.load_N, env.unwrapped.config)
    bank.estimate(obs)
    bank.advance(np.zeros(2))

    for module, attr in ((pickle, "load"), (pickle, "loads"), (pickle, "Unpickler"), (cloudpickle, "load"),
                         (cloudpickle, "loads"), (torch, "load")):
        monkeypatch.setattr(module, attr, refuse)
    assert zoo.shipped_names() == ["ppo_banked", "ppo_recurrent", "ppo_robust", "ppo_rolling_slow_noisy",
                                   "ppo_steel_slow_noisy", "ppo_tracked"]
    for name in zoo.shipped_names():   # one seed each (every seed: the conversion's check, experiments.shipping)
        agent = load_shipped(name, read_card(name)["seeds"][-1])
        action, _ = agent.predict(obs)
        assert action.shape == (2,) and np.all(np.abs(action) <= 1)
    files = [p.name for p in zoo.ZOO_DIR.rglob("*") if p.is_file()]
    assert not [f for f in files if f.endswith((".pkl", ".zip", ".pt", ".pth"))]

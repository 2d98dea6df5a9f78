"""``triplanar train``'s YAML, ``--set`` and ``--env-arg`` values checked where they enter: unknown or ill-typed keys
refused by name with the allowed range (exit 2, no traceback, nothing trained); the YAML read safely, its size and
alias expansion bounded; fuzzed: a named refusal or a valid configuration."""

from __future__ import annotations

import copy
import time
from pathlib import Path
from unittest import mock

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from triplanar import cli
from triplanar.yaml_input import YAMLInputError, load_text

pytest.importorskip("stable_baselines3")


@pytest.mark.parametrize("env, setting, message", [
    ("TriPlanarShear-v1", "normalize.clip_obs=-1", "normalize.clip_obs: expected a number in (0, 1e+06]"),
    ("TriPlanarShear-v0", "normalize.clip_obs=-1", "normalize.clip_obs: expected a number in (0, 1e+06]"),
    ("TriPlanarShear-v1", "hyperparams.lerning_rate=0.1", "hyperparams.lerning_rate: unknown key; known keys: "),
    ("TriPlanarShear-v1", "hyperparams.n_steps=abc", "hyperparams.n_steps: expected an integer in [1, 1000000]"),
    ("TriPlanarShear-v1", "hyperparams.n_steps=1e12", "hyperparams.n_steps: expected an integer"),
    ("TriPlanarShear-v1", "hyperparams.policy_kwargs.net_arch=[100000000]", "policy_kwargs.net_arch: expected"),
    ("TriPlanarShear-v1", "hyperparams.policy_kwargs.activation_fn=tanh", "policy_kwargs.activation_fn: unknown"),
    ("TriPlanarShear-v1", "hyperparams.learning_rate='3e-4'", "write numbers and booleans unquoted"),
    ("TriPlanarShear-v1", "normalize.norm_obs='no'", "normalize.norm_obs: expected true or false, got 'no'"),
    ("TriPlanarShear-v1", "normalize.foo=1", "normalize.foo: unknown key"),
    ("TriPlanarShear-v1", "n_envs=100000000", "n_envs: expected an integer in [1, 1024]"),
    ("TriPlanarShear-v1", "policy=CnnPolicy", "policy: expected 'MlpPolicy'"),
    ("TriPlanarShear-v0", "ppo.n_epochs=0", "ppo.n_epochs: expected an integer in [1, 1000]"),
    ("TriPlanarShear-v0", "normalize.lol.x=1", "override normalize.lol.x: lol is not a mapping"),
])
def test_bad_settings_are_refused_naming_the_key(env, setting, message, tmp_path, capsys) -> None:
    if setting.startswith("normalize.lol"):   # a scalar where a mapping is walked through
        argv = ["--set", "normalize.lol=1", "--set", setting]
    else:
        argv = ["--set", setting]
    assert cli.main(["train", "--env", env, *argv, "--out", str(tmp_path), "--executor", "serial",
                     "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not list(tmp_path.rglob("*.zip")) and not list(tmp_path.rglob("config.json"))


def test_unquoted_exponents_are_numbers_by_yaml_1_2(tmp_path) -> None:
    from agents.train_robust import load_robust_config
    path = tmp_path / "c.yaml"
    path.write_text("env_id: TriPlanarShear-v1\nhyperparams:\n  learning_rate: 3e-4\n")
    assert load_robust_config(path)["hyperparams"]["learning_rate"] == 3e-4
    path.write_text("env_id: TriPlanarShear-v1\nhyperparams:\n  learning_rate: \"3e-4\"\n")
    with pytest.raises(ValueError, match="hyperparams.learning_rate: expected a number in \\(0, 1\\], got '3e-4'"):
        load_robust_config(path)


def alias_bomb(levels: int = 9) -> str:
    text, previous = 'a: &a ["x","x","x","x","x","x","x","x","x"]\n', "a"
    for name in "bcdefghijk"[:levels - 1]:
        text += f"{name}: &{name} [" + ",".join([f"*{previous}"] * 9) + "]\n"
        previous = name
    return text


def test_nested_aliases_are_refused_quickly(tmp_path, capsys) -> None:
    bomb = alias_bomb()
    assert len(bomb) < 400
    config = tmp_path / "bomb.yaml"
    config.write_text(bomb)
    started = time.process_time()
    assert cli.main(["train", "--env", "TriPlanarShear-v1", "--config", str(config), "--out", str(tmp_path / "o"),
                     "--no-progress"]) == 2
    assert "more than 100000 entries once its aliases are expanded" in capsys.readouterr().err
    assert time.process_time() - started < 10   # a bound on the refusal, not a timing claim (it used to take 39 s)


def test_a_large_or_deep_yaml_is_refused() -> None:
    with pytest.raises(YAMLInputError, match="larger than"):
        load_text("a: " + "x" * 1_000_001, "big")
    with pytest.raises(YAMLInputError, match="nested more than"):
        load_text("[" * 40 + "]" * 40, "deep")


YAML_CHUNKS = st.sampled_from(["a:", " ", "\n", "  ", "- ", "&x ", "*x", "[", "]", "{", "}", ",", "3e-4", '"3e-4"',
                               "no", "true", "!!python/object:os.system", "hyperparams:", "learning_rate:",
                               "normalize:", "clip_obs:", "-1", "1e308", ".nan", "n_envs:", "policy_kwargs:",
                               "net_arch:", "env:", "train:", "total_timesteps:", "0", "x", "<<: *x", "~"])


@pytest.mark.slow
@settings(deadline=None, suppress_health_check=list(HealthCheck))   # inputs: the profile (tests/conftest.py)
@given(text=st.lists(YAML_CHUNKS, max_size=16).map("".join))
def test_fuzz_the_training_yaml_gives_a_named_error_or_a_configuration(text, tmp_path_factory) -> None:
    from agents.train_robust import check_robust_config
    try:
        config = load_text(text, "c.yaml")
    except YAMLInputError as err:
        assert str(err).startswith("c.yaml: ")
        return
    if not isinstance(config, dict):
        return
    try:
        check_robust_config({"env_id": "TriPlanarShear-v1", **config}, "c.yaml")
    except ValueError as err:
        assert str(err).startswith("c.yaml: ")


ROBUST = load_text((Path(__file__).resolve().parents[2] / "agents" / "robust.yaml").read_text(), "robust.yaml")
SET_KEYS = st.sampled_from(["hyperparams.learning_rate", "hyperparams.n_steps", "hyperparams.policy_kwargs.net_arch",
                            "hyperparams.policy_kwargs", "normalize.clip_obs", "normalize.norm_obs", "n_envs",
                            "train.total_timesteps", "hyperparams.x", "policy", "algo", "env.frame_stack",
                            "hyperparams.gamma", "normalize"])
SET_VALUES = st.one_of(st.sampled_from(["-1", "0", "1e308", "3e-4", "'3e-4'", "no", "true", "[1, 2]", "{a: 1}", "~",
                                        "[100000000]", "&a [*a]", "abc", "0.5", "64", "MlpPolicy"]),
                       st.text(max_size=12))


@pytest.mark.slow
@settings(deadline=None, suppress_health_check=list(HealthCheck))   # inputs: the profile (tests/conftest.py)
@given(key=SET_KEYS, value=SET_VALUES)
def test_fuzz_set_gives_a_named_error_or_a_configuration(key, value) -> None:
    import argparse

    from agents.train_robust import load_robust_config
    from triplanar.commands.train import key_value
    try:
        parsed = key_value(f"{key}={value}")
    except argparse.ArgumentTypeError as err:
        assert str(err).startswith(key)
        return
    try:
        with mock.patch("triplanar.yaml_input.load_file", lambda path: copy.deepcopy(ROBUST)):
            load_robust_config(overrides=dict([parsed]))
    except ValueError as err:
        assert key.split(".")[0] in str(err) or "env:" in str(err)

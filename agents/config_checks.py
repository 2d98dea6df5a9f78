"""The checks of a training YAML's ``hyperparams`` (v0: ``ppo``) and ``normalize`` sections: every key known, every
value of its type and in its range, refused (ValueError naming the key and the allowed values) before any training.

A boolean is ``true``/``false`` (not ``"no"``, not 1); a number is a YAML number (``3e-4`` or ``3.0e-4``, not the
string ``"3e-4"``: :mod:`triplanar.yaml_input`); sizes are bounded so that a typo cannot ask for a network or a
rollout buffer that does not fit in memory.
"""

from __future__ import annotations

import math
from typing import Any, Callable

Check = Callable[[Any], bool]


def _number(lo: float, hi: float, lo_open: bool = False, hi_open: bool = False) -> tuple[Check, str]:
    def ok(v: Any) -> bool:
        return (not isinstance(v, bool) and isinstance(v, (int, float)) and math.isfinite(v)
                and (lo < v if lo_open else lo <= v) and (v < hi if hi_open else v <= hi))
    return ok, f"a number in {'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}"


def _integer(lo: int, hi: int) -> tuple[Check, str]:
    return (lambda v: not isinstance(v, bool) and isinstance(v, int) and lo <= v <= hi), f"an integer in [{lo}, {hi}]"


def _optional(check: tuple[Check, str]) -> tuple[Check, str]:
    return (lambda v: v is None or check[0](v)), f"null or {check[1]}"


BOOLEAN: tuple[Check, str] = ((lambda v: isinstance(v, bool)), "true or false")
MAX_UNITS = 4096    # units of a layer
MAX_LAYERS = 16


def _net_arch_ok(v: Any) -> bool:
    def layers(x: Any) -> bool:
        return isinstance(x, list) and len(x) <= MAX_LAYERS and all(_integer(1, MAX_UNITS)[0](u) for u in x)
    if isinstance(v, dict):
        return set(v) <= {"pi", "vf", "qf"} and all(layers(x) for x in v.values())
    return layers(v)


POLICY_KWARGS: dict[str, tuple[Check, str]] = {
    "net_arch": (_net_arch_ok, f"a list of at most {MAX_LAYERS} layer sizes in [1, {MAX_UNITS}] (or pi/vf lists)"),
    "log_std_init": _number(-20, 5),
    "ortho_init": BOOLEAN,
    "full_std": BOOLEAN,
    "use_expln": BOOLEAN,
    "squash_output": BOOLEAN,
    "share_features_extractor": BOOLEAN,
    "lstm_hidden_size": _integer(1, MAX_UNITS),
    "n_lstm_layers": _integer(1, 8),
    "enable_critic_lstm": BOOLEAN,
    "shared_lstm": BOOLEAN,
}
HYPERPARAMS: dict[str, tuple[Check, str]] = {
    "learning_rate": _number(0, 1, lo_open=True),
    "n_steps": _integer(1, 1_000_000),
    "batch_size": _integer(1, 10_000_000),
    "n_epochs": _integer(1, 1000),
    "gamma": _number(0, 1, lo_open=True),
    "gae_lambda": _number(0, 1),
    "clip_range": _number(0, 10, lo_open=True),
    "clip_range_vf": _optional(_number(0, 10, lo_open=True)),
    "normalize_advantage": BOOLEAN,
    "ent_coef": _number(0, 10),
    "vf_coef": _number(0, 10),
    "max_grad_norm": _number(0, 1e6, lo_open=True),
    "use_sde": BOOLEAN,
    "sde_sample_freq": _integer(-1, 1_000_000),
    "target_kl": _optional(_number(0, 10, lo_open=True)),
    "stats_window_size": _integer(1, 100_000),
    "policy_kwargs": ((lambda v: isinstance(v, dict)), "a mapping (" + ", ".join(POLICY_KWARGS) + ")"),
}
NORMALIZE: dict[str, tuple[Check, str]] = {
    "norm_obs": BOOLEAN,
    "norm_reward": BOOLEAN,
    "clip_obs": _number(0, 1e6, lo_open=True),
    "clip_reward": _number(0, 1e6, lo_open=True),
    "gamma": _number(0, 1, lo_open=True),
    "epsilon": _number(0, 1, lo_open=True),
}
MAX_ENVS = 1024


def _looks_plain(text: str) -> bool:
    try:
        float(text)
        return True
    except ValueError:
        return text.lower() in ("true", "false")


def _check_section(section: Any, known: dict[str, tuple[Check, str]], where: str) -> None:
    if section is None:
        return
    if not isinstance(section, dict):
        raise ValueError(f"{where}: expected a mapping, got {section!r:.80}")
    for key, value in section.items():
        if key not in known:
            raise ValueError(f"{where}.{key}: unknown key; known keys: {', '.join(known)}")
        ok, allowed = known[key]
        if not ok(value):
            hint = " (a string: write numbers and booleans unquoted)" if isinstance(value, str) and _looks_plain(
                value) else ""
            raise ValueError(f"{where}.{key}: expected {allowed}, got {value!r:.80}{hint}")


def check_hyperparams(hyperparams: Any, where: str, extra: tuple[str, ...] = ()) -> None:
    """``hyperparams`` (the PPO/RecurrentPPO keyword arguments) checked; ``extra``: further keys allowed as
    strings (v0's ``ppo.policy``)."""
    if isinstance(hyperparams, dict):
        hyperparams = {k: v for k, v in hyperparams.items() if k not in extra or not isinstance(v, str)}
    _check_section(hyperparams, HYPERPARAMS, where)
    _check_section((hyperparams or {}).get("policy_kwargs"), POLICY_KWARGS, f"{where}.policy_kwargs")


def check_normalize(normalize: Any, where: str) -> None:
    _check_section(normalize, NORMALIZE, where)


def check_n_envs(n_envs: Any, where: str) -> None:
    ok, allowed = _integer(1, MAX_ENVS)
    if not ok(n_envs):
        raise ValueError(f"{where}: expected {allowed}, got {n_envs!r:.80}")

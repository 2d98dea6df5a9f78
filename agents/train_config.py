"""The one training configuration (rl-zoo-style YAML) for both envs, read and checked before anything trains.

Keys (every shipped YAML in ``agents/`` uses them; an unknown key or ill-typed value is refused, naming the file and
the key, :mod:`agents.config_checks`):

* ``env_id``: ``TriPlanarShear-v0`` (the ideal bench; evaluated at fixed loads) or ``TriPlanarShear-v1`` (the
  realistic bench; evaluated on tuning benches), and ``env``: its arguments (v0: ``ShearConfig`` fields; v1: any v1
  argument, randomisation included, plus the batch's ``frame_stack``, ``start_bank``, ``bank_reuse``, and
  ``privileged: true``: a teacher's run, each env's true unknowns appended to its observation, :mod:`agents.privileged`;
  its policy reads them from the env it is bound to, :class:`agents.robust_policy.PrivilegedPolicy`; or
  ``reference_deviation: true``: each env's deviation from its true hydrostatic reference and the reference's slope,
  :func:`envs.core.reference_deviation`, read likewise by :class:`agents.robust_policy.DeviationPolicy`; with
  ``reference_deviation_bias_mm: B``, trained off by a per-episode bias, or with
  ``reference_deviation_estimator: FOLDER``, on that bench estimator's output instead of the truth (the estimator
  in the loop; ``reference_deviation_estimator_state: true`` appends that estimator's GRU state as well), or with
  ``reference_deviation_bank: N``, on the estimate of a specimen bank of N hypotheses (``banked:RUN``'s,
  :mod:`agents.deviation_bank`; with ``reference_deviation_tracker: true``, on that bank's Gauss-Newton tracker's,
  :mod:`agents.deviation_tracker`),
  :class:`agents.sb3_vec_env.DeviationSB3VecEnv`);
* ``algo``: ``ppo`` (SB3 PPO) or ``recurrent`` (sb3-contrib ``RecurrentPPO``, v1), ``policy`` and ``hyperparams``
  (its keyword arguments); ``ppo:`` is the same pair in one section with ``policy`` inside (``agents/ppo.yaml``);
* ``n_envs`` (one batched env, :mod:`agents.sb3_vec_env`) and ``normalize`` (``VecNormalize``'s arguments);
* ``train``: ``total_timesteps``, ``eval_freq``, ``checkpoint_freq``, ``torch_threads``; ``eval_loads`` (v0: the
  loads of each evaluation).

What differs between the envs beyond the YAML is data, :data:`PROFILES`: the defaults and the run folder's layout.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np

from .config_checks import check_hyperparams, check_n_envs, check_normalize

HERE = Path(__file__).parent
V0, V1 = "TriPlanarShear-v0", "TriPlanarShear-v1"
CONFIG_KEYS = ("env_id", "algo", "env", "n_envs", "normalize", "policy", "hyperparams", "ppo", "train", "eval_loads")
TRAIN_KEYS = ("total_timesteps", "eval_freq", "checkpoint_freq", "torch_threads")
BATCH_KEYS = ("frame_stack", "start_bank", "bank_reuse")   # the batched v1 env's own arguments (envs.vector_v1)
PRIVILEGED = "privileged"  # v1, algo ppo: the bench's true unknowns appended to the observation (agents.privileged)
REFERENCE_DEVIATION = "reference_deviation"  # v1, algo ppo: the deviation from the true case-C reference appended
EXTRA_INPUTS = (PRIVILEGED, REFERENCE_DEVIATION)   # a frame-stack PPO's privileged inputs (at most one per run)
DEVIATION_BIAS = "reference_deviation_bias_mm"   # training with an estimate's error (agents.sb3_vec_env)
DEVIATION_ESTIMATOR = "reference_deviation_estimator"   # training on a bench estimator's output (the same module)
ESTIMATOR_STATE = "reference_deviation_estimator_state"   # and on its GRU's state, appended after the estimate
DEVIATION_BANK = "reference_deviation_bank"   # training on a specimen bank's estimate of N hypotheses (banked:RUN's)
DEVIATION_TRACKER = "reference_deviation_tracker"   # and on its Gauss-Newton tracker's (agents.deviation_tracker)
DEVIATION_OPTIONS = (DEVIATION_BIAS, DEVIATION_ESTIMATOR, ESTIMATOR_STATE, DEVIATION_BANK, DEVIATION_TRACKER)
ALGOS = {"ppo": "ppo_robust", "recurrent": "ppo_recurrent"}  # algo -> v1 controller name in the tables
POLICIES = {"ppo": "MlpPolicy", "recurrent": "MlpLstmPolicy"}
EVALUATIONS = 20       # v1: points of the learning curve when neither the YAML nor the caller sets train.eval_freq


@dataclass(frozen=True)
class Profile:
    """What an env id implies beyond its YAML: the default YAML per algo, the defaults of ``train``, the run folder's
    layout (``loads``: SB3-style ``checkpoints/`` and evaluations at ``eval_loads``, :mod:`agents.run_loads`;
    ``benches``: one ``checkpoint/`` set and evaluations on tuning benches, :mod:`agents.run_benches`)."""

    configs: dict[str, Path]
    total_timesteps: int
    eval_freq: int | None      # None: EVALUATIONS points over the run (default_eval_freq)
    checkpoint_freq: int
    layout: str
    keys: tuple[str, ...]      # the top-level keys this env takes


PROFILES = {
    V0: Profile({"ppo": HERE / "ppo.yaml"}, 400_000, 20_000, 50_000, "loads", CONFIG_KEYS),
    V1: Profile({"ppo": HERE / "robust.yaml", "recurrent": HERE / "recurrent.yaml"}, 100_000, None, 50_000,
                "benches", tuple(k for k in CONFIG_KEYS if k not in ("ppo", "eval_loads"))),
}


def _positive_int(value: Any, where: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value <= 0:
        raise ValueError(f"{where}: expected a positive integer, got {value!r}")
    return value


def load_config(path: str | Path, overrides: dict[str, Any] | None = None, env_id: str | None = None) -> dict[str, Any]:
    """The training YAML at ``path`` with ``overrides`` (``{"hyperparams.n_steps": 64}`` style), checked (``env_id``:
    the env the caller trains, which the YAML must name): a ValueError names the file and the key."""
    from triplanar.yaml_input import load_file
    config = load_file(path)
    if config is None:
        config = {}
    if not isinstance(config, dict):
        raise ValueError(f"{path}: expected a mapping of keys ({', '.join(CONFIG_KEYS)}), got {type(config).__name__}")
    apply_overrides(config, overrides or {}, str(path))
    check_config(config, str(path), env_id)
    return config


def apply_overrides(config: dict[str, Any], overrides: dict[str, Any], source: str) -> dict[str, Any]:
    """``config`` with each ``"a.b.c": value`` of ``overrides`` set in it (in place; returned)."""
    for key, value in overrides.items():
        node = config
        *parents, leaf = key.split(".")
        for parent in parents:
            node = node.setdefault(parent, {})
            if not isinstance(node, dict):
                raise ValueError(f"{source}: override {key}: {parent} is not a mapping")
        node[leaf] = value
    return config


def env_id_of(config: dict[str, Any], expected: str | None = None) -> str:
    """The config's env id (v0 when it names none, unless ``expected``)."""
    return config.get("env_id", expected or V0)


def _check_sections(config: dict[str, Any], source: str, profile: Profile) -> None:
    for key in config:
        if key not in profile.keys:
            raise ValueError(f"{source}: unknown key {key!r}; known keys: {', '.join(profile.keys)}")
    for section in ("env", "normalize", "hyperparams", "train", "ppo"):
        if not isinstance(config.get(section) or {}, dict):
            raise ValueError(f"{source}: {section}: expected a mapping, got {config[section]!r}")
    for key, value in (config.get("train") or {}).items():
        if key not in TRAIN_KEYS:
            raise ValueError(f"{source}: unknown key train.{key}; known keys: {', '.join(TRAIN_KEYS)}")
        _positive_int(value, f"{source}: train.{key}")
    if "n_envs" in config:
        check_n_envs(config["n_envs"], f"{source}: n_envs")
    if "ppo" in config and ("policy" in config or "hyperparams" in config):
        raise ValueError(f"{source}: ppo: give either ppo (policy inside) or policy and hyperparams, not both")
    check_hyperparams(config.get("ppo"), f"{source}: ppo", extra=("policy",))
    check_hyperparams(config.get("hyperparams"), f"{source}: hyperparams")
    check_normalize(config.get("normalize"), f"{source}: normalize")


def check_config(config: dict[str, Any], source: str = "config", env_id: str | None = None) -> None:
    """Refuse unknown keys and values that would fail only after training starts (ValueError naming the key)."""
    named = env_id_of(config, env_id)
    if not isinstance(named, str) or named not in PROFILES:
        raise ValueError(f"{source}: env_id: expected one of {', '.join(PROFILES)}, got {named!r:.80}")
    if env_id is not None and named != env_id:
        yamls = ", ".join(f"agents/{p.name}" for p in PROFILES[env_id].configs.values())
        raise ValueError(f"{source}: env_id is {named!r}: this run trains {env_id} (give --env {named} to train on "
                         f"it; {env_id} trains with {yamls})")
    _check_sections(config, source, PROFILES[named])
    algo = config.get("algo", "ppo")
    if not isinstance(algo, str) or algo not in ALGOS:
        raise ValueError(f"{source}: algo: expected one of {', '.join(ALGOS)}, got {algo!r}")
    if named == V0 and algo != "ppo":
        raise ValueError(f"{source}: algo: {algo!r} trains on TriPlanarShear-v1 (v0 trains algo ppo)")
    policy = policy_of(config)
    if named == V1 and "policy" in config and policy != POLICIES[algo]:
        raise ValueError(f"{source}: policy: expected {POLICIES[algo]!r} for algo {algo!r}, got {policy!r:.80}")
    try:   # the env's own checks, on a batch of one (no specimen is drawn)
        make_vec_env({**config, "n_envs": 1}, seed=0, env_id=named, check_only=True)
    except (TypeError, ValueError) as err:
        raise ValueError(f"{source}: env: {err}") from None
    if "eval_loads" in config:
        loads = config["eval_loads"]
        if not isinstance(loads, list) or not loads or any(
                isinstance(f, bool) or not isinstance(f, (int, float)) or not np.isfinite(f) or f <= 0 for f in loads):
            raise ValueError(f"{source}: eval_loads: expected a non-empty list of positive loads in N, got {loads!r}")


def policy_of(config: dict[str, Any]) -> Any:
    """The SB3 policy of ``config`` (``policy``, or ``ppo.policy``; default by ``algo``)."""
    default = POLICIES[config.get("algo", "ppo")]
    return (config.get("ppo") or {}).get("policy", default) if "ppo" in config else config.get("policy", default)


def hyperparams_of(config: dict[str, Any]) -> dict[str, Any]:
    """The algorithm's keyword arguments (``hyperparams``, or ``ppo`` without its ``policy``)."""
    if "ppo" in config:
        return {k: v for k, v in (config.get("ppo") or {}).items() if k != "policy"}
    return dict(config.get("hyperparams") or {})


def algo_class(algo: str) -> Any:
    if algo == "recurrent":
        from sb3_contrib import RecurrentPPO
        return RecurrentPPO
    from stable_baselines3 import PPO
    return PPO


def shear_config(config: dict[str, Any]) -> Any:
    """v0's ``ShearConfig`` of ``config``'s ``env``."""
    from envs.triplanar_shear import ShearConfig, make_config
    return make_config(ShearConfig(), **(config.get("env") or {}))


def eval_loads(config: dict[str, Any]) -> list[float]:
    """v0: the loads (N) of each evaluation."""
    return [float(f) for f in config.get("eval_loads", shear_config(config).load_levels)]


def frame_stack_of(config: dict[str, Any]) -> int:
    return int((config.get("env") or {}).get("frame_stack", 1))


def single_env_kwargs(config: dict[str, Any]) -> dict[str, Any]:
    """v1: the single env's arguments (evaluation episodes): the batch's own keys left out."""
    return {k: v for k, v in (config.get("env") or {}).items() if k not in BATCH_KEYS and k not in EXTRA_INPUTS
            and k not in DEVIATION_OPTIONS}


def extra_input_of(config: dict[str, Any]) -> str | None:
    """The privileged input (of :data:`EXTRA_INPUTS`) the run's policy sees appended to its frame stack, if any."""
    env = config.get("env") or {}
    return next((key for key in EXTRA_INPUTS if env.get(key, False)), None)


def make_vec_env(config: dict[str, Any], seed: int, env_id: str | None = None, check_only: bool = False) -> Any:
    """The training env of ``config``: ``n_envs`` batched envs as one SB3 ``VecEnv``, env ``i`` seeded ``seed + i``
    (``check_only``: the arguments checked, no SB3 adapter built)."""
    n_envs = int(config.get("n_envs", 16))
    if env_id_of(config, env_id) == V0:
        shear = shear_config(config)
        if check_only:
            return shear
        from .sb3_vec_env import ShearSB3VecEnv
        return ShearSB3VecEnv(n_envs, shear, seed=seed)
    from envs.core import ShearConfig, make_config
    from envs.triplanar_shear_v1 import BENCH_FIELDS, BenchConfig
    from envs.vector_v1 import BenchBatch
    env = dict(config.get("env") or {})
    known = ({f.name for f in fields(ShearConfig)} | set(BENCH_FIELDS) | set(BATCH_KEYS) | set(EXTRA_INPUTS)
             | set(DEVIATION_OPTIONS))
    unknown = sorted(set(env) - known)
    if unknown:
        raise ValueError(f"unknown env argument(s) {', '.join(unknown)}; known: {', '.join(sorted(known))}")
    extras = {key: _privileged_option(env.pop(key, False), config.get("algo", "ppo"), key) for key in EXTRA_INPUTS}
    if all(extras.values()):
        raise ValueError(f"{PRIVILEGED} and {REFERENCE_DEVIATION}: give one of them, not both")
    bias = _deviation_bias(env.pop(DEVIATION_BIAS, 0.0), extras[REFERENCE_DEVIATION])
    estimator = _deviation_estimator(env.pop(DEVIATION_ESTIMATOR, None), extras[REFERENCE_DEVIATION], bias)
    with_state = _flag_with(env.pop(ESTIMATOR_STATE, False), ESTIMATOR_STATE, estimator, DEVIATION_ESTIMATOR)
    bank_size = _deviation_bank(env.pop(DEVIATION_BANK, None), extras[REFERENCE_DEVIATION], bias, estimator)
    tracker = _flag_with(env.pop(DEVIATION_TRACKER, False), DEVIATION_TRACKER, bank_size, DEVIATION_BANK)
    batch_kwargs = {k: env.pop(k) for k in BATCH_KEYS if k in env}
    bench = BenchConfig(**{k: env.pop(k) for k in BENCH_FIELDS if k in env})
    batch = BenchBatch(n_envs, make_config(None, **env), bench, **batch_kwargs)
    if check_only:
        return batch
    from .sb3_vec_env import DeviationSB3VecEnv, PrivilegedSB3VecEnv, ShearSB3VecEnv
    if extras[REFERENCE_DEVIATION]:
        return DeviationSB3VecEnv(batch.num_envs, seed=seed, batch=batch, bias_mm=bias, estimator=estimator,
                                  with_state=with_state, bank_size=bank_size, tracker=tracker)
    return (PrivilegedSB3VecEnv if extras[PRIVILEGED] else ShearSB3VecEnv)(batch.num_envs, seed=seed, batch=batch)


def deviation_estimator_of(config: dict[str, Any]) -> str | None:
    """The estimator folder a reference-deviation run was trained on (``env.reference_deviation_estimator``), if any."""
    return (config.get("env") or {}).get(DEVIATION_ESTIMATOR)


def deviation_bank_of(config: dict[str, Any]) -> int | None:
    """The specimen bank's size a reference-deviation run was trained on (``env.reference_deviation_bank``), if any."""
    return (config.get("env") or {}).get(DEVIATION_BANK)


def _deviation_bank(value: Any, deviation: bool, bias: float, estimator: str | None) -> int | None:
    """``env.reference_deviation_bank``, checked: a positive integer, only with ``reference_deviation``, without a
    bias or an estimator (the bank's estimate is the input)."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise ValueError(f"{DEVIATION_BANK}: expected a number of hypotheses (an integer >= 1), got {value!r:.80}")
    if not deviation or bias or estimator is not None:
        raise ValueError(f"{DEVIATION_BANK}: needs {REFERENCE_DEVIATION}: true, no {DEVIATION_BIAS} and no "
                         f"{DEVIATION_ESTIMATOR}")
    return value


def deviation_tracker_of(config: dict[str, Any]) -> bool:
    """Whether a bank-trained run was trained on its bank's Gauss-Newton tracker
    (``env.reference_deviation_tracker``)."""
    return bool((config.get("env") or {}).get(DEVIATION_TRACKER, False))


def estimator_state_of(config: dict[str, Any]) -> bool:
    """Whether the run's policy reads its estimator's GRU state too (``env.reference_deviation_estimator_state``)."""
    return bool((config.get("env") or {}).get(ESTIMATOR_STATE, False))


def _flag_with(value: Any, key: str, needed: Any, needed_key: str) -> bool:
    """A true/false env option ``key`` that may be true only when ``needed_key`` is given (``needed`` not None)."""
    if not isinstance(value, bool) or (value and needed is None):
        raise ValueError(f"{key}: expected true or false, and true only with {needed_key}, got {value!r:.80}")
    return value


def _deviation_estimator(value: Any, deviation: bool, bias: float) -> str | None:
    """``env.reference_deviation_estimator``, checked: an existing folder's path, only with ``reference_deviation``
    and without a bias (the estimate brings its own error)."""
    if value is None:
        return None
    if not isinstance(value, str) or not Path(value).is_dir():
        raise ValueError(f"{DEVIATION_ESTIMATOR}: expected an estimator folder, got {value!r:.200}")
    if not deviation or bias:
        raise ValueError(f"{DEVIATION_ESTIMATOR}: needs {REFERENCE_DEVIATION}: true and no {DEVIATION_BIAS}")
    return value


def _deviation_bias(value: Any, deviation: bool) -> float:
    """``env.reference_deviation_bias_mm``, checked: a finite number >= 0, and only with ``reference_deviation``."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value) or value < 0:
        raise ValueError(f"{DEVIATION_BIAS}: expected a number of mm >= 0, got {value!r:.80}")
    if value and not deviation:
        raise ValueError(f"{DEVIATION_BIAS}: a bias of the reference deviation needs {REFERENCE_DEVIATION}: true")
    return float(value)


def _privileged_option(value: Any, algo: Any, key: str = PRIVILEGED) -> bool:
    """``env.privileged`` (or another of :data:`EXTRA_INPUTS`, ``key``), checked: a boolean, and only for the
    frame-stack PPO (whose policy appends the input)."""
    if not isinstance(value, bool):
        raise ValueError(f"{key}: expected true or false, got {value!r:.80}")
    if value and algo != "ppo":
        raise ValueError(f"{key}: the privileged input is for algo ppo (frame stack), not {algo!r}")
    return value


def default_eval_freq(config: dict[str, Any], timesteps: int) -> int:
    """v1's steps between the learning curve's evaluations when nobody set them: ``EVALUATIONS`` points over the
    run, at least one rollout (``n_envs * n_steps``) apart."""
    rollout = int(config.get("n_envs", 16)) * int(hyperparams_of(config).get("n_steps", 2048))
    return max(rollout, timesteps // EVALUATIONS)


def train_settings(config: dict[str, Any], timesteps: int | None = None) -> dict[str, int]:
    """``train`` with the env's defaults filled in (``timesteps``: over the YAML's)."""
    profile = PROFILES[env_id_of(config)]
    train = {"total_timesteps": profile.total_timesteps, "checkpoint_freq": profile.checkpoint_freq,
             "torch_threads": 1, **(config.get("train") or {})}
    if timesteps:
        train["total_timesteps"] = int(timesteps)
    if "eval_freq" not in train:
        train["eval_freq"] = profile.eval_freq or default_eval_freq(config, train["total_timesteps"])
    return train

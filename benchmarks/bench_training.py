"""Training speed of robust PPO on TriPlanarShear-v1 against CartPole-v1, in one process:
``PYTHONPATH=. python benchmarks/bench_training.py [--steps 16384] [--repeats 2] [--json out.json]``.

Both run stable-baselines3's PPO with the same settings (``agents/ppo.yaml``'s ``ppo`` section and ``n_envs``), one
torch thread, ``VecNormalize`` as training uses it, for ``--steps`` env steps after a warm-up of one rollout:

* ``v1``: the robust training env, ``TriPlanarShear-v1`` in bench mode with unknown specimens (``randomize``) and a
  4-frame stack, batched (:func:`agents.sb3_vec_env.bench_vec_env`), with the start bank ``agents/robust.yaml``
  sets (and once without it);
* ``cartpole``: ``CartPole-v1`` in stable-baselines3's ``DummyVecEnv``.

Runs are interleaved and the best of ``--repeats`` is kept (the machine is shared: the best run is the least
disturbed one). Each run is timed twice: wall clock, and the process's CPU time (torch has one thread and the envs run
in the process, so CPU time is the work done; other load on the machine inflates wall time far more than CPU time).
Prints env-steps/s by both clocks and the ratio v1 / CartPole by both.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any, Callable

from triplanar.atomic import write_atomic

ROOT = Path(__file__).resolve().parents[1]


def _ppo_settings() -> tuple[dict[str, Any], int]:
    from agents.train_config import load_config
    config = load_config(ROOT / "agents" / "ppo.yaml", None, "TriPlanarShear-v0")
    return dict(config["ppo"]), int(config["n_envs"])


def _v1_env(n_envs: int, seed: int, start_bank: int) -> Any:
    from agents.sb3_vec_env import bench_vec_env
    return bench_vec_env(n_envs, seed, frame_stack=4, start_bank=start_bank, observation_mode="bench",
                         randomize=True)


def _cartpole_env(n_envs: int, seed: int) -> Any:
    import gymnasium as gym
    from stable_baselines3.common.vec_env import DummyVecEnv
    venv = DummyVecEnv([lambda: gym.make("CartPole-v1") for _ in range(n_envs)])
    venv.seed(seed)
    return venv


def train_rate(make_env: Callable[[], Any], steps: int) -> tuple[float, float]:
    """Env-steps/s of PPO's ``learn`` for ``steps`` steps (rollouts and updates), after one warm-up rollout, by the
    wall clock and by the process's CPU time."""
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecNormalize
    torch.set_num_threads(1)
    ppo, _ = _ppo_settings()
    policy = ppo.pop("policy", "MlpPolicy")
    venv = VecNormalize(make_env(), norm_obs=True, norm_reward=True, clip_obs=10.0, gamma=ppo.get("gamma", 0.99))
    model = PPO(policy, venv, seed=0, device="cpu", verbose=0, **ppo)
    warm = model.n_steps * venv.num_envs
    model.learn(total_timesteps=warm)
    t0, c0 = time.perf_counter(), time.process_time()
    model.learn(total_timesteps=steps, reset_num_timesteps=False)
    done = model.num_timesteps - warm
    return done / (time.perf_counter() - t0), done / (time.process_time() - c0)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=16_384, help="timed env steps per run (after a warm-up)")
    parser.add_argument("--repeats", type=int, default=2)
    parser.add_argument("--start-bank", type=int, default=None,
                        help="start bank of the v1 run (default: agents/robust.yaml's)")
    parser.add_argument("--json", help="also write the numbers here")
    args = parser.parse_args()
    from agents.train_config import load_config
    bank = args.start_bank if args.start_bank is not None else \
        int(load_config(ROOT / "agents" / "robust.yaml", None, "TriPlanarShear-v1")["env"].get("start_bank", 0))
    _, n_envs = _ppo_settings()
    setups = {"cartpole": lambda: _cartpole_env(n_envs, 0),
              "v1_robust": lambda: _v1_env(n_envs, 0, bank),
              "v1_robust_no_bank": lambda: _v1_env(n_envs, 0, 0)}
    best: dict[str, float] = {}
    for _ in range(args.repeats):
        for name, make in setups.items():
            wall, cpu = train_rate(make, args.steps)
            best[f"{name}_wall"] = max(best.get(f"{name}_wall", 0.0), wall)
            best[f"{name}_cpu"] = max(best.get(f"{name}_cpu", 0.0), cpu)
    result: dict[str, Any] = {f"{key}_env_steps_per_s": rate for key, rate in best.items()}
    for clock in ("wall", "cpu"):
        for v1 in ("v1_robust", "v1_robust_no_bank"):
            result[f"{v1}_over_cartpole_{clock}"] = best[f"{v1}_{clock}"] / best[f"cartpole_{clock}"]
    result.update({"n_envs": n_envs, "start_bank": bank, "steps": args.steps, "repeats": args.repeats})
    for key, value in result.items():
        print(f"{key}: {value:,.2f}" if isinstance(value, float) else f"{key}: {value}")
    if args.json:
        write_atomic(args.json, lambda tmp: tmp.write_text(json.dumps(result, indent=2)))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

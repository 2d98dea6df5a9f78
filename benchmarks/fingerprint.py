"""Fingerprint the model's results, to prove that a change of the code's structure changes no result.

Records the six paper traces (cases A, B, C at 27.8 and 55.6 N), four traces with effects (rate friction, a
rising actuator, tilted planes, a user force through the Python wrench), 3000 random-action steps of
``TriPlanarShear-v0`` and 2000 of ``TriPlanarShear-v1`` in each observation mode with unknown specimens (all
seeded), then compares them with an earlier record::

    .venv/bin/python benchmarks/fingerprint.py --save /tmp/before.npz     # before the change
    .venv/bin/python benchmarks/fingerprint.py --compare /tmp/before.npz  # after it

Prints, per record, whether it is bitwise identical, else the largest difference (positions in m).
"""

from __future__ import annotations

import argparse
import sys

import numpy as np


def _traces() -> dict[str, np.ndarray]:
    from triplanar import Effect, paper_model, simulate
    from triplanar.effects import make_effect

    class _Drag(Effect):  # a user force: exercises the Python wrench path
        name = "_fingerprint_drag"
        parameters = {}

        def wrench(self, t, state):
            return -2.0 * state.velocity, np.zeros(3)

    out = {}
    runs = [(f"case_{case}_{force:g}N", paper_model(case, force)) for case in "ABC" for force in (27.8, 55.6)]
    runs += [("rate_friction", paper_model("B", 35.0, effects=[make_effect("rate_friction:a=0.2")])),
             ("actuator_rise", paper_model("A", 35.0, effects=[make_effect("actuator_rise:tau_s=0.05")])),
             ("plane_tilt", paper_model("A", 40.0, effects=[make_effect("plane_tilt:dip2_deg=1,dip_dir3_deg=5")])),
             ("user_force", paper_model("A", 40.0, effects=[_Drag()]))]
    for name, model in runs:
        result = simulate(model)
        out[f"{name}/t"] = result.t
        out[f"{name}/y"] = result.y
        out[f"{name}/aux"] = result.aux
        out[f"{name}/status"] = np.array([result.status.label])
    return out


# Info keys a record leaves out: v0's step info gained its episode's draw (so that reset and step info have the same
# keys); the draw is the reset's, not a result of the step, and the records keep their columns.
UNRECORDED_INFO = {"TriPlanarShear-v0": ("tip_friction_deg",)}


def _env_steps(env_id: str = "TriPlanarShear-v0", n_steps: int = 3000, prefix: str = "env",
               **kwargs) -> dict[str, np.ndarray]:
    import gymnasium as gym
    from envs import v0_on_purpose  # (importing envs registers the environments)

    with v0_on_purpose():
        env = gym.make(env_id, **kwargs)
    rng = np.random.default_rng(2026)
    obs_rows, rewards, ends, numbers = [], [], [], []
    obs, info = env.reset(seed=7)
    episode = 0
    for _ in range(n_steps):
        obs, reward, terminated, truncated, info = env.step(rng.uniform(-1, 1, 2).astype(np.float32))
        obs_rows.append(obs)
        rewards.append(reward)
        ends.append((terminated, truncated))
        numbers.append([v for k, v in sorted(info.items())
                        if isinstance(v, float) and k not in UNRECORDED_INFO.get(env_id, ())])
        if terminated or truncated:
            episode += 1
            obs, info = env.reset(seed=7 + episode)
    return {f"{prefix}/obs": np.array(obs_rows), f"{prefix}/reward": np.array(rewards),
            f"{prefix}/ends": np.array(ends), f"{prefix}/info": np.array(numbers)}


def record() -> dict[str, np.ndarray]:
    v1 = {f"v1_{mode}": _env_steps("TriPlanarShear-v1", 2000, f"v1_{mode}", observation_mode=mode, randomize=True)
          for mode in ("state", "bench")}
    return {**_traces(), **_env_steps(), **v1["v1_state"], **v1["v1_bench"]}


def compare(before: dict[str, np.ndarray], after: dict[str, np.ndarray]) -> bool:
    same = True
    for key in sorted(before):
        a, b = before[key], after.get(key)
        if b is None or a.shape != b.shape:
            print(f"{key}: DIFFERENT SHAPE {a.shape} -> {None if b is None else b.shape}")
            same = False
        elif a.dtype.kind in "fc" and a.tobytes() != b.tobytes():
            print(f"{key}: differs, max |change| {np.nanmax(np.abs(a - b)):.3e}")
            same = False
        elif a.dtype.kind not in "fc" and not np.array_equal(a, b):
            print(f"{key}: differs ({a.ravel()[:3]} -> {b.ravel()[:3]})")
            same = False
        else:
            print(f"{key}: bitwise identical")
    return same


def save_or_compare(description: str, kind: str) -> argparse.Namespace:
    """The command line of a fingerprint (this one, ``workbench_fingerprint.py``): ``--save FILE`` or ``--compare
    FILE``, a ``kind`` file."""
    parser = argparse.ArgumentParser(description=description)
    group = parser.add_mutually_exclusive_group(required=True)
    group.add_argument("--save", help=f"write the fingerprint to this {kind} file")
    group.add_argument("--compare", help=f"compare with the fingerprint in this {kind} file")
    return parser.parse_args()


def main() -> int:
    args = save_or_compare(__doc__.splitlines()[0], ".npz")
    current = record()
    if args.save:
        np.savez(args.save, **current)
        print(f"wrote {len(current)} records to {args.save}")
        return 0
    with np.load(args.compare) as saved:
        before = {k: saved[k] for k in saved.files}
    return 0 if compare(before, current) else 1


if __name__ == "__main__":
    sys.exit(main())

"""How far the block drifts from its case-C path during ``mpc``'s start, for start excitations replayed alone (no
estimator, no plan): ``MPCController.start_command`` for start settings of ``mpc``, its last command held for 4
periods more.

``PYTHONPATH=. python benchmarks/start_drift.py [--benches 60]``: for each excitation, on the first tuning benches
(stream ``agents.heldout.TUNING_SEED``) the episodes that end within those 12 periods (lift-off, departure from a
plane), the same on the first 12 of them with a 12 deg tip at 33 N (the seventh round's risky case), and the mean
distance to the case-C path at periods 4, 8, 10 and 12 and over the 12 (``docs/notes/mpc-tuning-rounds.md``, eighth round).
"""

from __future__ import annotations

import argparse
from dataclasses import replace

import numpy as np

from agents.heldout import TUNING_SEED, random_benches
from agents.mpc import MPCController
from envs.core import make_config
from envs.triplanar_shear_v1 import TriPlanarShearV1Env

HOLD = 4  # periods the start's last command is held after it
# MPCController settings of the start: nominal; mpc's own (-2 then +2 mm); +2 then -2; +1 then +3; 0 then +4; 0 then +3
EXCITATIONS = ({"start_thrust": 0.0, "start_offset_m": 0.0}, {}, {"start_offset_m": 0.002},
               {"start_centre_m": 0.002, "start_offset_m": -0.001}, {"start_centre_m": 0.002},
               {"start_centre_m": 0.0015, "start_offset_m": -0.0015})


def replay(bench, seed: int, start: MPCController) -> tuple[list[float], str]:
    """The distances (mm) of each period under ``start``'s commands (:meth:`MPCController.start_command`) and how
    the replay ended (``ok`` if it ran all periods)."""
    env = TriPlanarShearV1Env()
    env.reset(seed=seed, options={"bench": bench})
    distances = []
    for period in range(1, start.start_periods + HOLD + 1):
        action = start.start_command(min(period, start.start_periods), env.config).astype(np.float32)
        _, _, terminated, _, info = env.step(action)
        distances.append(info["distance_mm"])
        if terminated:
            return distances, info["reason"]
    return distances, "ok"


def describe(start: MPCController) -> str:
    """The two blocks' tip offsets (mm) and thrust steps (load levels), from the commands themselves."""
    config = make_config(None)
    blocks = [start.start_command(1 + k * start.block, config) for k in (0, 1)]
    offsets = [1e3 * (a[1] * config.offset_range_m - config.tip_offset_m) for a in blocks]
    thrusts = [0.5 * (a[0] + 1.0) * config.thrust_scale - 1.0 for a in blocks]
    return f"{offsets[0]:+.0f}, {offsets[1]:+.0f} | {thrusts[0]:+.1f}, {thrusts[1]:+.1f}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--benches", type=int, default=60)
    args = parser.parse_args()
    benches = random_benches(args.benches, TUNING_SEED)
    print("| tip offsets, mm | thrust steps | ended early | ended early, 12 deg tip at 33 N | distance at periods 4, 8, "
          "10, 12, mm | mean over the 12, mm |")
    print("|---|---|---|---|---|---|")
    for settings in EXCITATIONS:
        start = MPCController(**settings)
        runs = [replay(b, i, start) for i, b in enumerate(benches)]
        kept = np.array([d for d, how in runs if how == "ok"])
        risky = [replay(replace(b, load_N=33.0, specimen=replace(b.specimen, tip_friction_deg=12.0)), i, start)
                 for i, b in enumerate(benches[:12])]
        print(f"| {describe(start)} | {len(runs) - len(kept)}/{len(runs)} | {sum(how != 'ok' for _, how in risky)}/"
              f"{len(risky)} | " + " ".join(f"{v:.2f}" for v in kept[:, [3, 7, 9, 11]].mean(axis=0))
              + f" | {kept.mean():.3f} |")


if __name__ == "__main__":
    main()

"""How far the block drifts from its case-C path during ``mpc``'s start, for start excitations replayed alone (no
estimator, no plan): the thrust and tip offset of each of the start's two 4-period blocks, held for 4 periods more.

``PYTHONPATH=. python benchmarks/start_drift.py [--benches 60]``: for each excitation, on the first tuning benches
(stream ``agents.heldout.TUNING_SEED``) the episodes that end within those 12 periods (lift-off, departure from a
plane), the same on the first 12 of them with a 12 deg tip at 33 N (the seventh round's risky case), and the mean
distance to the case-C path at periods 4, 8, 10 and 12 and over the 12 (``docs/actuator-study.md``, eighth round).
"""

from __future__ import annotations

import argparse
from dataclasses import replace

import numpy as np

from agents.heldout import TUNING_SEED, random_benches
from envs.triplanar_shear_v1 import TriPlanarShearV1Env

BLOCK, HOLD = 4, 4
# (first block's tip offset mm, second's, first block's thrust step in load levels, second's)
EXCITATIONS = ((0, 0, 0.0, 0.0), (-2, 2, 0.1, -0.1), (2, -2, 0.1, -0.1), (1, 3, 0.1, -0.1), (0, 4, 0.1, -0.1),
               (0, 3, 0.1, -0.1))


def replay(bench, seed: int, excitation: tuple) -> tuple[list[float], str]:
    """The distances (mm) of each period and how the replay ended (``ok`` if it ran all periods)."""
    o1, o2, t1, t2 = excitation
    env = TriPlanarShearV1Env()
    env.reset(seed=seed, options={"bench": bench})
    scale, span = env.config.thrust_scale, env.config.offset_range_m
    nominal = np.array([2.0 / scale - 1.0, env.config.tip_offset_m / span])
    distances = []
    for period in range(2 * BLOCK + HOLD):
        first = period < BLOCK
        if period < 2 * BLOCK:
            step = np.array([2.0 * (t1 if first else t2) / scale, 1e-3 * (o1 if first else o2) / span])
            action = np.clip(nominal + step, -1.0, 1.0).astype(np.float32)
        _, _, terminated, _, info = env.step(action)
        distances.append(info["distance_mm"])
        if terminated:
            return distances, info["reason"]
    return distances, "ok"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--benches", type=int, default=60)
    args = parser.parse_args()
    benches = random_benches(args.benches, TUNING_SEED)
    print("| tip offsets, mm | thrust steps | ended early | ended early, 12 deg tip at 33 N | distance at periods 4, 8, "
          "10, 12, mm | mean over the 12, mm |")
    print("|---|---|---|---|---|---|")
    for excitation in EXCITATIONS:
        runs = [replay(b, i, excitation) for i, b in enumerate(benches)]
        kept = np.array([d for d, how in runs if how == "ok"])
        risky = [replay(replace(b, load_N=33.0, specimen=replace(b.specimen, tip_friction_deg=12.0)), i, excitation)
                 for i, b in enumerate(benches[:12])]
        print(f"| {excitation[0]:+d}, {excitation[1]:+d} | {excitation[2]:+.1f}, {excitation[3]:+.1f} | "
              f"{len(runs) - len(kept)}/{len(runs)} | {sum(how != 'ok' for _, how in risky)}/{len(risky)} | "
              + " ".join(f"{v:.2f}" for v in kept[:, [3, 7, 9, 11]].mean(axis=0)) + f" | {kept.mean():.3f} |")


if __name__ == "__main__":
    main()

"""How far a student of ``limit`` can get: ``limit`` itself on the student's judge benches, and how much of
``limit``'s action is its planner's own randomness, which no student can learn from any input.

``PYTHONPATH=. python -m experiments.privileged_bound --judge 100`` runs ``limit`` on the benches that
``experiments.train_student --judge 100`` runs a student on (the same draws and noise seeds) and prints the same
statistics. ``--label-noise K [--first 60000]`` rolls ``limit`` out on ``K`` draws of the tuning stream from
``--first`` (a range no label round used; ``--limit samples=256``: both with another search; ``--limit`` sets the
judged ``limit`` too) with a second ``limit`` of another planner seed alongside it, shown the
same observations and true states: the two actions in the same state differ only by the cross-entropy search's
samples. Half their mean squared difference is the variance of that noise in one label (two independent draws),
printed per span of decision index beside the labels' spread about their mean: the share of the labels' variance
that is search noise bounds the share any student can explain (docs/notes/student-experiments.md, finding 8).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from typing import Any

import numpy as np

from agents.heldout import TUNING_SEED
from agents.limit import LimitController
from envs.triplanar_shear_v1 import TriPlanarShearV1Env

from .distill_labels import bench_of_draw, expert_pairs
from .student_diagnosis import SPANS
from .train_student import JUDGE_DRAWS, judge_controller


def twin_actions(draw: int, seeds: tuple[int, int] = (0, 1), **limit_settings: Any
                 ) -> tuple[np.ndarray, np.ndarray] | None:
    """(driving ``limit``'s actions, the twin's actions in the same states), (T, 2) each, on draw ``draw`` of the
    tuning stream (None if friction holds it at rest); sensor noise seeded by the draw; ``limit_settings``: both
    limits' other fields (default: as shipped)."""
    bench = bench_of_draw(TUNING_SEED, draw, {})
    if bench is None:
        return None
    env = TriPlanarShearV1Env()
    obs, _ = env.reset(seed=draw, options={"bench": bench})
    pair = [LimitController(seed=seed, **limit_settings) for seed in seeds]
    for limit in pair:
        limit.bind(env)
        limit.reset(bench.load_N, env.config)
    ran, twin = [], []
    while True:
        action, other = (np.asarray(limit.act(obs), dtype=np.float64) for limit in pair)
        ran.append(action)
        twin.append(other)
        obs, _, terminated, truncated, _ = env.step(action.astype(np.float32))
        if terminated or truncated:
            return np.array(ran), np.array(twin)


def label_noise(first: int, k: int, **limit_settings: Any) -> dict:
    """Per span of decision index (:data:`experiments.student_diagnosis.SPANS`): the decisions, the labels' spread
    (RMS about the span's mean action), the search noise in one label (RMS of the twins' difference over sqrt 2)
    and the noise's share of the labels' variance, each with a 95 % interval (:func:`span_figures`); the same over
    all decisions. ``limit_settings``: both limits' fields (default: as shipped)."""
    if first < JUDGE_DRAWS or k < 1:
        raise ValueError(f"--first must be >= {JUDGE_DRAWS} (the judge's draws stay unlabelled) and K >= 1, got "
                         f"{first}, {k}")
    episodes = []
    start = time.process_time()
    for draw in range(first, first + k):
        pair = twin_actions(draw, **limit_settings)
        if pair is not None:
            episodes.append(pair)
    out = {"limit": limit_settings, "episodes_drawn": k, "episodes": len(episodes),
           "decisions": sum(len(ran) for ran, _ in episodes), "cpu_s": time.process_time() - start, "spans": []}
    for lo, hi in SPANS + ((0, 10_000),):
        parts = [(ran[lo:hi], twin[lo:hi]) for ran, twin in episodes if len(ran) > lo]
        if parts:
            out["spans"].append({"decisions": [lo, hi], **span_figures(parts)})
    return out


def span_figures(parts: list[tuple[np.ndarray, np.ndarray]], resamples: int = 2000) -> dict[str, Any]:
    """The figures of :func:`label_noise` on episodes' (ran, twin) actions, and their 95 % intervals from a
    bootstrap over the episodes (a seeded generator: the same figures every run)."""
    def figures(chosen: list[int]) -> tuple[float, float, float]:
        ran = np.concatenate([parts[c][0] for c in chosen])
        twin = np.concatenate([parts[c][1] for c in chosen])
        spread = float(np.sqrt(((ran - ran.mean(axis=0)) ** 2).mean()))
        noise = float(np.sqrt(((ran - twin) ** 2).mean() / 2.0))
        return spread, noise, noise ** 2 / spread ** 2 if spread > 0 else float("nan")
    rng = np.random.default_rng(2008)
    boot = np.array([figures(list(rng.integers(0, len(parts), len(parts)))) for _ in range(resamples)])
    low, high = np.nanpercentile(boot, [2.5, 97.5], axis=0)
    spread, noise, share = figures(list(range(len(parts))))
    return {"episodes": len(parts), "n": int(sum(len(r) for r, _ in parts)), "label_spread": spread,
            "search_noise": noise, "search_noise_95": [float(low[1]), float(high[1])],
            "noise_share_of_variance": share, "noise_share_95": [float(low[2]), float(high[2])]}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m experiments.privileged_bound", description=__doc__.split("\n\n")[0])
    parser.add_argument("--judge", type=int, default=0, metavar="N", help="run limit on the first N judge benches")
    parser.add_argument("--judge-skip", type=int, default=0, metavar="M", help="from the M-th of them")
    parser.add_argument("--label-noise", type=int, default=0, metavar="K", help="twin limits on K draws")
    parser.add_argument("--first", type=int, default=60_000, help="the first draw for --label-noise (default 60000)")
    parser.add_argument("--limit", action="append", default=[], metavar="FIELD=VALUE",
                        help="a LimitController setting of the judged limit and of both twins (repeatable), e.g. samples=256 "
                        "or change_cost=0.01")
    args = parser.parse_args(argv)
    try:
        settings = dict(expert_pairs(args.limit, "limit"))
        if args.judge:
            print(json.dumps(judge_controller(LimitController(**settings), {}, args.judge, args.judge_skip),
                             indent=1))
        if args.label_noise:
            settings.pop("seed", None)   # the twins' seeds are theirs (0 and 1)
            print(json.dumps(label_noise(args.first, args.label_noise, **settings), indent=1))
    except ValueError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Measurements of :mod:`agents.deviation_tracker` (finding 14 of ``docs/notes/student-experiments.md``): ``shadow``
measures its estimate beside a driving ``banked:RUN``; ``judge`` lets it drive finding 11's policy (and ``--truth
FROM,TO`` feeds the true deviation on those decisions instead, to see which part of the episode the estimate's error
costs).

``python -m experiments.gn_tracker shadow --run RUN [--n 20] [--skip 100] [--start 6 --every 4 --chord 2
--rebuild 2] [--budget UNITS]`` and ``python -m experiments.gn_tracker judge --run RUN [--n 100] [--truth FROM,TO]
[--out FILE]`` (the same settings; judge draws of the tuning stream, :func:`experiments.train_student.judge_draws`;
RUN is UNPICKLED: only yours).
"""

from __future__ import annotations

import argparse
import json
import time
from typing import Any

import numpy as np

from agents.deviation_tracker import GaussNewtonTracker, TrackerSettings
from triplanar.atomic import write_atomic


class TruthWindow(GaussNewtonTracker):
    """The tracker, running throughout, whose estimate is replaced by the env's true deviation on decisions
    ``first`` to ``last - 1`` (counted from 0): a diagnostic of where the estimate's error costs."""

    def __init__(self, first: int, last: int, settings: TrackerSettings = TrackerSettings()):
        super().__init__(settings)
        self.first, self.last, self.env = int(first), int(last), None

    def estimate(self, obs: np.ndarray) -> np.ndarray:
        estimate = super().estimate(obs)
        if self.first <= self.periods - 1 < self.last:
            return self.env.unwrapped.reference_deviation()
        return estimate


def tracked_policy(run: str, settings: TrackerSettings, truth: tuple[int, int] | None = None) -> Any:
    """``banked:RUN``'s policy driven by the tracker (or by :class:`TruthWindow`; UNPICKLES ``run``)."""
    from agents.banked_deviation import BankedDeviationPolicy
    if truth is None:
        return BankedDeviationPolicy.load(run, estimator=GaussNewtonTracker(settings), name="ppo_deviation_tracked")
    window = TruthWindow(*truth, settings)

    class TruthFed(BankedDeviationPolicy):
        needs_env = True

        def bind(self, env: Any) -> None:
            window.env = env
    return TruthFed.load(run, estimator=window, name="ppo_deviation_truth_window")


SPANS = ((0, 8), (8, 16), (16, 32), (32, 10_000))   # decision indices


def shadow(run: str, settings: TrackerSettings, n: int, skip: int) -> dict[str, Any]:
    """``banked:RUN`` drives; the tracker follows: both estimates' mean error by span of decisions, the tracker's
    CPU per period (mean, 99th percentile) and counts."""
    from agents.banked_deviation import BankedDeviationPolicy
    from agents.controller_base import play
    from agents.deviation_bank import estimate_error_mm
    from envs.triplanar_shear_v1 import TriPlanarShearV1Env

    from .train_student import judge_draws
    controller = BankedDeviationPolicy.load(run)
    tracker = GaussNewtonTracker(settings)
    rows: list[tuple[int, float, float, float]] = []
    for i, (_, bench) in enumerate(judge_draws(skip + n, {})[skip:]):
        env = TriPlanarShearV1Env()
        obs, _ = env.reset(seed=skip + i, options={"bench": bench})
        tracker.reset(bench.load_N, env.unwrapped.config)
        decision = iter(range(10_000))

        def record(decided_on: np.ndarray, action: np.ndarray) -> None:
            truth = env.unwrapped.reference_deviation()
            started = time.thread_time()
            tracked = tracker.estimate(decided_on)
            tracker.advance(action)
            rows.append((next(decision), estimate_error_mm(controller.estimate, truth),
                         estimate_error_mm(tracked, truth), time.thread_time() - started))

        play(controller, env, obs, bench.load_N, on_decision=record)
    table = np.array(rows)
    units = np.array(tracker.units or [0])
    out: dict[str, Any] = {"run": run, "n": n, "skip": skip, "decisions": len(table), **tracker.counts,
                           "refit_units_per_period_max": int(units.max()),
                           "refit_units_mean_while_refitting": float(units.mean()),
                           "tracker_cpu_mean_ms": 1e3 * float(table[:, 3].mean()),
                           "tracker_cpu_p99_ms": 1e3 * float(np.percentile(table[:, 3], 99))}
    for lo, hi in SPANS:
        span = (table[:, 0] >= lo) & (table[:, 0] < hi)
        out[f"bank_error_mm_{lo}_{min(hi, 999)}"] = float(table[span, 1].mean())
        out[f"tracker_error_mm_{lo}_{min(hi, 999)}"] = float(table[span, 2].mean())
    out["bank_error_mm_all"], out["tracker_error_mm_all"] = float(table[:, 1].mean()), float(table[:, 2].mean())
    return out


def judge(run: str, settings: TrackerSettings, n: int, skip: int, truth: tuple[int, int] | None) -> dict[str, Any]:
    """The tracked policy on the judge draws: :func:`experiments.train_student.judged_stats`, each bench's score."""
    from agents.heldout import FAILURE_SCORE_MM

    from .train_student import judge_outcomes, judged_stats
    controller = tracked_policy(run, settings, truth)
    outcomes = judge_outcomes(controller, {}, n, skip)
    result = judged_stats([outcomes])
    result["bench_scores_mm"] = [o.mimicry_error_mm if o.success else FAILURE_SCORE_MM for o in outcomes]
    result.update(run=run, truth=truth, counts=controller.deviation_bank.counts)
    return result


def main(argv: list[str] | None = None) -> int:
    from dataclasses import asdict

    import torch
    from threadpoolctl import threadpool_limits
    parser = argparse.ArgumentParser(prog="python -m experiments.gn_tracker", description=__doc__.splitlines()[0])
    parser.add_argument("what", choices=["shadow", "judge"])
    parser.add_argument("--run", required=True, help="a reference_deviation PPO run (UNPICKLED: load only yours)")
    parser.add_argument("--n", type=int, default=20)
    parser.add_argument("--skip", type=int, default=0)
    defaults = TrackerSettings()
    for name in ("start", "every", "chord", "rebuild", "budget"):
        parser.add_argument(f"--{name}", type=int, default=getattr(defaults, name))
    parser.add_argument("--truth", metavar="FIRST,LAST", help="judge: the true deviation on these decisions")
    parser.add_argument("--out", help="also write the JSON here")
    args = parser.parse_args(argv)
    try:
        settings = TrackerSettings(args.start, args.every, args.chord, args.rebuild, budget=args.budget)
        truth = tuple(int(v) for v in args.truth.split(",")) if args.truth else None
    except ValueError as error:
        parser.error(str(error))
    if truth is not None and (len(truth) != 2 or not 0 <= truth[0] < truth[1]):
        parser.error(f"--truth: FIRST,LAST with 0 <= FIRST < LAST, got {args.truth!r}")
    if args.n < 1 or args.skip < 0:
        parser.error(f"--n must be >= 1 and --skip >= 0, got {args.n}, {args.skip}")
    torch.set_num_threads(1)
    with threadpool_limits(1):
        if args.what == "shadow":
            result = shadow(args.run, settings, args.n, args.skip)
        else:
            result = judge(args.run, settings, args.n, args.skip, truth)
    result["settings"] = asdict(settings)
    text = json.dumps(result, indent=1, default=float)
    print(text)
    if args.out:
        write_atomic(args.out, lambda tmp: tmp.write_text(text))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

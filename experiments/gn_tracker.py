"""The policies driven by :mod:`agents.deviation_tracker` (finding 14 of ``docs/notes/student-experiments.md``):
``judge`` lets the tracker drive finding 11's policy (and ``--truth FROM,TO`` feeds the true deviation on those
decisions instead, to see which part of the episode the estimate's error costs; ``--worker US`` runs the tracker
behind the decision, :mod:`agents.estimate_worker`). The tracker's estimate and CPU beside a driving
``banked:RUN``: ``benchmarks/bench_banked.py --shadow tracker``.

``python -m experiments.gn_tracker judge --run RUN [--n 100] [--skip 0] [--start 6 --every 4 --chord 2 --rebuild 2]
[--budget UNITS] [--truth FROM,TO | --worker US [--shed-after PERIODS]] [--out FILE]`` (judge draws of the tuning
stream, :func:`experiments.train_student.judge_draws`; RUN is UNPICKLED: only yours).
"""

from __future__ import annotations

import argparse
import json
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


def tracked_policy(run: str, settings: TrackerSettings, truth: tuple[int, int] | None = None,
                   worker_us: float | None = None, shed_after: int | None = None) -> Any:
    """``banked:RUN``'s policy driven by the tracker (behind the decision with a worker of ``worker_us`` of CPU a
    period shedding the tracker ``shed_after`` periods behind, :class:`agents.estimate_worker.EstimateWorker`; or by
    :class:`TruthWindow`; UNPICKLES ``run``)."""
    from agents.banked_deviation import BankedDeviationPolicy
    from agents.estimate_worker import EstimateWorker
    if truth is None:
        tracker = GaussNewtonTracker(settings)
        estimator = tracker if worker_us is None else EstimateWorker(tracker, worker_us, shed_after=shed_after)
        return BankedDeviationPolicy.load(run, estimator=estimator, name="ppo_deviation_tracked")
    window = TruthWindow(*truth, settings)

    class TruthFed(BankedDeviationPolicy):
        needs_env = True

        def bind(self, env: Any) -> None:
            window.env = env
    return TruthFed.load(run, estimator=window, name="ppo_deviation_truth_window")


def judge(run: str, settings: TrackerSettings, n: int, skip: int, truth: tuple[int, int] | None,
          worker_us: float | None = None, shed_after: int | None = None) -> dict[str, Any]:
    """The tracked policy on the judge draws: :func:`experiments.train_student.judged_stats`, each bench's score
    (and with a worker, how many periods old the decisions' estimates were)."""
    from agents.heldout import FAILURE_SCORE_MM

    from .train_student import judge_outcomes, judged_stats
    controller = tracked_policy(run, settings, truth, worker_us, shed_after)
    outcomes = judge_outcomes(controller, {}, n, skip)
    result = judged_stats([outcomes])
    result["bench_scores_mm"] = [o.mimicry_error_mm if o.success else FAILURE_SCORE_MM for o in outcomes]
    result.update(run=run, truth=truth, counts=controller.deviation_bank.counts, worker_us=worker_us,
                  shed_after=shed_after, sheds=getattr(controller.deviation_bank, "sheds", None))
    lags = getattr(controller.deviation_bank, "lags", None)
    if lags:
        result["lag_periods"] = {"mean": float(np.mean(lags)), "p99": float(np.percentile(lags, 99)),
                                 "max": int(np.max(lags))}
    return result


def main(argv: list[str] | None = None) -> int:
    from dataclasses import asdict

    import torch
    from threadpoolctl import threadpool_limits
    parser = argparse.ArgumentParser(prog="python -m experiments.gn_tracker", description=__doc__.splitlines()[0])
    parser.add_argument("what", choices=["judge"])
    parser.add_argument("--run", required=True, help="a reference_deviation PPO run (UNPICKLED: load only yours)")
    parser.add_argument("--n", type=int, default=100)
    parser.add_argument("--skip", type=int, default=0)
    defaults = TrackerSettings()
    for name in ("start", "every", "chord", "rebuild", "budget"):
        parser.add_argument(f"--{name}", type=int, default=getattr(defaults, name))
    parser.add_argument("--truth", metavar="FIRST,LAST", help="judge: the true deviation on these decisions")
    parser.add_argument("--worker", type=float, metavar="US", help="the tracker behind the decision, US microseconds "
                        "of CPU a period (agents.estimate_worker)")
    parser.add_argument("--shed-after", type=int, metavar="PERIODS", help="with --worker: shed the tracker's "
                        "trajectories when the worker is more than PERIODS behind")
    parser.add_argument("--out", help="also write the JSON here")
    args = parser.parse_args(argv)
    try:
        settings = TrackerSettings(args.start, args.every, args.chord, args.rebuild, budget=args.budget)
        truth = tuple(int(v) for v in args.truth.split(",")) if args.truth else None
    except ValueError as error:
        parser.error(str(error))
    if truth is not None and (len(truth) != 2 or not 0 <= truth[0] < truth[1]):
        parser.error(f"--truth: FIRST,LAST with 0 <= FIRST < LAST, got {args.truth!r}")
    if args.worker is not None and (truth is not None or not args.worker > 0):
        parser.error(f"--worker: a positive number of microseconds, and not with --truth, got {args.worker!r}")
    if args.shed_after is not None and (args.worker is None or args.shed_after < 0):
        parser.error(f"--shed-after: a non-negative number of periods, with --worker, got {args.shed_after!r}")
    if args.n < 1 or args.skip < 0:
        parser.error(f"--n must be >= 1 and --skip >= 0, got {args.n}, {args.skip}")
    torch.set_num_threads(1)
    with threadpool_limits(1):
        result = judge(args.run, settings, args.n, args.skip, truth, args.worker, args.shed_after)
    result["settings"] = asdict(settings)
    text = json.dumps(result, indent=1, default=float)
    print(text)
    if args.out:
        write_atomic(args.out, lambda tmp: tmp.write_text(text))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""``banked:RUN``'s decision time and its estimate's error (:class:`agents.banked_deviation.BankedDeviationPolicy`,
finding 13b of ``docs/notes/student-experiments.md``), on the first ``--n`` judge draws, driven by itself.

``PYTHONPATH=. taskset -c 0 python benchmarks/bench_banked.py --run RUN [--n 20] [--skip 0] [--bank-size 16]
[--shadow N,REFINE_EVERY,MOVE_PERIODS]`` prints, as JSON,
the median, 99th percentile and largest thread CPU of a decision (the new measurement weighed, the estimate, the
policy: what stands between a measurement and its command) and of the whole period (the bank's prediction for the
command decided included, which a bench runs in the period's slack), from the controller's own ``info``; and the
estimate's error against the env's true deviation (:meth:`envs.base.ShearEnvBase.reference_deviation`: the mean
over the three contact points of the x-z distance, mm) by span of decisions. The issue's target: 1 ms at the 99th
percentile on one pinned core with nothing else running. numpy's BLAS and torch are held to one thread.

``--shadow`` runs a second estimator beside the controller's, which does not drive (the episodes are the
controller's own): ``N,REFINE_EVERY,MOVE_PERIODS`` a bank of ``N`` hypotheses, ``mpc``'s refinement every
``REFINE_EVERY`` periods (0: none), resample-moves in the first ``MOVE_PERIODS`` periods (0: the whole episode; -1:
none); ``tracker[:START,EVERY,CHORD,REBUILD,BUDGET]`` the Gauss-Newton tracker of
:mod:`agents.deviation_tracker` on a ``--bank-size`` bank (``TrackerSettings()``: refits at once; or these, e.g.
``tracker:6,4,2,2,150``, the bench's ``BENCH_SETTINGS``). Its estimate's error by
the same spans and its thread CPU per period (and a tracker's refit counts and work units), to see what a richer
estimate would know and cost on the same closed loop (findings 13d and 14 of ``docs/notes/student-experiments.md``).
``--skip M`` starts at the M-th judge draw.
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
from threadpoolctl import threadpool_limits

from agents.banked_deviation import BANK_SIZE, BankedDeviationPolicy
from agents.controller_base import play
from agents.deviation_bank import DeviationBank, estimate_error_mm
from agents.deviation_tracker import GaussNewtonTracker, TrackerSettings
from agents.mpc import MPCController
from envs.triplanar_shear_v1 import TriPlanarShearV1Env
from experiments.train_student import judge_draws

SPANS = ((0, 8), (8, 16), (16, 32), (32, 10_000))   # decision indices


def episode(controller: BankedDeviationPolicy, bench, seed: int,
            shadow: DeviationBank | GaussNewtonTracker | None = None) -> list[tuple[float, ...]]:
    """(decision CPU s, period CPU s, the estimate's error mm[, the shadow's error mm, its CPU s]) of every decision
    of one episode."""
    env = TriPlanarShearV1Env()
    obs, _ = env.reset(seed=seed, options={"bench": bench})
    if shadow is not None:
        shadow.reset(bench.load_N, env.unwrapped.config)
    rows = []

    def record(decided_on: np.ndarray, action: np.ndarray) -> None:
        info = controller.info
        truth = env.unwrapped.reference_deviation()
        row: tuple[float, ...] = (info["decision_cpu_s"], info["period_cpu_s"],
                                  estimate_error_mm(controller.estimate, truth))
        if shadow is not None:
            started = time.thread_time()
            estimate = shadow.estimate(decided_on)
            shadow.advance(action)
            row += (estimate_error_mm(estimate, truth), time.thread_time() - started)
        rows.append(row)

    play(controller, env, obs, bench.load_N, on_decision=record)
    return rows


def summary(rows: list[list[tuple[float, float, float]]]) -> dict:
    flat = np.array([r for episode_rows in rows for r in episode_rows])
    out: dict = {"decisions": int(len(flat)), "episodes": len(rows)}
    for k, name in ((0, "decision"), (1, "period")):
        out.update({f"{name}_p50_ms": 1e3 * float(np.percentile(flat[:, k], 50)),
                    f"{name}_p99_ms": 1e3 * float(np.percentile(flat[:, k], 99)),
                    f"{name}_max_ms": 1e3 * float(flat[:, k].max())})
    for prefix, k in (("", 2), ("shadow_", 3)):
        if flat.shape[1] <= k:
            continue
        for lo, hi in SPANS:
            errors = [r[k] for episode_rows in rows for r in episode_rows[lo:hi]]
            out[f"{prefix}error_mm_decisions_{lo}_{min(hi, 999)}"] = float(np.mean(errors)) if errors else None
        out[f"{prefix}error_mm_all"] = float(flat[:, k].mean())
    if flat.shape[1] > 4:
        out.update({"shadow_cpu_mean_ms": 1e3 * float(flat[:, 4].mean()),
                    "shadow_cpu_p99_ms": 1e3 * float(np.percentile(flat[:, 4], 99))})
    return out


def tracker_counts(shadow: DeviationBank | GaussNewtonTracker | None) -> dict:
    """A tracker shadow's refits, accepted steps and replays over the run, and the refit work units done in a
    period's slack (largest, and mean over the periods that refitted; spread refits only); {} for a bank."""
    if not isinstance(shadow, GaussNewtonTracker):
        return {}
    units = np.array(shadow.units or [0])
    return {**shadow.counts, "refit_units_per_period_max": int(units.max()),
            "refit_units_mean_while_refitting": float(units.mean())}


def shadow_bank(text: str | None, bank_size: int = BANK_SIZE) -> DeviationBank | GaussNewtonTracker | None:
    """The ``--shadow`` estimator (module docstring; a tracker on a bank of ``bank_size``), or None."""
    if text is None:
        return None
    if text == "tracker" or text.startswith("tracker:"):
        try:
            settings = TrackerSettings()
            if ":" in text:
                start, every, chord, rebuild, budget = (int(v) for v in text[len("tracker:"):].split(","))
                settings = TrackerSettings(start, every, chord, rebuild, budget=budget)
        except ValueError as error:
            raise ValueError(f"--shadow: expected tracker or tracker:START,EVERY,CHORD,REBUILD,BUDGET (five "
                             f"integers), got {text!r}: {error}") from None
        return GaussNewtonTracker(settings, DeviationBank.of_size(bank_size))
    try:
        size, refine_every, move_periods = (int(v) for v in text.split(","))
    except ValueError:
        raise ValueError(f"--shadow: expected N,REFINE_EVERY,MOVE_PERIODS (three integers), got {text!r}") from None
    if size < 1 or refine_every < 0 or move_periods < -1:
        raise ValueError(f"--shadow: N >= 1, REFINE_EVERY >= 0, MOVE_PERIODS >= -1, got {text!r}")
    settings = MPCController(bank_size=size, refine_every=refine_every, move_periods=max(move_periods, 0),
                             move_steps=1)
    return DeviationBank(settings, moves=move_periods >= 0)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--run", required=True, help="a reference_deviation PPO run (UNPICKLED: load only yours)")
    parser.add_argument("--n", type=int, default=20, help="the first N judge draws (default 20)")
    parser.add_argument("--skip", type=int, default=0, help="start at the M-th judge draw (default 0)")
    parser.add_argument("--bank-size", type=int, default=BANK_SIZE)
    parser.add_argument("--shadow", metavar="N,REFINE_EVERY,MOVE_PERIODS|tracker[:START,EVERY,CHORD,REBUILD,BUDGET]",
                        help="a second estimator beside, not driving (module docstring)")
    args = parser.parse_args(argv)
    try:
        shadow = shadow_bank(args.shadow, args.bank_size)
    except ValueError as error:
        parser.error(str(error))
    if args.n < 1 or args.skip < 0:
        parser.error(f"--n must be >= 1 and --skip >= 0, got {args.n}, {args.skip}")
    import torch
    torch.set_num_threads(1)
    controller = BankedDeviationPolicy.load(args.run, bank_size=args.bank_size)
    draws = judge_draws(args.skip + args.n, {})[args.skip:]
    with threadpool_limits(1):
        rows = [episode(controller, bench, args.skip + i, shadow) for i, (_, bench) in enumerate(draws)]
    with open("/proc/loadavg") as f:
        load = f.read().split()[:3]
    print(json.dumps({"run": args.run, "bank_size": args.bank_size, "skip": args.skip, "shadow": args.shadow,
                      **summary(rows), **tracker_counts(shadow), "load": load}, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

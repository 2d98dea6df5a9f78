"""Any controller's decision time on a bench: the CPU one ``act`` costs, one decision after another as on a bench.

``PYTHONPATH=. taskset -c 0 python benchmarks/bench_decisions.py --controller SPEC [--benches 20] [--first 0]``
runs the controller (any string of :func:`agents.controller_specs.parse_controller`: ``shipped:NAME``,
``student:FOLDER``, ``estimated:RUN``, ``mpc``, ...) through the one episode loop on the students' judge benches
(:func:`experiments.train_student.judge_draws`: startable draws of the tuning stream, never the held-out one; noise
seed: the bench's index) and times every ``act``: in CPU time of the thread (``time.thread_time_ns``: what the
decision costs the core) and in wall time (``time.perf_counter_ns``: what a bench waits, which another process on
the same core lengthens). Prints, as JSON, the median, 99th percentile and largest of each, the number of decisions,
the machine's load average before and after, and each episode's outcome (a controller that fails is timed too).
Before the timed episodes one untimed episode loads numba's cache and the controller's files, which a bench does
once at start-up, not per decision. numpy's BLAS is held to one thread (``threadpoolctl``), as on one core.

Issue 34's target: 1 ms at the 99th percentile on one pinned core with nothing else running (``taskset -c 0`` pins
it; nothing else running is the caller's to ensure: the load average printed says how quiet the machine was).
``--out FILE`` writes the JSON too (complete or not at all).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
from threadpoolctl import threadpool_limits

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from agents.controller_specs import ControllerSpecError, parse_controller
from agents.heldout import run_episode
from experiments.judge import emit
from experiments.train_student import judge_draws


class _Timed:
    """A controller whose every ``act`` is timed (thread CPU and wall, ns); the rest passes through. A controller
    that splits its period (``info["decision_cpu_s"]``: the CPU from the measurement to the command, the rest of its
    ``act`` running after the command is sent, as ``banked:RUN`` and a shipped ``banked`` agent advance their bank)
    has that part recorded too."""

    def __init__(self, controller: Any) -> None:
        self._controller = controller
        self.cpu_ns: list[int] = []
        self.wall_ns: list[int] = []
        self.decision_ns: list[int] = []

    def __getattr__(self, name: str) -> Any:
        return getattr(self._controller, name)

    def act(self, obs: np.ndarray) -> np.ndarray:
        cpu, wall = time.thread_time_ns(), time.perf_counter_ns()
        action = self._controller.act(obs)
        self.wall_ns.append(time.perf_counter_ns() - wall)
        self.cpu_ns.append(time.thread_time_ns() - cpu)
        info = getattr(self._controller, "info", None)
        if isinstance(info, dict) and "decision_cpu_s" in info:
            self.decision_ns.append(round(1e9 * info["decision_cpu_s"]))
        return action


def _summary_ms(ns: list[int]) -> dict[str, float]:
    ms = np.asarray(ns, dtype=np.float64) / 1e6
    return {"p50_ms": float(np.median(ms)), "p99_ms": float(np.percentile(ms, 99)), "max_ms": float(ms.max())}


def bench_decisions(text: str, benches: int, first: int = 0) -> dict[str, Any]:
    """Time every decision of controller ``text`` on judge benches ``first`` .. ``first + benches - 1`` (one untimed
    episode on the bench before them, or on bench 0, first)."""
    if benches < 1 or first < 0:
        raise ValueError(f"--benches must be >= 1 and --first >= 0 (got {benches}, {first})")
    built = parse_controller(text).build(text, {})
    draws = [bench for _, bench in judge_draws(first + benches, built.env_kwargs)]
    warm = max(first - 1, 0)
    run_episode(built.controller, draws[warm], env_kwargs=built.env_kwargs, seed=warm, bench_set="tuning",
                index=warm)
    timed = _Timed(built.controller)
    load_before = os.getloadavg()
    outcomes = [run_episode(timed, draws[i], env_kwargs=built.env_kwargs, seed=i, bench_set="tuning", index=i)
                for i in range(first, first + benches)]
    split = {"to_command_thread_cpu": _summary_ms(timed.decision_ns)} if timed.decision_ns else {}
    return {"controller": text, "benches": [first, first + benches], "decisions": len(timed.cpu_ns),
            "thread_cpu": _summary_ms(timed.cpu_ns), **split, "wall": _summary_ms(timed.wall_ns),
            "load_average_before_after": [round(load_before[0], 2), round(os.getloadavg()[0], 2)],
            "affinity": sorted(os.sched_getaffinity(0)),
            "outcomes": [{"bench": o.index, "success": bool(o.success), "steps": int(o.steps),
                          "error_mm": float(o.mimicry_error_mm) if o.success else None}
                         for o in outcomes]}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--controller", required=True, help="a controller string (parse_controller)")
    parser.add_argument("--benches", type=int, default=20, help="timed episodes (default 20)")
    parser.add_argument("--first", type=int, default=0, help="the first judge bench timed (default 0)")
    parser.add_argument("--out", help="also write the JSON here")
    args = parser.parse_args(argv)
    try:
        with threadpool_limits(limits=1):
            result = bench_decisions(args.controller, args.benches, args.first)
    except (ControllerSpecError, ValueError) as error:
        parser.error(str(error))
    emit(result, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())

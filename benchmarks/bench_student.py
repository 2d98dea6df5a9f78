"""A student's decision time (:class:`agents.student.StudentController.act`: the frame stack, the normalisation and
the network), on the observations of recorded label episodes, one decision after another as on a bench.

``PYTHONPATH=. taskset -c 0 python benchmarks/bench_student.py --student DIR --labels LABELS [--episodes 20]
[--repeats 20]`` replays the observations of the first ``--episodes`` started shards of the label folder (each
episode from a reset, ``--repeats`` times) and prints the median, 99th percentile and largest time of one decision,
in CPU time of the thread (``time.thread_time_ns``: what the decision costs the core) and in wall time
(``time.perf_counter_ns``: what a bench waits, which another process on the same core lengthens). The issue's target:
1 ms at the 99th percentile on one pinned core with nothing else running. numpy's BLAS is held to one thread
(``threadpoolctl``), as on a bench's single core.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np
from threadpoolctl import threadpool_limits

from agents.student import StudentController
from experiments.distill_labels import label_shards, truth_values


def episodes_of(labels: Path, n: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """(observations, the bench's true unknowns) of the first ``n`` started episodes."""
    found = []
    for path in label_shards([labels]):
        with np.load(path, allow_pickle=False) as s:
            if bool(s["started"]):
                found.append((s["obs"].copy(), s["truth"].copy()))
        if len(found) == n:
            break
    if not found:
        raise SystemExit(f"{labels}: no started episode")
    return found


def decision_times(student: StudentController, episodes: list[tuple[np.ndarray, np.ndarray]], repeats: int
                   ) -> tuple[np.ndarray, ...]:
    """(CPU ns, wall ns) of every decision: each episode from a reset, ``repeats`` times (a privileged student given
    the episode's true unknowns, ``experiments.train_student --given truth``)."""
    cpu, wall = [], []
    for _ in range(repeats):
        for obs, truth in episodes:
            student.reset(0.0, None)
            if student.given_names:
                student.given = truth_values(truth, student.given_names)
            for o in obs:
                c0, w0 = time.thread_time_ns(), time.perf_counter_ns()
                student.act(o)
                w1, c1 = time.perf_counter_ns(), time.thread_time_ns()
                cpu.append(c1 - c0)
                wall.append(w1 - w0)
    return np.array(cpu), np.array(wall)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--student", required=True, help="a student folder (experiments.train_student's --out)")
    parser.add_argument("--labels", required=True, help="a label folder whose observations are replayed")
    parser.add_argument("--episodes", type=int, default=20)
    parser.add_argument("--repeats", type=int, default=20)
    args = parser.parse_args(argv)
    student = StudentController.load(args.student)
    episodes = episodes_of(Path(args.labels), args.episodes)
    with threadpool_limits(1):
        decision_times(student, episodes[:1], 1)  # first calls (allocations, caches) are not a bench's steady state
        cpu, wall = decision_times(student, episodes, args.repeats)
    out = {"decisions": int(len(cpu)), "episodes": len(episodes), "repeats": args.repeats,
           "kind": student.spec.get("kind", "mlp"), "gru": student.spec.get("gru"), "hidden": student.spec["hidden"],
           "frames": student.n_frames, "given": len(student.given_names)}
    for name, ns in (("cpu", cpu), ("wall", wall)):
        out.update({f"{name}_p50_us": float(np.percentile(ns, 50)) / 1e3,
                    f"{name}_p99_us": float(np.percentile(ns, 99)) / 1e3, f"{name}_max_us": float(ns.max()) / 1e3})
    print(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

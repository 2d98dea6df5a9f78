"""One workbench evaluation, taken apart: a model at one load compared with that load's tests, the unit every fit
repeats thousands of times (``triplanar.workbench.spec.evaluate``).

    PYTHONPATH=. python benchmarks/bench_evaluation.py [--repeats 40]

On ``data/lab_traces.csv`` (12 load levels, 4 tests each, about 120 samples a test), with end friction at 8 deg:
for each part, CPU milliseconds per task (``time.process_time``, the best of five passes over the 12 tasks x
``--repeats``). The parts overlap as their names say; the compiled physics is ``simulate`` on an already built model
less its Python (compare ``simulate_for (model built)`` with ``build + simulate_for``).
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from triplanar.measurement import read_measurements
from triplanar.result import SimulationResult
from triplanar.workbench.discrepancy import discrepancy_group
from triplanar.workbench.spec import ModelSpec, evaluate, simulate_for, tasks_for


def _unread(result: SimulationResult) -> SimulationResult:
    """The same run with nothing derived yet (its rows' kinematics and interpolants computed anew)."""
    return replace(result)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=40)
    args = parser.parse_args(argv)
    tests = read_measurements(ROOT / "data" / "lab_traces.csv")
    spec = ModelSpec().with_effects([("end_friction", (("phi_deg", 8.0),))])
    tasks = [replace(t, report=False) for t in tasks_for(spec, tests)]
    models = {t.force_N: t.spec.build(t.force_N) for t in tasks}
    runs = {t.force_N: simulate_for(models[t.force_N], t.tests) for t in tasks}
    parts = {
        "evaluate (all of it)": lambda t: evaluate(t),
        "build the model + its kernel parameters": lambda t: t.spec.build(t.force_N).kernel_params_cached,
        "build + simulate_for": lambda t: simulate_for(t.spec.build(t.force_N), t.tests),
        "simulate_for (model built)": lambda t: simulate_for(models[t.force_N], t.tests),
        "compare (fresh run: kinematics, resampling, terms)": lambda t: discrepancy_group(
            t.tests, _unread(runs[t.force_N]), False),
    }
    for task in tasks:          # (compile and cache whatever is not yet)
        evaluate(task)
    print(f"{len(tasks)} tasks, {sum(len(t.tests) for t in tasks)} tests; CPU ms per task, best of 5:")
    for name, part in parts.items():
        best = min(_pass(part, tasks, args.repeats) for _ in range(5))
        print(f"  {name:52s} {best * 1e3:7.3f}")
    return 0


def _pass(part, tasks, repeats: int) -> float:
    start = time.process_time()
    for _ in range(repeats):
        for task in tasks:
            part(task)
    return (time.process_time() - start) / (repeats * len(tasks))


if __name__ == "__main__":
    sys.exit(main())

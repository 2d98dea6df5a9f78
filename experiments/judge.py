"""Any controller on the students' judge benches (:func:`experiments.train_student.judge_controller`: the first
``N`` startable draws of the tuning stream below 1000, never labelled; noise seed: the bench's index), so that a
PPO run, a shipped agent or ``limit`` is compared with the students on the same episodes.

``python -m experiments.judge --controller ppo:RUN [--controller ...] --n 100 [--skip M] [--shipped-seed K ...]``
prints, as JSON, each controller's row (:func:`experiments.stats.row_stats`: success with its Wilson interval, error
over successes and score with their bootstrap intervals, the failures, each bench's score: failure =
``FAILURE_SCORE_MM``, for paired comparisons) and, with several, the row pooling them as
seeds of one recipe (the same benches each). ``--out FILE`` also writes it. A controller is any string of
:func:`agents.controller_specs.parse_controller` (``ppo:RUN`` loads a privileged run, ``env.privileged``, as
:class:`agents.robust_policy.PrivilegedPolicy`; ``shipped:ppo_robust``, once per ``--shipped-seed``).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from typing import Any

from agents.controller_specs import ControllerSpecError, parse_controller
from agents.heldout import FAILURE_SCORE_MM
from triplanar.atomic import write_atomic

from .train_student import judge_outcomes, judged_stats


def judge_all(texts: list[str], n: int, skip: int = 0, shipped_seeds: tuple[int, ...] = (0,)) -> dict[str, Any]:
    """Each controller's judged row (and CPU seconds; a shipped agent's once per seed of ``shipped_seeds``), and
    the pooled row when there are several."""
    repeated = sorted({t for t in texts if texts.count(t) > 1})
    if repeated:
        raise ValueError(f"--controller {repeated[0]!r} is given twice (pool training seeds as separate runs)")
    rows, runs = {}, []
    for text, seed in [(t, s) for t in texts for s in (shipped_seeds if t.startswith("shipped:") else (0,))]:
        label = f"{text} seed {seed}" if text.startswith("shipped:") else text
        built = parse_controller(text, seed=seed).build(label, {})
        started = time.process_time()
        outcomes = judge_outcomes(built.controller, built.env_kwargs, n, skip)
        rows[label] = {**judged_stats([outcomes]), "cpu_s": time.process_time() - started,
                       "bench_scores_mm": [o.mimicry_error_mm if o.success else FAILURE_SCORE_MM for o in outcomes]}
        runs.append(outcomes)
    result: dict[str, Any] = {"n": n, "skip": skip, "rows": rows}
    if len(runs) > 1:
        result["pooled"] = judged_stats(runs)
    return result


def emit(result: dict[str, Any], out: str | None) -> None:
    """Print ``result`` as JSON and, with ``out``, write it there too (complete or not at all)."""
    text = json.dumps(result, indent=1)
    print(text)
    if out:
        write_atomic(out, lambda tmp: tmp.write_text(text + "\n"))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m experiments.judge", description=__doc__.split("\n\n")[0])
    parser.add_argument("--controller", action="append", required=True, help="a controller string (repeatable)")
    parser.add_argument("--n", type=int, default=100, help="the first N judge benches (default 100)")
    parser.add_argument("--skip", type=int, default=0, metavar="M", help="from the M-th of them")
    parser.add_argument("--shipped-seed", type=int, action="append", help="a training seed of a shipped:NAME agent "
                        "(repeatable: one row per seed; default 0)")
    parser.add_argument("--out", help="also write the JSON here")
    args = parser.parse_args(argv)
    try:
        result = judge_all(args.controller, args.n, args.skip, tuple(args.shipped_seed or (0,)))
    except (ControllerSpecError, ValueError) as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    emit(result, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())

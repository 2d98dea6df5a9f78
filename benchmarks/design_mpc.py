"""The current ``mpc`` on every design of the bench study's sweep, beside the study's rows of that design.

``PYTHONPATH=. python benchmarks/design_mpc.py --out runs/design_mpc [--n 50] [--workers 2]
[--study docs/actuator-study/designs.csv] [--designs A,B]``

For each design and each of ``mpc`` and ``limit``: ``triplanar evaluate --controller C --design D --n N`` (the
design's first ``N`` held-out benches with its tip, the benches of the study's model-based rows; ``mpc`` told the
design's hardware and known tip, :func:`experiments.evaluate.scripted_batch`), written to ``OUT/C/D/`` as
``evaluate`` writes it; one whose ``heldout.json`` exists is not run again (resumable). Then a table per design: the
current ``mpc`` and ``limit`` rows and the ratio of their scores, the study's rows of both, and the best buildable
controller among the study's rows and the current ``mpc`` with its distance to the current limit. Results go to
``docs/actuator-study.md`` by hand, with the command.
"""

from __future__ import annotations

import argparse
import csv
import json
from pathlib import Path

from experiments.designs import DESIGNS
from experiments.evaluate import evaluate, write
from triplanar.executor import pool_scope, run_tasks


def run_design(task: tuple[str, str, int, str]) -> str:
    controller, name, n, out = task
    where = Path(out) / controller / name
    if not (where / "heldout.json").exists():
        write(evaluate(controller, design=name, n=n, progress=False), where)
    return name


def study_rows(path: Path) -> dict[str, dict[str, dict]]:
    """design -> controller -> the study's row (``designs.csv``)."""
    rows: dict[str, dict[str, dict]] = {}
    with open(path, newline="") as f:
        for r in csv.DictReader(f):
            rows.setdefault(r["design"], {})[r["controller"]] = r
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", default="runs/design_mpc")
    parser.add_argument("--n", type=int, default=50)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--study", default="docs/actuator-study/designs.csv")
    parser.add_argument("--designs", default=None, metavar="A,B",
                        help="only these designs (default: every design of the sweep)")
    args = parser.parse_args()
    names = [d.name for d in DESIGNS]
    if args.designs is not None:
        wanted = args.designs.split(",")
        unknown = sorted(set(wanted) - set(names))
        if unknown:
            raise SystemExit(f"--designs: {unknown} are not designs of the sweep; choose from {names}")
        names = [n for n in names if n in wanted]
    tasks = [(controller, name, args.n, args.out) for name in names for controller in ("mpc", "limit")]
    with pool_scope(args.workers) as ex:
        run_tasks(run_design, tasks, ex, progress=True, desc="designs")
    study = study_rows(Path(args.study))
    print("| design | `mpc` now: success, % | error over successes, mm (95 % CI) | score, mm (95 % CI) | "
          "`limit` now: success, % | score, mm (95 % CI) | `mpc` / limit | study: `mpc`, `limit` scores | "
          "best buildable | best / limit |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for name in names:
        r, lim = (json.loads((Path(args.out) / c / name / "heldout.json").read_text()) for c in ("mpc", "limit"))
        others = {c: float(v["score"]) for c, v in study[name].items() if c not in ("mpc", "limit")}
        others["mpc"] = r["score"]
        best = min(others, key=others.get)
        print(f"| {name} | {100 * r['success_rate']:.0f} | {r['mimicry_error_mm']:.2f} ({r['error_low_mm']:.2f}-"
              f"{r['error_high_mm']:.2f}) | {r['score']:.2f} ({r['score_low']:.2f}-{r['score_high']:.2f}) | "
              f"{100 * lim['success_rate']:.0f} | {lim['score']:.2f} ({lim['score_low']:.2f}-{lim['score_high']:.2f}) | "
              f"{r['score'] / lim['score']:.2f} | {float(study[name]['mpc']['score']):.2f}, "
              f"{float(study[name]['limit']['score']):.2f} | `{best}` {others[best]:.2f} | "
              f"{others[best] / lim['score']:.2f} |")


if __name__ == "__main__":
    main()

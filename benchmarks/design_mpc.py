"""The current ``mpc`` on every design of the bench study's sweep, beside the study's rows of that design.

``PYTHONPATH=. python benchmarks/design_mpc.py --out runs/design_mpc [--n 50] [--workers 2]
[--study docs/actuator-study/designs.csv]``

For each design: ``triplanar evaluate --controller mpc --design D --n N`` (the design's first ``N`` held-out benches
with its tip, the benches of the study's model-based rows; ``mpc`` told the design's hardware and known tip,
:func:`experiments.evaluate.scripted_batch`), written to ``OUT/D/`` as ``evaluate`` writes it; a design whose
``OUT/D/heldout.json`` exists is not run again (resumable). Then a table per design: the new ``mpc`` row, the
study's ``limit`` (same benches) and the ratio of the scores, the study's own ``mpc`` row, and the best buildable
controller among the study's rows and the new ``mpc`` with its distance to the limit. Results go to
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


def run_design(task: tuple[str, int, str]) -> str:
    name, n, out = task
    if not (Path(out) / name / "heldout.json").exists():
        write(evaluate("mpc", design=name, n=n, progress=False), Path(out) / name)
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
    args = parser.parse_args()
    names = [d.name for d in DESIGNS]
    with pool_scope(args.workers) as ex:
        run_tasks(run_design, [(name, args.n, args.out) for name in names], ex, progress=True, desc="designs")
    study = study_rows(Path(args.study))
    print("| design | `mpc` now: success, % (95 % CI) | error over successes, mm (95 % CI) | score, mm (95 % CI) | "
          "`limit` (study), score | `mpc` now / limit | `mpc` in the study, score | best buildable | best / limit |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name in names:
        r = json.loads((Path(args.out) / name / "heldout.json").read_text())
        limit = float(study[name]["limit"]["score"])
        old = float(study[name]["mpc"]["score"])
        others = {c: float(v["score"]) for c, v in study[name].items() if c not in ("mpc", "limit")}
        others["mpc"] = r["score"]
        best = min(others, key=others.get)
        print(f"| {name} | {100 * r['success_rate']:.1f} ({100 * r['success_low']:.1f}-{100 * r['success_high']:.1f}) | "
              f"{r['mimicry_error_mm']:.2f} ({r['error_low_mm']:.2f}-{r['error_high_mm']:.2f}) | {r['score']:.2f} "
              f"({r['score_low']:.2f}-{r['score_high']:.2f}) | {limit:.2f} | {r['score'] / limit:.2f} | {old:.2f} | "
              f"`{best}` {others[best]:.2f} | {others[best] / limit:.2f} |")


if __name__ == "__main__":
    main()

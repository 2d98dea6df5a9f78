"""How often is an instrument effect taken for a physical one, and the other way round?

Each built-in effect with a scenario (``triplanar/effects.py``) is hidden in seeded datasets from the project's own
generator (``triplanar/labdata.py``: case B plus the effect, 4 loads x 2 repeats, 0.2 mm noise, 0.2 deg friction
scatter) and diagnosed against case B (2 folds). Counted: the verdict, the effect named, and whether what is named
acts on the same thing (physics or instrument) as what was hidden::

    PYTHONPATH=. python benchmarks/instrument_confusion.py [--seeds 5] [--first-seed 400]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections import Counter
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from triplanar import make_effect
from triplanar.effects import REGISTRY
from triplanar.labdata import generate_lab_data
from triplanar.workbench import Diagnoser
from triplanar.workbench.scenarios import HIDDEN_EFFECTS

LOADS = (27.8, 35.0, 45.0, 55.6)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--first-seed", type=int, default=400)
    args = parser.parse_args()
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    began = time.perf_counter()
    print(f"{len(HIDDEN_EFFECTS)} effects x {args.seeds} seeds ({seeds.start}-{seeds.stop - 1}), 4 loads x 2 repeats, "
          f"against case B; load average {os.getloadavg()[0]:.2f}")
    print(f"{'hidden':20s} {'kind':10s} {'named right':>11s} {'same kind':>9s} {'other kind':>10s} {'nothing':>7s}  named")
    for name, (spec, _) in HIDDEN_EFFECTS.items():
        kind = REGISTRY[name].acts_on
        named: Counter[str] = Counter()
        right = same = other = nothing = 0
        for seed in seeds:
            tests, _ = generate_lab_data(loads=LOADS, repeats=2, seed=seed, effects=[make_effect(spec)])
            report = Diagnoser(folds=2, progress=False, executor="serial").fit(tests).report_
            got = report["missing_effect"]
            named[f"{got} ({report['verdict']}, {report['confidence']})"] += 1
            if got is None:
                nothing += 1
                continue
            right += got == name
            if REGISTRY[got].acts_on == kind:
                same += 1
            else:
                other += 1
        n = len(seeds)
        print(f"{name:20s} {kind:10s} {right:7d}/{n} {same:6d}/{n} {other:7d}/{n} {nothing:4d}/{n}  "
              + "; ".join(f"{k} x{v}" for k, v in named.most_common()), flush=True)
    print(f"({time.perf_counter() - began:.0f} s; load average {os.getloadavg()[0]:.2f})")


if __name__ == "__main__":
    main()

"""How often :func:`triplanar.workbench.locate.locate` puts a cause outside the library at the right point and along
the right direction, on datasets with a known truth made by the independent laboratory
(``benchmarks/workbench_calibration.py``; its outside causes, ``benchmarks/calibration_plugins.py``, all act at the
mass centre). ::

    PYTHONPATH=. python benchmarks/locate_rates.py DATA_DIR [DATA_DIR ...] [--results DIR] [--seeds 1000-3999]

Each ``DATA_DIR`` holds ``outside_*-s<seed>.csv`` with ``.truth.json`` beside it (read only). The model located from
is the one the dataset's diagnosis starts from (the given effects; case B), the folds those of ``diagnose`` (3, by
load level). ``--results``: the calibration's kept diagnoses (``results/<label>-s<seed>.json``), for the verdict
column. Prints one row per dataset (kind, located form, right or not, CPU s) and the rates with their Wilson 95 %
intervals: direction and point right (the point: the true one, or one where the force has the same moment about the
vertical, ``LocatedTerm.same_moment``; and with the look-alikes), what it follows right, the size's interval holding the
true value.
"""

from __future__ import annotations

import argparse
import json
import math
import resource
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from triplanar.workbench.locate import LocatedTerm

#: What each outside cause is, as a term: the point, the directions counted right (a periodic force's sign is its
#: phase), what it follows (the sign of the lateral pull is read from its parameter).
TRUTH = {"outside_viscous_drag": ("mass centre", ("-e1",), "slip speed"),
         "outside_quadratic_drag": ("mass centre", ("-e1",), "slip speed squared"),
         "outside_thrust_ripple": ("mass centre", ("+e1", "-e1"), "time"),
         "outside_travel_hardening": ("mass centre", ("-e1",), "travel"),
         "outside_lateral_pull": ("mass centre", None, "constant")}


#: The truth's parameter that is the located term's size (same unit: each cause acts at the mass centre).
SIZE = {"outside_viscous_drag": "c_N_s_m", "outside_quadratic_drag": "k_N_s2_m2", "outside_thrust_ripple":
        "amplitude_N", "outside_travel_hardening": "b_N_m", "outside_lateral_pull": "force_N"}


def true_size(truth: dict) -> float:
    name, params = truth["outside_library"][0]["name"], truth["outside_library"][0]["parameters"]
    return abs(float(params[SIZE[name]]))


def truth_of(truth: dict) -> tuple[str, tuple[str, ...], str]:
    name, params = truth["outside_library"][0]["name"], truth["outside_library"][0]["parameters"]
    point, directions, follows = TRUTH[name]
    if directions is None:
        directions = ("+e3",) if params["force_N"] > 0 else ("-e3",)
    return point, directions, follows


def _parse_label(label: str) -> tuple[str, str, str]:
    """``POINT along DIR following WHAT`` as its three parts."""
    point, _, rest = label.partition(" along ")
    direction, _, follows = rest.partition(" following ")
    return point, direction, follows.split(" (")[0]


def judge(term: LocatedTerm | None, lookalikes: tuple[str, ...], truth: tuple[str, tuple[str, ...], str]) -> dict:
    point, directions, follows = truth
    if term is None:
        return {"where": False, "where_group": False, "follows": False}
    where = (term.point == point or point in term.same_moment) and term.direction in directions
    group = where or any(p == point and d in directions for p, d, _ in map(_parse_label, lookalikes))
    return {"where": where, "where_group": group, "follows": term.follows == follows}


def wilson(k: int, n: int) -> tuple[float, float]:
    if n == 0:
        return math.nan, math.nan
    z = 1.959964
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return centre - half, centre + half


def _seeds(text: str) -> range:
    lo, _, hi = text.partition("-")
    return range(int(lo), int(hi or lo) + 1)


def main() -> None:
    from triplanar import make_effect
    from triplanar.measurement import read_measurements
    from triplanar.workbench import ModelSpec
    from triplanar.workbench.locate import locate
    from triplanar.workbench.sweep import load_folds
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("data", nargs="+", type=Path)
    parser.add_argument("--results", type=Path, help="the calibration's kept diagnoses, for the verdict column")
    parser.add_argument("--seeds", type=_seeds, help="only these seeds, LOW-HIGH")
    args = parser.parse_args()
    rows = []
    for folder in args.data:
        for path in sorted(folder.glob("outside_*-s*.csv")):
            seed = int(path.stem.rsplit("-s", 1)[1])
            if args.seeds is not None and seed not in args.seeds:
                continue
            if 10000 <= seed <= 10065:
                raise SystemExit(f"{path}: seeds 10000-10065 are the calibration's held-out part; not looked at here")
            truth = json.loads(path.with_name(path.name + ".truth.json").read_text(encoding="utf-8"))
            tests = read_measurements(path)
            given = [make_effect(f"{e['name']}:" + ",".join(f"{k}={v}" for k, v in e["parameters"].items()))
                     for e in truth["given_model_effects"]]
            verdict = "?"
            if args.results is not None and (args.results / f"{path.stem}.json").is_file():
                verdict = json.loads((args.results / f"{path.stem}.json").read_text(encoding="utf-8"))["verdict"]
            before = resource.getrusage(resource.RUSAGE_SELF)
            found = locate(tests, ModelSpec.from_effects(given), load_folds([t.shear_force_N for t in tests], 3),
                           "serial")
            after = resource.getrusage(resource.RUSAGE_SELF)
            cpu = after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime
            right = judge(found.term, found.lookalikes, truth_of(truth))
            size = true_size(truth)
            covers = bool(right["where"] and right["follows"] and found.term.ci95[0] <= size <= found.term.ci95[1])
            rows.append({"name": path.stem, "verdict": verdict, "found": found, "cpu": cpu, "covers": covers,
                         **right})
            term = found.term.label if found.term else "none"
            if found.term is not None:
                term += f" {found.term.size:.3g} [{found.term.ci95[0]:.3g}, {found.term.ci95[1]:.3g}] (true {size:.3g})"
            term += " (weak)" if found.weak else ""
            print(f"{path.stem:34s} {verdict:16s} {term:99s} where {'Y' if right['where'] else 'n'} "
                  f"(group {'Y' if right['where_group'] else 'n'}, {len(found.lookalikes)} alike) follows "
                  f"{'Y' if right['follows'] else 'n'}  removes {100 * found.share_removed:5.1f} %  "
                  f"{cpu:5.1f} CPU s", flush=True)
    _summary(rows)


def _summary(rows: list[dict]) -> None:
    print()
    print("| kind | datasets | point (or one with the same moment about the vertical) and direction right | ... or among the look-alikes | follows right "
          "| size's interval holds the truth |")
    print("|---|---|---|---|---|---|")
    kinds = sorted({r["name"].rsplit("-s", 1)[0] for r in rows})
    for kind in [*kinds, "all", "diagnosed outside_library"]:
        sel = [r for r in rows if kind == "all" or r["name"].rsplit("-s", 1)[0] == kind
               or (kind.startswith("diagnosed") and r["verdict"] == "outside_library")]
        cells = []
        for key in ("where", "where_group", "follows", "covers"):
            k = sum(r[key] for r in sel)
            lo, hi = wilson(k, len(sel))
            cells.append(f"{k}/{len(sel)}" + (f" [{lo:.2f}, {hi:.2f}]" if kind in ("all", "diagnosed outside_library") and sel else ""))
        print(f"| {kind} | {len(sel)} | " + " | ".join(cells) + " |")
    cpu = sorted(r["cpu"] for r in rows)
    if cpu:
        print(f"\nCPU s per dataset: median {cpu[len(cpu) // 2]:.1f}, max {cpu[-1]:.1f}")


if __name__ == "__main__":
    main()

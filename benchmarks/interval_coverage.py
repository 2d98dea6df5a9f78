"""Coverage of diagnose's 95 % intervals, with and without model-form error, on datasets the project makes itself.

Every dataset is made by ``triplanar/labdata.py`` with end friction 8 deg (the truth), 6 loads x 2 repeats (27.8-55.6
N), 0.5 mm rangefinder noise, 0.2 deg friction scatter; the intervals are end friction's from a diagnosis (3 folds)
against case B with end friction the only candidate, or the refit of a wrong given value. Kinds:

* ``clean``: the library's physics is the truth;
* ``refit``: the model is given end friction 4 deg, refitted;
* ``drag``: the truth has a viscous drag of 3 N s/m at the mass centre that the library lacks (a stand-in for the
  dissipation of soft contacts: a model-form error; registered only while the data are made, so it is never a
  candidate nor a model-form alternative);
* ``gain``: every lateral rangefinder reading is 10 % high, which the model does not know (a small instrument bias);
* ``euler``, ``rk4``: the data are integrated by the explicit Euler stepper with a fixed 2 ms step, or by RK4 with a
  fixed 5 ms step, instead of the adaptive DOPRI5 the workbench uses (another integrator: the data's own numerical
  error is a model-form error);
* ``load``: the load cell reads 5 % high (the force applied is 5 % above the one recorded), which the model does
  not know.

Three intervals per dataset: the curvature one (``param_ci95``: sandwich or jackknife, with the Birge-ratio
allowances), the profile-likelihood one (``param_profile_ci95``) and the one that admits model-form error
(``param_model_ci95``, :mod:`triplanar.workbench.alternatives`); "high on a miss" counts datasets whose interval
misses 8 deg while diagnose's confidence is ``high``. ::

    PYTHONPATH=. python benchmarks/interval_coverage.py [--seeds 10] [--first-seed 600] [--kinds clean,drag]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from triplanar import EFFECTS, make_effect
from triplanar.effects import Effect, Parameter
from triplanar.labdata import generate_lab_data
from triplanar.workbench import Diagnoser, ModelSpec
from triplanar.workbench.executor import run_tasks

LOADS = (27.8, 32.5, 37.5, 42.5, 47.5, 55.6)
TRUTH = 8.0


class UnmodelledDrag(Effect):
    """Outside the library: a viscous drag at the mass centre (never registered as a candidate)."""

    name = "outside_viscous_drag"
    parameters = {"c_N_s_m": Parameter(0.0, 0.0, 50.0, "N s/m", "drag per unit speed")}

    def wrench(self, t, state):
        return -self["c_N_s_m"] * state.velocity, np.zeros(3)


KINDS = {
    "clean": ([], ModelSpec()),
    "refit": ([], ModelSpec.from_effects([make_effect("end_friction:phi_deg=4")])),
    "drag": ([UnmodelledDrag(c_N_s_m=3.0)], ModelSpec()),
    "gain": ([make_effect("rangefinder_gain:gain_x3=1.1")], ModelSpec()),
    "euler": ([], ModelSpec()),
    "rk4": ([], ModelSpec()),
    "load": ([make_effect("load_cell_gain:gain=1.05")], ModelSpec()),
}
#: the generator's integrator for the kinds that swap it (another integrator: its numerical error is a model-form error)
INTEGRATOR = {"euler": {"method": "euler", "dt": 0.002}, "rk4": {"method": "rk4", "dt": 0.005}}


def dataset(kind: str, seed: int) -> list:
    """The tests of one dataset (the outside drag is registered only while its data are made: it must not be a
    candidate or a model-form alternative)."""
    extra, _ = KINDS[kind]
    import triplanar.labdata as labdata
    plain = labdata.simulate
    if kind in INTEGRATOR:      # the generator's integrator swapped for this kind only
        labdata.simulate = lambda model, **kw: plain(model, **INTEGRATOR[kind], **kw)
    EFFECTS[UnmodelledDrag.name] = UnmodelledDrag
    try:
        tests, _ = generate_lab_data(loads=LOADS, repeats=2, seed=seed, noise_m=5e-4,
                                     effects=[make_effect("end_friction:phi_deg=8"), *extra])
    finally:
        labdata.simulate = plain
        EFFECTS.pop(UnmodelledDrag.name, None)
    return tests


def one(job: tuple[str, int]) -> dict:
    """End friction's intervals and the confidence from a diagnosis of one dataset (pure: run_tasks maps it)."""
    kind, seed = job
    tests = dataset(kind, seed)
    _, model = KINDS[kind]
    candidates = [] if kind == "refit" else ["end_friction"]
    diag = Diagnoser(candidates, folds=3, progress=False, executor="serial").fit(tests, model)
    entry = diag.refits_[0] if kind == "refit" else diag.candidates_[0]
    return {"kind": kind, "seed": seed, "value": entry.params["phi_deg"],
            "curvature": entry.param_ci95.get("phi_deg"), "profile": entry.param_profile_ci95.get("phi_deg"),
            "model": entry.param_model_ci95.get("phi_deg"), "confidence": diag.report_["confidence"],
            "named": diag.best_ is entry, "moved": sorted(n for n, a in entry.model_form.items() if a["supported"])}


def covers(ci: list[float] | None) -> bool:
    return ci is not None and ci[0] <= TRUTH <= ci[1]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seeds", type=int, default=10)
    parser.add_argument("--first-seed", type=int, default=600)
    parser.add_argument("--kinds", help="comma-separated kinds (default: all)")
    parser.add_argument("--executor", default="local", help="runs the datasets: local (2 processes) or serial")
    args = parser.parse_args()
    kinds = args.kinds.split(",") if args.kinds else list(KINDS)
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    began = time.perf_counter()
    print(f"{len(kinds)} kinds x {args.seeds} seeds ({seeds.start}-{seeds.stop - 1}); load average "
          f"{os.getloadavg()[0]:.2f}", flush=True)
    rows = run_tasks(one, [(k, s) for k in kinds for s in seeds], args.executor)
    total = {w: 0 for w in ("curvature", "profile", "model")}
    high_miss = {w: 0 for w in total}
    for kind in kinds:
        mine = [r for r in rows if r["kind"] == kind]
        cells = []
        for w in total:
            hits = sum(covers(r[w]) for r in mine)
            total[w] += hits
            bad = sum(1 for r in mine if not covers(r[w]) and r["confidence"] == "high")
            high_miss[w] += bad
            width = np.nanmedian([r[w][1] - r[w][0] if r[w] else np.nan for r in mine])
            cells.append(f"{w} {hits}/{len(mine)} (width {width:.2f}, high on a miss {bad})")
        print(f"{kind:6s} " + "; ".join(cells) + f"; high {sum(r['confidence'] == 'high' for r in mine)}", flush=True)
        for r in mine:
            print(f"       seed {r['seed']}: {r['value']:.3f} curvature {r['curvature']} model {r['model']} "
                  f"{r['confidence']} alternatives {r['moved']}", flush=True)
    n = len(rows)
    for w in total:
        print(f"all kinds, {w}: {total[w]}/{n} = {total[w] / n:.0%} cover 8 deg; high on a miss: {high_miss[w]}")
    print(f"({time.perf_counter() - began:.0f} s; load average {os.getloadavg()[0]:.2f})")


if __name__ == "__main__":
    main()

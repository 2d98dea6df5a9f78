"""Coverage of diagnose's 95 % intervals, with and without model-form error, on datasets the project makes itself.

Every dataset is made by ``triplanar/labdata.py`` with end friction 8 deg (the truth), 6 loads x 2 repeats (27.8-55.6
N), 0.5 mm rangefinder noise, 0.2 deg friction scatter; the interval is end friction's from a diagnosis (3 folds)
against case B with end friction the only candidate, or the refit of a wrong given value. Kinds:

* ``clean``: the library's physics is the truth;
* ``refit``: the model is given end friction 4 deg, refitted;
* ``drag``: the truth has a viscous drag of 3 N s/m at the mass centre that the library lacks (a stand-in for the
  dissipation of soft contacts: a model-form error);
* ``gain``: every lateral rangefinder reading is 10 % high, which the model does not know (a small instrument bias);
* ``euler``: the data are integrated by the explicit Euler stepper with a fixed 2 ms step instead of the adaptive
  DOPRI5 the workbench uses (another integrator: the data's own numerical error is a model-form error).

Each dataset is diagnosed twice: with the intervals' allowance for a bias below the scatter (``model_form_allowance``) and
without it (the intervals before it). ::

    PYTHONPATH=. python benchmarks/interval_coverage.py [--seeds 10] [--first-seed 500]
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

import triplanar.workbench.evidence as evidence
from triplanar import EFFECTS, make_effect
from triplanar.effects import Effect, Parameter
from triplanar.labdata import generate_lab_data
from triplanar.workbench import Diagnoser, ModelSpec

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
}


def interval(kind: str, seed: int, allowance: bool) -> tuple[float, list[float] | None, float]:
    extra, model = KINDS[kind]
    import triplanar.labdata as labdata
    plain = labdata.simulate
    if kind == "euler":      # the generator's integrator swapped for this kind only
        labdata.simulate = lambda model, **kw: plain(model, method="euler", dt=0.002, **kw)
    try:
        tests, _ = generate_lab_data(loads=LOADS, repeats=2, seed=seed, noise_m=5e-4,
                                     effects=[make_effect("end_friction:phi_deg=8"), *extra])
    finally:
        labdata.simulate = plain
    original = evidence.model_form_allowance
    if not allowance:
        evidence.model_form_allowance = lambda found: 1.0
    try:
        candidates = [] if kind == "refit" else ["end_friction"]
        diag = Diagnoser(candidates, folds=3, progress=False, executor="serial").fit(tests, model)
    finally:
        evidence.model_form_allowance = original
    entry = diag.refits_[0] if kind == "refit" else diag.candidates_[0]
    return entry.params["phi_deg"], entry.param_ci95.get("phi_deg"), diag.report_["confidence"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--seeds", type=int, default=10)
    parser.add_argument("--first-seed", type=int, default=500)
    parser.add_argument("--kinds", help="comma-separated kinds (default: all)")
    args = parser.parse_args()
    kinds = args.kinds.split(",") if args.kinds else list(KINDS)
    EFFECTS[UnmodelledDrag.name] = UnmodelledDrag          # by name, for the generator
    seeds = range(args.first_seed, args.first_seed + args.seeds)
    began = time.perf_counter()
    print(f"{len(kinds)} kinds x {args.seeds} seeds ({seeds.start}-{seeds.stop - 1}); load average "
          f"{os.getloadavg()[0]:.2f}")
    totals = {True: [0, 0], False: [0, 0]}
    for kind in kinds:
        for allowance in (False, True):
            hits, widths, misses_high = 0, [], 0
            for seed in seeds:
                value, ci, confidence = interval(kind, seed, allowance)
                inside = ci is not None and ci[0] <= TRUTH <= ci[1]
                hits += inside
                misses_high += (not inside) and confidence == "high"
                widths.append(ci[1] - ci[0] if ci else np.nan)
            totals[allowance][0] += hits
            totals[allowance][1] += len(seeds)
            print(f"{kind:6s} {'with' if allowance else 'without':7s} allowance: {hits}/{len(seeds)} cover 8 deg, "
                  f"median width {np.nanmedian(widths):.2f} deg, missed with confidence high: {misses_high}",
                  flush=True)
    for allowance, (hits, n) in totals.items():
        print(f"all kinds, {'with' if allowance else 'without'} the allowance: {hits}/{n} = {hits / n:.0%}")
    print(f"({time.perf_counter() - began:.0f} s; load average {os.getloadavg()[0]:.2f})")


if __name__ == "__main__":
    main()

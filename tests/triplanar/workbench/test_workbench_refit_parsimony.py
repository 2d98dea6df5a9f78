"""A wrong given parameter is refitted, not replaced by a more flexible candidate that fits as well.

End to end on the project's own generator (reduced campaign: 4 loads x 2 repeats, 2 folds, every default
candidate and the refits): the data are made with the model as given but one of its parameters wrong.

* end friction given 6 deg, truth 8: the refit is named, its interval holds 8;
* cohesion given 0.15 N per contact, truth 0.35 (the 3-parameter ``contact_friction`` is cohesion's look-alike):
  no candidate with more free parameters than the refit is named, the refit is preferred whenever such a candidate
  is within the fold-to-fold uncertainty of the difference, and the refit's interval holds 0.35: on seeds 1 and 2
  in ``make test`` (each puts a more flexible candidate within that uncertainty: contact_friction, plane_tilt), on
  seeds 3-5 too in ``make test-slow`` (``long``). That the refit itself is the verdict in every seed does not hold
  (a strict xfail with the numbers, ``long``: it reads all five).

Run with ``-s`` to print the numbers.
"""

from __future__ import annotations

import functools
import math

import pytest

from triplanar import make_effect
from triplanar.labdata import generate_lab_data
from triplanar.workbench import Diagnoser, ModelSpec
from triplanar.workbench.parsimony import difference_se
from triplanar.workbench.sweep import CandidateResult

# each dataset is simulated and diagnosed with every candidate: 5-10 s each. One xdist worker runs the module, so that
# the strict xfail below reads the cohesion diagnoses `diagnosed` cached for the test before it instead of
# making all five again on the other worker.
pytestmark = [pytest.mark.slow, pytest.mark.xdist_group("refit_parsimony")]

LOADS = (27.8, 35.0, 45.0, 55.6)
COHESION_SEEDS = (1, 2, 3, 4, 5)
EXERCISING_SEEDS = (1, 2)      # the seeds that put a more flexible candidate within the uncertainty (module doc)


@functools.lru_cache(maxsize=None)
def diagnosed(truth: str, given: str, seed: int) -> Diagnoser:
    """The generator's data made with ``truth``, diagnosed against the model with ``given`` instead (cached: the
    tests below read the same diagnoses). Without the model-form step, which adds the named entry's profile and
    model-form intervals and may lower its confidence, none of which these tests read (as in conftest.py)."""
    tests, made = generate_lab_data(loads=LOADS, repeats=2, effects=[make_effect(truth)], seed=seed)
    assert not made["skipped"]
    return Diagnoser(folds=2, progress=False, model_form=False, executor="serial").fit(
        tests, ModelSpec.from_effects([make_effect(given)]))


def n_free(c: CandidateResult) -> int:
    return len(c.params) + len(c.per_test)


def flexible_within(diag: Diagnoser, refit: CandidateResult) -> list[tuple[CandidateResult, float, float]]:
    """Entries with more free parameters than ``refit`` that fit as well: their held-out error within one standard
    error of the difference of the refit's (``(entry, mean difference, its standard error)``, mm^2)."""
    out = []
    for c in diag.ranked_:
        if c is refit or not c.plausible or n_free(c) <= n_free(refit):
            continue
        mean, se = difference_se(c, refit)          # how much worse the refit is than c
        if math.isfinite(mean) and abs(mean) <= se:
            out.append((c, mean, se))
    return out


def show(label: str, diag: Diagnoser) -> None:
    r = diag.report_
    print(f"\n[{label}] {r['verdict']} named {diag.best_.kind}:{diag.best_.effect} ({r['confidence']}); "
          f"look-alikes {r['indistinguishable_from']}")
    for c in diag.ranked_[:5]:
        print(f"    {c.kind:9s} {c.effect:18s} {n_free(c)} free  cv {c.cv_error_mm:.3f} mm  "
              + ", ".join(f"{k} = {v:.4g} {c.param_ci95.get(k)}" for k, v in c.params.items()))


def test_a_wrong_given_end_friction_is_refitted_not_replaced() -> None:
    diag = diagnosed("end_friction:phi_deg=8", "end_friction:phi_deg=6", 1)
    show("end friction given 6, truth 8", diag)
    report = diag.report_
    assert report["verdict"] == "refit_given_effect" and report["missing_effect"] is None
    (refit,) = diag.refits_
    assert diag.best_ is refit
    lo, hi = refit.param_ci95["phi_deg"]
    assert lo <= 8.0 <= hi
    assert report["missing_effects"][0]["effect"] == "end_friction"
    assert report["missing_effects"][0]["kind"] == "refit"
    for c, mean, se in flexible_within(diag, refit):     # none here: contact_friction is worse by more than that
        print(f"    within the uncertainty: {c.effect}, the refit worse by {mean:+.3f} +- {se:.3f} mm^2")


def not_replaced_by_a_look_alike(seeds: tuple[int, ...]) -> int:
    """Assert the cohesion refit is not replaced on each of ``seeds``; return how many put a more flexible
    candidate within the uncertainty of the difference."""
    exercised = 0
    for seed in seeds:
        diag = diagnosed("cohesion:c_N=0.35", "cohesion:c_N=0.15", seed)
        show(f"cohesion given 0.15, truth 0.35, seed {seed}", diag)
        (refit,) = diag.refits_
        lo, hi = refit.param_ci95["c_N"]
        assert lo <= 0.35 <= hi, f"seed {seed}: refit c_N = {refit.params['c_N']:.3f} [{lo:.3f}, {hi:.3f}]"
        assert diag.best_ is not None and n_free(diag.best_) <= n_free(refit), \
            f"seed {seed}: {diag.best_.effect} ({n_free(diag.best_)} free parameters) named over the refit"
        assert diag.report_["missing_effect"] != "contact_friction"
        close = flexible_within(diag, refit)
        for c, mean, se in close:
            print(f"    within the uncertainty: {c.effect} ({n_free(c)} free), the refit worse by "
                  f"{mean:+.3f} +- {se:.3f} mm^2")
            assert diag.best_ is not c
        exercised += bool(close)
    return exercised


def test_a_wrong_given_cohesion_is_not_replaced_by_its_three_parameter_look_alike() -> None:
    exercised = not_replaced_by_a_look_alike(EXERCISING_SEEDS)
    assert exercised >= 1, "no seed put a more flexible candidate within the uncertainty of the refit"


@pytest.mark.long
def test_a_wrong_given_cohesion_is_not_replaced_on_the_other_seeds() -> None:
    not_replaced_by_a_look_alike(tuple(s for s in COHESION_SEEDS if s not in EXERCISING_SEEDS))


@pytest.mark.long
@pytest.mark.xfail(strict=True, reason=(
    "measured on seeds 1-5 (4 loads x 2 repeats): the refit of cohesion is the verdict in seeds 3 and 4 only; "
    "seed 1: the refit is named (contact_friction a look-alike, 0.910 vs 0.905 mm) but the verdict is "
    "outside_library, the repeats scattering 1.28 mm, 2.1 x the 0.61 mm noise and a 0.2 deg friction scatter "
    "explain (the data's own scatter, the same with the true model); seeds 2 and 5: rate_friction (1 free "
    "parameter, as many as the refit) is named, held-out error 0.636 vs the refit's 0.711 mm (seed 2, better by "
    "0.101 +- 0.095 mm^2) and 0.670 vs 0.698 mm (seed 5, within the uncertainty; the tie between equally "
    "flexible entries goes to the lower error, so the look-alike rate_friction is named, low confidence, with "
    "the refit as its look-alike)"))
def test_a_wrong_given_cohesion_is_the_verdict_in_every_seed() -> None:
    verdicts = {seed: (diagnosed("cohesion:c_N=0.35", "cohesion:c_N=0.15", seed).report_["verdict"],
                       diagnosed("cohesion:c_N=0.35", "cohesion:c_N=0.15", seed).best_.effect)
                for seed in COHESION_SEEDS}
    print("\n[cohesion verdicts]", verdicts)
    assert all(v == ("refit_given_effect", "cohesion") for v in verdicts.values())

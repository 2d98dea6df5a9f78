"""The verdict's rules and their constants, in one place: :func:`decide` turns a diagnosis's
:class:`~triplanar.workbench.verdict.Evidence` into its :class:`~triplanar.workbench.verdict.Verdict` (the only
place one is made); :func:`examined_entry`, :func:`tries_combination` and :func:`step_accepted` answer the
questions the gathering asks on the way (which entry to examine, whether to try entries in combination, whether a
further entry joins one).

The rules:

* ``repeat_scatter_mm``: the discrepancy a perfect model would still show (repeats' spread about their mean
  path, :func:`~triplanar.workbench.discrepancy.repeat_scatter_mm`).
* Nothing to explain: baseline error below ``QUIET_FACTOR`` x scatter (and no bias common to all tests that an
  entry removes; below the scatter a bias lets any entry be examined only at p < ``HIDDEN_BIAS_ALPHA``) ->
  ``none_missing``, or ``outside_library`` when the residual shows a pattern (periodic, or repeats scattering beyond
  noise and the specimen). A weaker shared bias is said, but is not a pattern (:func:`_nothing_to_explain`: why).
* An entry *explains* the data when its improvement (fraction of the baseline error removed, cross-validated) is
  at least ``MIN_IMPROVEMENT`` and none of its parameters ends at the edge of its plausible range; of those, the
  one-standard-error rule names the simplest that fits as well as the best (:mod:`~triplanar.workbench.parsimony`).
  It is the verdict (``library_effect``, or ``refit_given_effect`` for a given effect refitted) when what it leaves
  is within ``EXPLAINED_FACTOR`` x scatter with no bias common to all tests, the repeats scatter no more than
  ``SCATTER_FACTOR`` x what noise and the specimen explain, and nothing periodic remains; else ``outside_library``
  ("what remains is not noise").
* Confidence ``high`` when, in addition, its improvement is at least ``HIGH_IMPROVEMENT``, the runner-up's
  cross-validated error is at least ``MARGIN`` x the winner's and worse by more than the uncertainty of the
  difference, no look-alike is known, no hint of a shared bias (p < ``HINT_ALPHA``) remains, no supported
  alternative form moves a named parameter outside its interval, and something was held out. Otherwise ``low``.
* Combinations: whenever the entry examined leaves a pattern (the verdict would be ``outside_library``), entries
  are added to it one at a time (:mod:`~triplanar.workbench.combine`); a further entry joins when it removes at
  least ``MIN_FALL`` of the current cross-validated error and beats the current model by more than the uncertainty
  of the difference (held-out squared errors over the tests), at most ``MAX_EFFECTS`` in all; once a second entry
  has joined, the first is re-examined given the second and replaced when another beats the pair by more than the
  uncertainty of the difference (:func:`swap_accepted`, stepwise selection's backward look); and when the best
  other single entry comes within ``MARGIN`` of the first (:func:`restart_from`), forward selection is run from it
  too and its combination kept when it beats the first's by more than the uncertainty of the difference; so it is
  from the entry the rigid block's test sees (:func:`rigidity_start`) when that test says ``instrument`` and another
  entry, or none (no entry explaining alone), was examined. Two or
  more are named (``library_effects``) when together they leave at most ``EXPLAINED_FACTOR`` x scatter with nothing
  periodic, beat the best single entry by more than the uncertainty of the difference, and the scatter is what
  noise and the specimen explain. A step is ``high`` when its runner-up leaves at least ``MARGIN`` x its error and
  it has no look-alike.

* An instrument seen by the rigid block (:func:`_instrument_cap`): physics alone is never named ``high`` when the
  contact points' mutual distances change along the travel.

* Look-alike groups (:func:`_effect_groups`): a named entry the data cannot tell from others (within one standard
  error of the difference) is reported with them as a group (``Verdict.groups``, the report's ``lookalike_groups``)
  and the shear test that decides.

* An extra force outside the library (:func:`_outside_force`): a verdict that would be ``high`` is ``low`` when one
  force located outside the library (:mod:`~triplanar.workbench.locate`), with fewer parameters, predicts the held-out
  loads within ``OUTSIDE_FORCE_SE`` standard errors of the difference from the named entries.

* Given numbers of the specimen and of the instruments (:func:`_given_numbers`, only when the audit fitted one in
  full, so a diagnosis without one decides as before): a number that explains is said ("your given X is probably Y
  [interval]") with the measurement that decides it; it caps the confidence at ``low`` (never raises it, never
  changes the kind or the named entries) when it is within ``MARGIN`` of the named entry or shares a signature with
  the entry examined or its look-alikes (reported as a group, e.g. mass and load-cell gain: weigh the block). Its
  ``SCREEN_*`` constants were set by hand on the kernel's data, not on the calibration set below; the instruments'
  numbers joined the audit with them unchanged (2026-11-29, ``docs/workbench.md``).

Which data chose the constants. First the project's own kernel traces (datasets made by :mod:`triplanar.labdata`
with the compiled kernel: the shipped ``data/lab_traces.csv``, the seeded datasets of ``tests/triplanar/workbench/``,
``benchmarks/threshold_check.py``, ``benchmarks/instrument_confusion.py``, ``benchmarks/interval_coverage.py``).
Then, re-chosen on data the kernel did not make: the TUNING part of the independent calibration set (seeds
1000-1033, ``benchmarks/workbench_calibration.py``; ``run --part tuning --out /work/calib3`` and ``run --redecide``
on its kept evidence, 2026-11-28; the table is in ``docs/workbench.md``). On it every value below was kept: with
each dataset's cause judged against what the data can show (``benchmarks/calibration_detectability.py``), the
verdict was right in 20 of 20 in-library datasets whose cause shows, 6 of 6 clean ones and 2 of 2 outside causes
that show, never ``high`` on a wrong answer once the actuator rise's interval admitted its form tolerance
(``Effect.form_tolerance_m``, not a rule here) and plane_tilt's sideways limit stopped reading as implausible
(``Parameter.limit_ends``). What no constant fixes there: an outside cause at the detectability limit (s1014, a thrust ripple) taken for
``time_offset`` removing 30.4 % (``MIN_IMPROVEMENT`` 0.34 would refuse it, but the nearest in-library verdict, a
refit, removes 37.7 %: too close to move the bar on one dataset), and a lateral rangefinder gain below the limit
(s1030, 23 %) called ``outside_library``. Those were left as they are; the held-out part reports the rest.

Then, on 2026-11-28, after the first held-out report (seeds 2000-2065; looked at, so tuning data since: 100 tuning
datasets, seeds 1000-1033 and 2000-2065, ``run --part tuning --out /work/calib4 --redecide``), the hidden-bias rule
got its own level ``HIDDEN_BIAS_ALPHA`` (:func:`examined_entry`, :func:`_nothing_to_explain` say why, with the
numbers) and every interval admits ``IMPLEMENTATION_TOLERANCE_M``; the other constants were kept. On those 100 the
verdict is right in 94 (60 of 62 in-library datasets whose cause shows, 16 of 16 clean ones, 6 of 8 outside causes,
12 of 14 below detectability; before: 91), never ``high`` on a wrong answer (before: once, s2040).

Reported on the held-out part, seeds 3000-3065 (66 datasets, run once with these rules; ``docs/workbench.md``): 40
of 43 in-library verdicts right (93 %: below the 95 % target), 10 of 10 clean ones ``none_missing``, never ``high``
on a wrong answer. Those seeds tune from then on; the next held-out part is seeds 4000-4065.

Then, on the 166 tuning datasets (seeds 1000-1033, 2000-2065, 3000-3065; the 36 that try a combination
re-diagnosed, the rest re-decided on their kept evidence: ``run --part tuning --out /work/calib4b``), a pair's first
entry is re-examined given the second (:func:`swap_accepted`; no constant of its own): s3022 (a time offset standing
in for an actuator's rise beside the right tip offset) became right, no other verdict changed; 101 of 105 in-library
verdicts right (before: 100), 103 of 105 counting a truth inside a named look-alike group (:func:`_effect_groups`,
new: s2020's contact friction beside the named load-cell gain, s3017's cohesion beside rate friction). Still wrong
in-library: s2063 (a rangefinder offset removing 29.9 %, under ``MIN_IMPROVEMENT``) and s3052 (the after-best
shared-bias test; no level separates it from the outside causes that test catches). No constant changed.

Reported on the held-out part, seeds 4000-4065 (66 datasets, run once with these rules, commit a0c9508;
``docs/workbench.md``): 39 of 42 in-library verdicts right (93 %: below the 95 % target again), 10 of 10 clean ones
``none_missing``, ``high`` on a wrong answer once (s4052: the time offset rightly named, its value 0.06 ms outside
its interval). Those seeds tune from then on; the next held-out part is seeds 7000-7065.

Then, on the 232 tuning datasets (seeds 1000-1033, 2000-2065, 3000-3065, 4000-4065; the 49 that try a combination
re-diagnosed, the rest re-decided: ``run --part tuning --out /work/calib4c``): forward selection also runs from a
close runner-up (:func:`restart_from`, its constant ``MARGIN``'s): s4051 (rate friction first, the actuator's rise
within 1.14 x; the truth a tip offset with the actuator's rise) became right, three pairs came out in the other
order, nothing else changed: 141 of 147 in-library right (before: 140), 143 counting named groups; and physics
alone is not ``high`` when the rigidity test says instrument (:func:`_instrument_cap`: no verdict changed).

Reported on the held-out part, seeds 7000-7065 (66 datasets, run once with these rules, commit 6cad9fd;
``docs/workbench.md``): 41 of 43 in-library verdicts right (95.3 %: the target met on this part; 120 of 128 over the
day's three held-out reports), 10 of 10 clean ones ``none_missing``, never ``high`` on a wrong answer; outside the
library 3 of 6. Those seeds tune from then on; the next held-out part is seeds 8000-8065.

Then, on 2026-11-29 (issue 33: never ``high`` on a wrong answer), the outside-force rule (:func:`_outside_force`,
its constant ``OUTSIDE_FORCE_SE``): a verdict that would be ``high`` is held against one extra force located outside
the library (:mod:`~triplanar.workbench.locate`), and is ``low`` when that force, with fewer parameters, predicts the
held-out loads within ``OUTSIDE_FORCE_SE`` standard errors of the difference. Chosen on 235 of the 298 tuning
datasets (seeds 1000-1033, 2000-2065, 3000-3065, 4000-4065, 7000-7065; every ``effect``, ``pair`` and
``outside_library`` one, 28 of the 45 refits; not the 17 refits and 46 clean ones that were never ``high`` in their
reports: only a ``high`` can change), generated and diagnosed with the rule's inputs kept
(``benchmarks/workbench_calibration.py`` rows, ``evidence.outside_force``). 64 were ``high`` without the rule (63 right,
one a right verdict with its value outside its interval, s4052); in 12 the named entries have more than one
parameter, and there the force located was worse than them by 2.08 standard errors at the least (s3027, end friction
with FP2 tilted, 5 parameters) and by 4.5-41.7 in the others. So at 2 (and at 1) the rule lowers none of the 63 right
``high`` s; allowed as many parameters as the named entries it would lower 3 at 2 standard errors (end friction s4054
at 1.6, s7000 at 1.7: a constant vertical force at CP1 or the tip; a load-cell gain s1029 at -0.4: a force along -e1
in proportion to the load, the gain's own physics) and 1 at 1, so a force must be simpler. No ``outside_library``
dataset there was ``high`` (45 of 45 diagnosed). Its benefit is on the stand-in laboratory's data
(``tests/triplanar/workbench/test_outside_library_findings.py``): a 2.5 N sideways pull named contact friction and a
rangefinder drift (5 parameters), the force located within 0.71 standard errors; a 15 N s/m drag named rate and
contact friction (4), the force (one following slip speed at the mass centre) within 1.44. At 1 standard error the
drag would stay ``high``; 2 is locate's own level for calling two forces alike (``locate.LOOKALIKE_SE``), kept, with
the nearest right ``high`` (2.08) close above it. Cost: one location per ``high`` naming more than one parameter (the
only ones it can lower, :func:`locates`; 12 of the 64: 0.3-0.4 CPU s against 3.7-18.3 CPU s for the diagnosis; the
measurement located for all 64, 0.3-0.7 CPU s each, and the held-out report below ran so, with the same verdicts).

Reported on the held-out part, seeds 8000-8065 (66 datasets, run once with these rules, commit 8fb791b;
``docs/workbench.md``, every line in ``docs/notes/workbench-calibration-heldout-8000.md``): 41 of 43 in-library
verdicts right (95.3 %), 10 of 10 clean ones ``none_missing``, never ``high`` on a wrong answer; the outside-force rule
lowered none of the 13 ``high`` s (all right). Those seeds tune from then on.

Then, on 2026-11-29 (issue 33 item 1: the instruments' given numbers in the audit, :mod:`~triplanar.workbench.given`),
what a given number says (:func:`_given_numbers`, :func:`_holds_given`, :func:`_number_bar`) and a combination's
idle step (:func:`_drop_idle`), chosen on 224 of the tuning datasets with the first beyond part (seeds 6000-6017)
in them: no in-library verdict or confidence changed, the beyond part's 13 -> 15 of 17
(``docs/notes/workbench-calibration-tuning.md``). Reported once (commit 3154a2a; ``docs/workbench.md``): the second
beyond part, seeds 6100-6135, 32 of 36 right (27 with the audit rule before), never ``high`` on a wrong answer; the
held-out part, seeds 9000-9065, 39 of 40 in-library verdicts right, 10 of 10 clean ones ``none_missing``, ``high`` on
a wrong answer once (s9052, a time offset's value 0.05 ms outside its interval), no verdict changed by the rules of
this change on the same evidence. Those seeds tune from then on.

Then, on 2026-11-29 (issue 33: two instrument gains at once), forward selection also starts from the entry the rigid
block's test sees (:func:`rigidity_start`, :data:`RIGIDITY_SEES`; no constant): chosen on the 326 tuning datasets
with kept evidence (seeds 1000-1033, 2000-2065, 57 of 3000-3065, 46 of 4000-4065, 6000-6017, 4 of 7000-7065,
6100-6135, 9000-9065; the four whose gathering it changes re-diagnosed, the rest re-decided), s6103, s6106 and
s6109 (a load-cell gain with an x1 rangefinder gain, partly cancelling) became right, named as the pair (``low``); no
other verdict changed (299 -> 302 of 326; s1030, a lateral rangefinder gain at D 0.83, stays ``outside_library``, as
does s7062 of the kept evidence of seeds 7000-8065, the one other dataset there it reaches;
``docs/notes/workbench-calibration-tuning.md``). Reported once (commit 1519c40; ``docs/workbench.md``): the third
beyond part, seeds 6200-6235, 30 of 36 right (the target of 90 % not met; the pair found by this start in 3 of the 4
pairs named right), never ``high`` on a wrong answer; the held-out part, seeds 10000-10065, 42 of 44 in-library
verdicts right, 10 of 10 clean ones ``none_missing``, never ``high`` on a wrong answer. Those seeds tune from then on.
On them (428 datasets with kept evidence, those two parts added), the start reaches a single entry named that the
rigid block's test cannot see, where it says ``instrument`` (:func:`tries_combination`): s6206 (the load-cell gain
named alone beside a true x1 rangefinder gain) became the pair; no other dataset's gathering changed (391 -> 392 of
428). Then, on the same 428 (issue 33: the beyond part's misses), the rigid block's test read in two more places:
a rangefinder gain admitted only by a hidden bias is not examined where the test finds the block rigid
(:func:`rigid_rules_out`: a clock, s6207, then said as the time base), a contact point's number is said where the test
finds the distances off the drawing and it removes more than every library entry (:func:`drawing_lead`: three pads
at the detectability limit, s6217, s6218, s6221), and the start from the rangefinder gain need not be plausible alone
(:func:`rigidity_start`: s6006). 392 -> 397 of 428 (the seven datasets whose gathering changed re-diagnosed, the rest
re-decided), no in-library verdict changed (``docs/notes/workbench-calibration-tuning.md``). Reported once (commit
b81dbd5; ``docs/workbench.md``): the fourth beyond part, seeds 6300-6335, 36 of 36 right (Wilson 90.4-100 %; 112 of
126 over the four beyond reports), never ``high`` on a wrong answer; the held-out part, seeds 11000-11065, 36 of 39
in-library verdicts right (92.3 %: below the 95 % target), 10 of 10 clean ones ``none_missing``, never ``high`` on a
wrong answer. Those seeds tune from then on; the next beyond part is 6400-6435, the next held-out part 12000-12065.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any, Mapping, Sequence

import numpy as np

from .given_audit import GivenAudit, effect_measurements
from .parsimony import difference_se, parsimonious
from .verdict import Evidence, NamedEffect, Reason, Verdict, VerdictKind, label

if TYPE_CHECKING:
    from .candidate_result import CandidateResult
    from .rigidity import RigidityResult

#: An entry explains when it removes at least this fraction of the model's error on held-out loads.
MIN_IMPROVEMENT = 0.3
#: ... and is named with ``high`` confidence only when it removes at least this fraction.
HIGH_IMPROVEMENT = 0.5
#: What an entry leaves is "within the scatter" up to this many times the repeats' scatter.
EXPLAINED_FACTOR = 2.0
#: The model as given needs nothing when its error is within this many times the repeats' scatter.
QUIET_FACTOR = 1.5
#: The runner-up must leave this many times the named entry's error for ``high`` confidence.
MARGIN = 1.25
#: The repeats' scatter may exceed what noise and the specimen's variability explain by this factor.
SCATTER_FACTOR = 2.0
#: The specimen's repeat-to-repeat friction scatter (deg) that ``expected_scatter_mm`` assumes (the shipped data's
#: laboratory: 0.2 deg).
FRICTION_SCATTER_DEG = 0.2
#: The residual "grows with travel" when its lateral error over the last third is this many times the first third's.
GROWTH_FACTOR = 2.0
#: A residual spectrum's peak this many times its median power counts as periodic (:mod:`~triplanar.workbench.evidence`).
#: Tests last 25-70 samples; on noise-only data (8 tests, tests/triplanar/workbench/test_workbench_verdicts.py's "none"
#: dataset) the largest ratio was 3.7, with a 10 Hz, 30 % thrust ripple 8.7-13.5 in 6 of 7 tests long enough to look.
PEAK_FACTOR = 6.0
#: The error is "mostly in time" when the travel lag's RMS exceeds this many times the mean path distance (case B on the
#: shipped end-friction data: 4 x; on the rate-friction dataset of tests/triplanar/workbench/test_workbench_verdicts.py:
#: 11.5 mm against 0.64 mm, 18 x).
MOSTLY_IN_TIME = 10.0
#: Significance level of :func:`~triplanar.workbench.evidence.systematic_bias` over all its features together
#: (Bonferroni): below it a bias is "systematic"; its false-positive rate on clean data is measured by
#: ``benchmarks/threshold_check.py`` (``docs/workbench.md``).
SYSTEMATIC_ALPHA = 0.01
#: Below this (and above ``SYSTEMATIC_ALPHA``) a shared bias is only hinted at: not a verdict, but no ``high``
#: confidence either (an unmodelled look-alike biases a parameter while leaving little else;
#: ``benchmarks/interval_coverage.py``); the intervals' model-form allowance uses it too.
HINT_ALPHA = 0.05
#: Every fitted value's 95 % interval admits the change that moves the traces by this much (m; the
#: :func:`~triplanar.workbench.intervals.form_allowance` of :func:`form_tolerance_mm`), whatever the effect: two
#: faithful implementations of the paper's equations differ by about 0.01 mm along a path where they differ at all
#: (``benchmarks/workbench_calibration.py check``: end friction with the law smoothed below 0.05 mm/s 0.011 mm, FP1
#: tilted 0.018 mm; issue 32). Chosen from that measurement, not from a dataset; on the tuning part (seeds 1000-1033,
#: 2000-2065) it widens the examined entries' intervals by 2 % of their half-width (median of 92; at most 28 %, a
#: rangefinder offset) and brings the one ``high`` with its truth outside
#: (s2040: a rangefinder gain's interval missing by 0.0005, which 0.008 mm of trace covers) inside; a 95 % interval
#: without it holds the truth 19 times in 20 by design, so a miss at ``high`` had no other cause to remove.
IMPLEMENTATION_TOLERANCE_M = 1e-5
#: A bias shared by all tests below the scatter lets an entry that removes less than ``MIN_IMPROVEMENT`` be examined
#: only at a p-value below this: ten times below the strongest such bias the independent implementation's own
#: difference left on the 16 clean tuning datasets (p = 0.0091, s2048; :func:`examined_entry` says what it decides).
HIDDEN_BIAS_ALPHA = 1e-3
#: A library verdict is not ``high`` when one extra force located outside the library (:func:`_outside_force`), with
#: fewer parameters, predicts the held-out loads within this many standard errors of the difference from the named
#: entries' held-out error (or better): :data:`~triplanar.workbench.locate.LOOKALIKE_SE`, the level at which locate
#: itself calls two forces alike (module doc: what 1 and 2 did on the tuning part).
OUTSIDE_FORCE_SE = 2.0
#: A further entry of a combination must remove at least this fraction of the current cross-validated error.
MIN_FALL = 0.1
#: At most this many entries in a combination.
MAX_EFFECTS = 3
#: The library entry that the rigid block's test sees (:mod:`~triplanar.workbench.rigidity`: a gain along one axis
#: stretches the contact triangle; a shared offset or drift, the load cell and the clock keep its distances), from
#: which forward selection also starts when that test says ``instrument`` (:func:`rigidity_start`).
RIGIDITY_SEES = "rangefinder_gain"

# -- the audit of the given numbers, the specimen's and the instruments' (triplanar/workbench/given.py) -------------
#: Each given number is screened by one forward-difference column of the fit's residual vector, a step of this
#: fraction of its drawing range (0.5 mm of a +-5 mm length, 1 % of the mass): large against the integrator's 1e-4 mm,
#: small against the range.
SCREEN_STEP = 0.05
#: A number is fitted in full only when a least-squares step along its column, within its drawing range, removes at
#: least this share of the squared discrepancy of the model diagnosed (0.2: the error falls by 11 %; less cannot be
#: named, MIN_IMPROVEMENT being 30 %). Chosen by hand on the kernel's data (tests/triplanar/workbench/
#: test_given_number_*.py), not on the independent calibration set: see docs/workbench.md.
SCREEN_SHARE = 0.2
#: At most this many given numbers of the specimen are fitted in full (the largest shares): each costs a candidate's
#: cross-validated fit.
MAX_AUDITED = 2
#: ...and at most this many of the instruments', beside them (so that the time base, by default the one instrument's
#: number fitted by the audit, never takes a specimen number's place: on the tuning part it had the larger share in
#: 75 of the first 252 datasets, 2026-11-29).
MAX_AUDITED_INSTRUMENTS = 1
#: The leading one-parameter candidates (by cross-validated error) whose signatures the audited numbers are compared
#: with for look-alike groups.
SCREEN_EFFECTS = 3


def _fmt(values: Mapping[str, float]) -> str:
    return ", ".join(f"{k} = {v:.4g}" for k, v in values.items())


def form_tolerance_mm(effect: str) -> float:
    """The trace difference (mm) a fitted value of ``effect`` admits in its interval: the larger of the effect's own
    form tolerance (``Effect.form_tolerance_m``: where the paper leaves its equations a choice) and
    ``IMPLEMENTATION_TOLERANCE_M``."""
    from ..effects import REGISTRY
    own = REGISTRY[effect].form_tolerance_m if effect in REGISTRY else 0.0
    return max(own, IMPLEMENTATION_TOLERANCE_M) * 1e3


def scatter_ok(ev: Evidence) -> bool:
    """The repeats scatter no more than ``SCATTER_FACTOR`` x what noise and the specimen explain."""
    scatter, expected = ev.repeat_scatter_mm, ev.expected_scatter_mm
    return not (math.isfinite(scatter) and math.isfinite(expected) and scatter > SCATTER_FACTOR * expected)


def examined_entry(ranked: Sequence[CandidateResult], baseline_error_mm: float, scatter_mm: float,
                   bias_p: float, rigidity: RigidityResult | None = None
                   ) -> tuple[CandidateResult | None, list[CandidateResult]]:
    """The entry a diagnosis examines (the parsimonious one of those that explain: plausible, removing at least
    ``MIN_IMPROVEMENT``) and its look-alikes. A bias shared by all tests below the scatter (the model as given within
    ``QUIET_FACTOR`` x scatter) whose p-value (``bias_p``, :func:`~triplanar.workbench.evidence.systematic_bias`'s
    ``p_value_all``) is below ``HIDDEN_BIAS_ALPHA`` opens the bar: an entry that removes any of the error may
    explain it (judged by what it leaves).

    Until 2026-11-28 any bias at ``SYSTEMATIC_ALPHA`` opened it. On the 100 tuning datasets (seeds 1000-1033,
    2000-2065) that path was taken 8 times, naming entries that removed 2-24 %: library instrument effects below
    detectability 4 times (s1031 p = 1.8e-8, s2062 8.4e-6, s2050 7.6e-7, s1032 4.8e-4), outside causes 3 times (s2019
    p = 2.1e-4: a sideways pull taken for rangefinder drift; s2024 2.4e-3, s2004 3.8e-3) and a clean dataset once
    (s2048, p = 0.0091, 2 %). What the entry removes does not tell them apart (the outside causes' 11-22 % lie among
    the library effects' 8-24 %; on the 16 clean datasets the best entry removes 0-7 %), nor does the significance of
    its gain; the bias's own strength partly does: the independent implementation's own difference from the model
    left a clean dataset a shared bias at p = 0.0091 (the smallest of the 16 clean datasets'), so a bias opens the bar
    only when it is an order of magnitude stronger than that (:data:`HIDDEN_BIAS_ALPHA`). Of the 8, the clean one and
    the two outside causes below detectability then become ``none_missing`` (right); the four instrument effects are
    still named (right); s2019 still is (wrong). The project's own kernel data, where the model is exact, show such
    biases far stronger (a lateral rangefinder gain of 20 %: p = 5e-18, ``test_workbench_instruments.py``)."""
    quiet = math.isfinite(scatter_mm) and baseline_error_mm <= QUIET_FACTOR * scatter_mm
    least = 1e-9 if quiet and bias_p < HIDDEN_BIAS_ALPHA else MIN_IMPROVEMENT
    explaining = [c for c in ranked if c.plausible and c.improvement >= least
                  and not (c.improvement < MIN_IMPROVEMENT and rigid_rules_out(c, rigidity))]
    return parsimonious(explaining) if explaining else (None, [])


def rigid_rules_out(entry: CandidateResult, rigidity: RigidityResult | None) -> bool:
    """Whether the rigid block's test contradicts ``entry``: it is :data:`RIGIDITY_SEES`, the one library entry that
    changes the contact points' mutual distances, and the test found them unchanged (``specimen_or_load``). Read only
    where a shared bias below the scatter opened the bar (:func:`examined_entry`: an entry removing less than
    ``MIN_IMPROVEMENT``, the weakest evidence a verdict rests on).

    Why (2026-11-29, the calibration's tuning part with its three beyond parts, 428 datasets with kept evidence): the
    test said ``instrument`` for every true rangefinder gain (25 of 25, p <= 2e-5) and ``specimen_or_load`` for every
    dataset without one or a moved contact point; the hidden-bias rule named the rangefinder gain twice where the
    block stayed rigid, both logger clocks 2-2.4 % off (s6110, s6207: gains x1 and x3 alike, 1.05, the stretch a
    slower clock puts on a path followed in time; a gain along one axis would have stretched the contact triangle as
    the block turned). A clock keeps every distance, a rangefinder gain does not."""
    return (entry.effect == RIGIDITY_SEES and entry.kind == "candidate" and rigidity is not None
            and rigidity.kind == "specimen_or_load")


def moved_outside(best: CandidateResult) -> list[dict[str, Any]]:
    """The supported alternatives that move a named parameter outside its curvature interval (with what they move)."""
    moved = []
    for name, alt in (best.model_form or {}).items():
        if not alt["supported"]:
            continue
        for p, v in alt["params"].items():
            ci = best.param_ci95.get(p)
            if ci is not None and not ci[0] <= v <= ci[1]:
                moved.append({"alternative": name, "param": p, "value": v, "ci95": ci})
    return moved


def residual_kinds(ev: Evidence, unexplained_mm: float) -> list[Reason]:
    """What kind of residual remains (the evidence of an ``outside_library`` verdict), one clause per kind."""
    kinds = []
    td = ev.time_domain_after
    if td.get("dominant_frequency_hz") is not None:
        kinds.append(Reason(f"periodic at {td['dominant_frequency_hz']:.1f} Hz (a spectral peak in "
                            f"{td['periodic_fraction']:.0%} of the tests)", "PEAK_FACTOR",
                            td["periodic_fraction"], 0.5))
    if math.isfinite(ev.growth_after) and ev.growth_after > GROWTH_FACTOR:
        kinds.append(Reason(f"growing with travel (the lateral error over the last third of the travel is "
                            f"{ev.growth_after:.1f} x that over the first)", "GROWTH_FACTOR", ev.growth_after,
                            GROWTH_FACTOR))
    scatter, expected = ev.repeat_scatter_mm, ev.expected_scatter_mm
    if not scatter_ok(ev):
        kinds.append(Reason(f"random from test to test (the repeats scatter {scatter:.2f} mm, {scatter / expected:.1f} x "
                            f"the {expected:.2f} mm that instrument noise ({ev.noise_mm:.2f} mm) and a "
                            f"{ev.friction_scatter_deg:g} deg friction scatter explain)", "SCATTER_FACTOR",
                            scatter / expected, SCATTER_FACTOR))
    bias = ev.systematic_after
    if bias["systematic"]:
        kinds.append(Reason(f"systematic, common to all tests (the {bias['feature']} averages {bias['mean']:+.3g} "
                            f"over the {bias['levels']} load levels, {abs(bias['z']):.1f} standard errors of the "
                            f"repeats' means from 0; p = {bias['p_value_all']:.2g})", "SYSTEMATIC_ALPHA",
                            bias["p_value_all"], SYSTEMATIC_ALPHA))
    if td.get("mostly_in_time"):
        kinds.append(Reason(f"mostly in time (travel lag {td['lag_rms_mm']:.2f} mm RMS against a mean path distance "
                            f"of {td['mean_distance_mm']:.2f} mm)", "MOSTLY_IN_TIME", td["lag_rms_mm"]))
    if not kinds and math.isfinite(unexplained_mm):
        kinds.append(Reason(f"{unexplained_mm:.2f} mm unexplained, without a periodic or travel-growing pattern",
                            "EXPLAINED_FACTOR", unexplained_mm))
    return kinds


def _joined(head: str, rule: str, value: float | None, parts: Sequence[Reason]) -> Reason:
    """One clause ``head`` followed by ``parts`` (the report's sentence keeps today's wording)."""
    return Reason(head + "; ".join(p.text for p in parts), rule, value)


@dataclass
class Judgement:
    """What the examined entry's confidence and verdict rest on (:func:`judge`)."""

    scatter: float              # the scatter what it leaves is judged against
    scatter_ok: bool            # the repeats scatter no more than noise and the specimen explain
    periodic: bool
    systematic: bool            # a bias common to all tests remains after it
    explained: bool             # what it leaves is within the scatter
    separated: bool             # the runner-up is worse by the margin and the uncertainty; no look-alike
    hinted: bool                # a hint (p < HINT_ALPHA) of a shared bias remains
    high: bool
    runner: CandidateResult | None
    moved: list[dict[str, Any]]  # alternatives that move a named parameter outside its interval (alternatives.py)

    @property
    def names_it(self) -> bool:
        """What it leaves is noise: it is the verdict."""
        return self.explained and self.scatter_ok and not self.periodic


def judge(ev: Evidence, best: CandidateResult) -> Judgement:
    """The evidence for the examined entry ``best``: what it leaves against the scatter, the runner-up and
    look-alikes, the residual's patterns; ``high`` when all of it holds."""
    scatter, expected = ev.repeat_scatter_mm, ev.expected_scatter_mm
    ok = scatter_ok(ev)
    periodic = ev.time_domain_after.get("dominant_frequency_hz") is not None
    systematic = ev.systematic_after["systematic"]
    others = [c for c in ev.ranked if c.key != best.key]
    runner = others[0] if others else None
    if best.per_test and math.isfinite(expected):
        # per-test parameters explain test-to-test differences: what they leave is judged against what noise
        # and the specimen explain, not against the repeats' scatter (which they are meant to absorb)
        scatter = min(scatter, expected) if math.isfinite(scatter) else expected
        ok = best.fit_error_mm <= SCATTER_FACTOR * expected
    explained = ((not math.isfinite(scatter)) or best.cv_error_mm <= EXPLAINED_FACTOR * scatter) and not systematic
    diff, diff_se = difference_se(best, runner) if runner is not None else (math.nan, math.nan)
    # the runner-up must be worse by the margin and by more than the uncertainty of the difference, and no
    # entry may be within that uncertainty of the one named (a look-alike)
    separated = runner is None or not math.isfinite(runner.cv_error_mm) or (
        runner.cv_error_mm >= MARGIN * best.cv_error_mm and not (math.isfinite(diff) and diff <= diff_se)
        and not ev.lookalikes)
    hinted = not systematic and ev.systematic_after["p_value_all"] < HINT_ALPHA
    moved = moved_outside(best)
    high = (best.improvement >= HIGH_IMPROVEMENT and explained and separated and ok and not periodic
            and not hinted and ev.held_out and not moved)
    return Judgement(scatter, ok, periodic, systematic, explained, separated, hinted, high, runner, moved)


def _why(ev: Evidence, best: CandidateResult, j: Judgement) -> list[Reason]:
    """The reason's clauses for the examined entry (before the verdict's own)."""
    expected, base = ev.expected_scatter_mm, ev.baseline_error_mm
    what = (f"refitting the given {best.effect} ({_fmt(best.given)} -> {_fmt(best.params)})"
            if best.kind == "refit" else best.effect)
    why = [Reason(f"{what} removes {best.improvement:.0%} of the error {ev.where}", "MIN_IMPROVEMENT",
                  best.improvement, MIN_IMPROVEMENT)]
    if math.isfinite(j.scatter):
        if best.per_test and math.isfinite(expected):
            why.append(Reason(f"leaving {best.cv_error_mm:.2f} mm against the {expected:.2f} mm that noise and the "
                              f"specimen explain (its per-test {', '.join(best.per_test)} absorb the repeats' scatter "
                              f"of {ev.repeat_scatter_mm:.2f} mm)", "EXPLAINED_FACTOR", best.cv_error_mm,
                              EXPLAINED_FACTOR * j.scatter))
        else:
            why.append(Reason(f"leaving {best.cv_error_mm:.2f} mm against a repeat scatter of {j.scatter:.2f} mm",
                              "EXPLAINED_FACTOR", best.cv_error_mm, EXPLAINED_FACTOR * j.scatter))
    top = ev.ranked[0]
    if best.key != top.key:
        why.append(Reason(f"{label(best)} ({len(best.params)} free parameter(s)) is named over {top.effect} "
                          f"({len(top.params)}), whose {ev.error_word} {top.cv_error_mm:.3f} mm is lower by less than "
                          f"the uncertainty of the difference (one-standard-error rule)", "parsimony.one_standard_error",
                          top.cv_error_mm))
    if ev.lookalikes:
        why.append(Reason("the data cannot tell it from " + ", ".join(
            f"{label(c)} ({ev.error_word} {c.cv_error_mm:.3f} mm)" for c in ev.lookalikes)
            + ": within the uncertainty of the difference", "parsimony.one_standard_error",
            ev.lookalikes[0].cv_error_mm))
    if j.runner is not None:
        why.append(Reason(f"runner-up {label(j.runner)} leaves {j.runner.cv_error_mm:.2f} mm", "MARGIN",
                          j.runner.cv_error_mm, MARGIN * best.cv_error_mm))
    td = ev.time_domain
    if td.get("mostly_in_time"):
        why.append(Reason(f"the model's error was mostly in time (travel lag {td['lag_rms_mm']:.2f} mm RMS, mean "
                          f"path distance {td['mean_distance_mm']:.2f} mm)", "MOSTLY_IN_TIME",
                          td["lag_rms_mm"]))
    bias = ev.systematic
    if bias["systematic"] and not j.systematic and math.isfinite(j.scatter) and base <= QUIET_FACTOR * j.scatter:
        why.append(Reason(f"the model as given left a bias common to all tests below the scatter "
                          f"({bias['feature']}, p = {bias['p_value_all']:.2g}) that it removes",
                          "SYSTEMATIC_ALPHA", bias["p_value_all"]))
    return why


def lacks(ev: Evidence, best: CandidateResult, j: Judgement) -> list[Reason]:
    """Why the confidence is not ``high``: one clause per rule that withheld it."""
    out = []
    if best.improvement < HIGH_IMPROVEMENT:
        out.append(Reason(f"it removes less than {HIGH_IMPROVEMENT:.0%}", "HIGH_IMPROVEMENT", best.improvement,
                          HIGH_IMPROVEMENT))
    if j.systematic:
        out.append(Reason("a bias common to all tests remains", "SYSTEMATIC_ALPHA",
                          ev.systematic_after["p_value_all"], SYSTEMATIC_ALPHA))
    elif not j.explained:
        out.append(Reason("what remains is well above the repeat scatter (another effect may be missing)",
                          "EXPLAINED_FACTOR", best.cv_error_mm, EXPLAINED_FACTOR * j.scatter))
    if not j.separated:
        out.append(Reason("a look-alike explains the data as well" if ev.lookalikes else
                          "the runner-up explains the data almost as well", "MARGIN",
                          j.runner.cv_error_mm if j.runner is not None else None, MARGIN * best.cv_error_mm))
    if not (j.scatter_ok and not j.periodic):
        out.append(Reason("the residual shows a pattern no library effect explains",
                          "PEAK_FACTOR" if j.periodic else "SCATTER_FACTOR"))
    if not ev.held_out:
        out.append(Reason("with one load level nothing was held out", "held_out", len(ev.folds), 2))
    if j.hinted:
        bias = ev.systematic_after
        out.append(Reason(f"a hint of a bias common to all tests remains ({bias['feature']}, p = "
                          f"{bias['p_value_all']:.2g}): an unmodelled effect may have shifted the parameters",
                          "HINT_ALPHA", bias["p_value_all"], HINT_ALPHA))
    for m in j.moved:
        out.append(Reason(f"the value depends on the model's form: with {m['alternative']} fitted too, {m['param']} = "
                          f"{m['value']:.4g}, outside [{m['ci95'][0]:.4g}, {m['ci95'][1]:.4g}]",
                          "alternatives.supported", m["value"]))
    return out


@dataclass
class _Draft:
    """The verdict while :func:`decide` builds it."""

    kind: VerdictKind = VerdictKind.OUTSIDE_LIBRARY
    effects: list[NamedEffect] = field(default_factory=list)
    missing_effect: str | None = None
    confidence: str = "none"
    reasons: list[Reason] = field(default_factory=list)
    unexplained_mm: float = math.nan
    combination: dict[str, Any] | None = None
    judged_entry: bool = False          # the verdict rests on the examined entry (it was judged, not bypassed)
    groups: list[dict[str, Any]] = field(default_factory=list)     # look-alike groups (effects, given numbers)


def _nothing_to_explain(ev: Evidence) -> _Draft | None:
    """The model as given is within the repeats' scatter (and no entry explains a shared bias below it): its verdict
    (``none_missing``, or ``outside_library`` when the residual has a pattern); else ``None``.

    A bias common to all tests below the scatter that no entry is examined for (weaker than ``HIDDEN_BIAS_ALPHA``, and
    none removes ``MIN_IMPROVEMENT``) is said in the reason but is not a pattern: on the tuning part (seeds 1000-1033,
    2000-2065) such biases came with a clean model (s2048: the independent implementation's own difference, p =
    0.0091) and with outside causes below detectability (s2004, s2024), where ``none_missing`` is right and
    ``outside_library`` would be wrong for the clean one."""
    scatter, expected, base = ev.repeat_scatter_mm, ev.expected_scatter_mm, ev.baseline_error_mm
    # a candidate with per-test parameters that brings the error down to what noise and the specimen explain
    # explains the repeats' excess scatter itself: it is judged below even when the error is within that scatter
    per_test_explains = (ev.best is not None and bool(ev.best.per_test) and math.isfinite(expected)
                         and ev.best.fit_error_mm <= SCATTER_FACTOR * expected)
    hidden_bias = ev.systematic["systematic"] and ev.best is not None   # below the scatter, but shared
    if not (math.isfinite(scatter) and base <= QUIET_FACTOR * scatter) or per_test_explains or hidden_bias:
        return None
    draft = _Draft(unexplained_mm=base)
    periodic = ev.time_domain_after.get("dominant_frequency_hz") is not None
    unexplained_bias = ev.systematic["systematic"] and ev.best is None
    if scatter_ok(ev) and not periodic and (unexplained_bias or not ev.systematic_after["systematic"]):
        draft.kind = VerdictKind.NONE_MISSING
        draft.reasons = [Reason(f"the model already matches the data to within the repeats' own scatter (error "
                                f"{base:.2f} mm, scatter {scatter:.2f} mm), and that scatter is what instrument "
                                f"noise and the specimen's variability explain ({expected:.2f} mm): nothing is "
                                f"missing", "QUIET_FACTOR", base, QUIET_FACTOR * scatter)]
        if unexplained_bias:
            bias = ev.systematic
            top = next((c for c in ev.ranked if c.plausible), None)
            draft.reasons.append(Reason(
                f"a bias common to all tests below the scatter remains ({bias['feature']}, p = "
                f"{bias['p_value_all']:.2g}) that no library entry removes {MIN_IMPROVEMENT:.0%} of"
                + (f" (the most, {label(top)}, {top.improvement:.0%})" if top is not None else "")
                + ": too small to name a cause", "SYSTEMATIC_ALPHA", bias["p_value_all"], SYSTEMATIC_ALPHA))
    else:
        draft.reasons = [_joined(f"the model matches the data as well as the repeats agree with each other (error "
                                 f"{base:.2f} mm, scatter {scatter:.2f} mm), but something outside the library "
                                 f"acts: ", "QUIET_FACTOR", base, residual_kinds(ev, base))]
    return draft


def _single_entry(ev: Evidence, best: CandidateResult, confidence: str) -> NamedEffect:
    """The named single entry as the report lists it."""
    report = {"effect": best.effect, "kind": best.kind, "params": dict(best.params),
              "param_ci95": dict(best.param_ci95),
              **({"param_profile_ci95": dict(best.param_profile_ci95)} if best.param_profile_ci95 else {}),
              **({"param_model_ci95": dict(best.param_model_ci95)} if best.param_model_ci95 else {}),
              "cv_error_mm": best.cv_error_mm, "share_of_improvement": best.improvement, "confidence": confidence}
    return NamedEffect(best.effect, best.kind, dict(best.params), dict(best.param_ci95), confidence,
                       dict(best.given), report)


def _single(ev: Evidence) -> _Draft:
    """The verdict on the evidence of single entries (no combination)."""
    quiet = _nothing_to_explain(ev)
    if quiet is not None:
        return quiet
    best, base = ev.best, ev.baseline_error_mm
    if best is None:
        top = ev.ranked[0] if ev.ranked else None
        detail = (f"; the best, {top.effect}, removes {top.improvement:.0%} of the error"
                  f"{'' if top.plausible else ' with an implausible ' + ', '.join(top.at_bound)}"
                  if top else "")
        reason = _joined(f"no candidate explains the discrepancy (none removes at least {MIN_IMPROVEMENT:.0%} of it "
                         f"with plausible parameters){detail}; what remains: ", "MIN_IMPROVEMENT",
                         top.improvement if top else None, residual_kinds(ev, base))
        return _Draft(reasons=[reason], unexplained_mm=base)
    j = judge(ev, best)
    draft = _Draft(confidence="high" if j.high else "low", unexplained_mm=best.cv_error_mm, judged_entry=True)
    draft.reasons = _why(ev, best, j)
    if j.names_it:
        draft.kind = VerdictKind.REFIT_GIVEN_EFFECT if best.kind == "refit" else VerdictKind.LIBRARY_EFFECT
        draft.effects = [_single_entry(ev, best, draft.confidence)]
        draft.missing_effect = best.effect if best.kind == "candidate" else None
    else:
        # a library effect helps, but what it leaves is not noise: say so rather than name it as the answer
        draft.missing_effect = best.effect if best.kind == "candidate" else None
        draft.reasons.append(_joined("but what remains is not noise: ", "EXPLAINED_FACTOR", best.cv_error_mm,
                                     residual_kinds(ev, best.cv_error_mm)))
    if not j.high:
        withheld = lacks(ev, best, j)
        draft.reasons.append(Reason("low confidence: " + "; ".join(r.text for r in withheld),
                                    ", ".join(dict.fromkeys(r.rule for r in withheld)) or "high",
                                    withheld[0].value if withheld else None, withheld[0].limit if withheld else None))
    return draft


def tries_combination(ev: Evidence) -> bool:
    """Whether to try entries in combination: the repeats' scatter is known, the examined entry (if any) has no
    per-test parameters, and either the verdict on single entries would be ``outside_library`` with the examined entry
    leaving a pattern (judged) or no entry examined and the rigid block's test pointing at one
    (:func:`rigidity_start`), or it would be ``library_effect`` naming an entry that test cannot see while it says a
    position channel misreads (the single verdict leaves the test's finding unexplained)."""
    single = _single(ev)
    if not math.isfinite(ev.repeat_scatter_mm) or (ev.best is not None and ev.best.per_test):
        return False
    if single.kind is VerdictKind.OUTSIDE_LIBRARY:
        return single.judged_entry if ev.best is not None else rigidity_start(ev) is not None
    return single.kind is VerdictKind.LIBRARY_EFFECT and rigidity_start(ev) is not None


def rigidity_start(ev: Evidence) -> CandidateResult | None:
    """The entry forward selection also starts from (:mod:`~triplanar.workbench.combine`) when the rigid block's
    contact points say a position channel misreads along the travel (``rigidity.kind`` ``instrument``) and the entry
    examined is not the library's one such misreading, :data:`RIGIDITY_SEES`: that entry (a candidate, plausible
    alone or not), else ``None``.

    Why (2026-11-29, the calibration's tuning part with its beyond parts, ``docs/notes/workbench-calibration-
    tuning.md``): the test said ``instrument`` in 22 of 326 datasets, each with a true rangefinder gain (17 of 17 of
    those datasets), and where a load-cell gain came with it the two partly cancel, so neither alone removed 30 %:
    no entry examined (s6106, s6109) or contact friction examined and nothing joining it (s6103), each
    ``outside_library``. Forward selection from the entry the test points at finds the pair there. After the report
    of those rules (seeds 6200-6235), also where the load-cell gain alone passed as the verdict (s6206, the test
    saying ``instrument``): :func:`tries_combination`. After the report of seeds 6200-6235 too, the start need not be
    plausible alone: where the load-cell gain partly cancels it the gain alone ends at its bound (0.7 or 1.3) and the
    pair's joint fit frees it again (7 of the 15 two-gain datasets; s6006 named a time offset with the load-cell gain
    instead; a start's pair replaces the first's only when it beats it by more than the uncertainty, and the pair's
    steps are judged as any combination's)."""
    rig = ev.rigidity
    if rig is None or rig.kind != "instrument" or (ev.best is not None and ev.best.effect == RIGIDITY_SEES):
        return None
    return next((c for c in ev.ranked if c.effect == RIGIDITY_SEES and c.kind == "candidate" and not c.per_test),
                None)


def combination_continues(current_mm: float, scatter_mm: float, steps: int) -> bool:
    """Whether to look for one more entry: fewer than ``MAX_EFFECTS`` so far, and (after the first, which left a
    pattern) what the entries so far leave is more than ``EXPLAINED_FACTOR`` x the scatter."""
    return steps < MAX_EFFECTS and (steps == 1 or current_mm > EXPLAINED_FACTOR * scatter_mm)


def beats(new: CandidateResult, current: CandidateResult) -> tuple[float, float]:
    """``(gain, its standard error)``: how much lower ``new``'s held-out squared error is than ``current``'s (mm^2,
    mean over the tests; :func:`~triplanar.workbench.parsimony.difference_se`)."""
    return difference_se(new, current)


def step_accepted(new: CandidateResult, current: CandidateResult) -> bool:
    """A further entry joins a combination when it removes at least ``MIN_FALL`` of the current cross-validated
    error and its gain is larger than the uncertainty of the gain."""
    if not math.isfinite(new.cv_error_mm) or new.cv_error_mm > (1 - MIN_FALL) * current.cv_error_mm:
        return False
    gain, se = beats(new, current)
    return not (math.isfinite(gain) and math.isfinite(se)) or gain > se


def swap_accepted(new: CandidateResult, current: CandidateResult) -> bool:
    """A pair re-examined (:mod:`~triplanar.workbench.combine`) takes a new first entry when the new pair's
    cross-validated error is lower and its gain is larger than the uncertainty of the gain (the same test as a step's
    and a combination's over the single entry)."""
    if not (math.isfinite(new.cv_error_mm) and new.cv_error_mm < current.cv_error_mm):
        return False
    gain, se = beats(new, current)
    return math.isfinite(gain) and math.isfinite(se) and gain > se


def restart_from(first: CandidateResult, runner: CandidateResult) -> bool:
    """Whether forward selection is also run from the runner-up single entry: it comes within ``MARGIN`` of the
    first (the first step would not be ``high``), so the first choice did not decide the path."""
    return math.isfinite(runner.cv_error_mm) and runner.cv_error_mm < MARGIN * first.cv_error_mm


def _step_confidence(step: Mapping[str, Any]) -> str:
    runner = step["runner_up_cv_error_mm"]
    separated = runner is None or not math.isfinite(runner) or runner >= MARGIN * step["cv_error_mm"]
    return "high" if separated and not step["indistinguishable_from"] else "low"


def _combined(ev: Evidence, draft: _Draft) -> _Draft:
    """The verdict once the combination tried is in: ``library_effects`` when it explains (module doc), else the
    single entries' verdict with what the combination left added to its reason."""
    comb = ev.combination
    assert comb is not None
    steps = [{**s, "confidence": _step_confidence(s)} for s in comb.steps]
    scatter = ev.repeat_scatter_mm
    explains = comb.cv_error_mm <= EXPLAINED_FACTOR * scatter and not comb.periodic
    draft.combination = {"steps": steps, "cv_error_mm": comb.cv_error_mm, "explains": explains,
                         "periodic": comb.periodic, "systematic": comb.systematic,
                         "gain_over_single_mm2": comb.gain_mm2, "gain_se_mm2": comb.gain_se_mm2}
    listed = "; then ".join(
        f"{'refitting the given ' if s['kind'] == 'refit' else ''}{s['effect']} ("
        + ", ".join(_format_value(k, v, s["param_ci95"].get(k)) for k, v in s["params"].items())
        + f") removes {s['share_of_improvement']:.0%}" for s in steps)
    beats_single = not (math.isfinite(comb.gain_mm2) and math.isfinite(comb.gain_se_mm2)) \
        or comb.gain_mm2 > comb.gain_se_mm2
    if len(steps) >= 2 and explains and beats_single and scatter_ok(ev):
        low = [f"{s['effect']} ({', '.join(s['indistinguishable_from'] or [str(s['runner_up'])])} "
               f"{'fits as well' if s['indistinguishable_from'] else 'comes close'})"
               for s in steps if s["confidence"] != "high"]
        reason = Reason(f"two or more library effects explain the discrepancy, none alone: {listed} of the error "
                        f"{ev.where}; together they leave {comb.cv_error_mm:.2f} mm against a repeat scatter of "
                        f"{scatter:.2f} mm" + (f"; low confidence at the step of {'; '.join(low)}" if low else ""),
                        "EXPLAINED_FACTOR", comb.cv_error_mm, EXPLAINED_FACTOR * scatter)
        named, idle = _drop_idle(steps)
        effects = [NamedEffect(s["effect"], s["kind"], dict(s["params"]), dict(s["param_ci95"]), s["confidence"],
                               dict(s.get("given") or {}), {k: v for k, v in s.items() if k != "given"})
                   for s in named]
        return _Draft(VerdictKind.LIBRARY_EFFECTS, effects,
                      next((s["effect"] for s in named if s["kind"] == "candidate"), None),
                      "high" if all(s["confidence"] == "high" for s in named) else "low", [reason, *idle],
                      comb.cv_error_mm, draft.combination, True)
    if len(steps) >= 2:
        draft.reasons.append(Reason(f"in combination ({listed} of the error {ev.where}) they still leave "
                                    f"{comb.cv_error_mm:.2f} mm" + (", periodic" if comb.periodic else ""),
                                    "EXPLAINED_FACTOR", comb.cv_error_mm, EXPLAINED_FACTOR * scatter))
    return draft


def _idle_parameters(step: Mapping[str, Any]) -> dict[str, Sequence[float]]:
    """A combination step's fitted parameters and their 95 % intervals (in the combination's joint fit) when every
    one holds the value at which the effect does nothing (its neutral value); else empty."""
    from ..effects import REGISTRY
    cls = REGISTRY.get(step["effect"])
    if cls is None or step["kind"] != "candidate":
        return {}
    cis = {k: ci for k, ci in step["param_ci95"].items() if ci is not None and k in cls.parameters}
    holds = all(ci[0] <= cls.parameters[k].neutral_value <= ci[1] for k, ci in cis.items())
    return cis if cis and holds else {}


def _drop_idle(steps: list[dict[str, Any]]) -> tuple[list[dict[str, Any]], list[Reason]]:
    """The steps a ``library_effects`` verdict names: not one that does nothing identifiable beside the others (every
    parameter's interval in the joint fit holds its neutral value: it removed its share at its step, and the entries
    that joined after it took that share over), as long as two remain; with the reason for each left out. On the
    calibration's first beyond part (seeds 6000-6017, tuning) a time offset came first for two instrument gains at
    once and ended at dt_s = 0.00033 s [-0.00079, 0.00145] beside them (s6003)."""
    idle = {i: _idle_parameters(s) for i, s in enumerate(steps)}
    idle = {i: p for i, p in idle.items() if p}
    if not idle or len(steps) - len(idle) < 2:
        return steps, []
    reasons = [Reason(f"{steps[i]['effect']} is not named: beside the others its "
                      + ", ".join(f"{k} [{ci[0]:.4g}, {ci[1]:.4g}]" for k, ci in p.items())
                      + " holds the value at which it does nothing", "combination.idle_step") for i, p in idle.items()]
    return [s for i, s in enumerate(steps) if i not in idle], reasons


def _effect_groups(ev: Evidence, draft: _Draft) -> _Draft:
    """The named entries' look-alike groups: a named entry whose held-out error the data cannot tell from other
    entries' (within one standard error of the difference, :func:`~triplanar.workbench.parsimony.parsimonious`) is
    named with them as a group, never alone with ``high`` (the confidence rules already make it ``low``), with the
    shear test that decides where :mod:`~triplanar.workbench.experiment` computed one and, for each instrument among
    them, the measurement outside the shear test that checks it (``given_audit.EFFECT_MEASUREMENT``). A laboratory
    then reads "one of these; this test decides" instead of a winner among twins (on the calibration's tuning part: rate friction
    named for cohesion, s3017; a load-cell gain for contact friction, s2020)."""
    if draft.kind is VerdictKind.LIBRARY_EFFECTS and draft.combination is not None:
        named = {e.effect for e in draft.effects}
        twins = [(s["effect"], list(s["indistinguishable_from"])) for s in draft.combination["steps"]
                 if s["effect"] in named]
    elif draft.kind in (VerdictKind.LIBRARY_EFFECT, VerdictKind.REFIT_GIVEN_EFFECT) and ev.best is not None:
        twins = [(label(ev.best), [label(c) for c in ev.lookalikes])]
    else:
        return draft
    for named, others in twins:
        if not others:
            continue
        deciding = [e["sentence"] for e in ev.experiments
                    if {named, *others} >= set(e["between"])] + effect_measurements([named, *others])
        draft.groups.append({"members": [named, *others], "source": "effects",
                             "deciding_measurement": "; ".join(deciding) if deciding else
                             "no deciding shear test was computed for this group"})
    return draft


def _format_value(name: str, value: float, ci: Sequence[float] | None) -> str:
    """``name = value [low, high]`` (the one interval format of every command's output)."""
    return f"{name} = {value:.4g}" + (f" [{ci[0]:.4g}, {ci[1]:.4g}]" if ci is not None else "")


def _given_numbers(ev: Evidence, draft: _Draft) -> _Draft:
    """The audit of the given numbers (specimen, instruments) on the draft (only when one was fitted in full, so a
    diagnosis without the audit decides as before). A number *explains* as an entry does (improvement at least
    ``MIN_IMPROVEMENT``, plausible; :func:`_number_bar`) and when its interval does not hold the value given
    (:func:`_holds_given`). Where an entry is named, a number that explains is said only as its rival: its
    cross-validated error within ``MARGIN`` x what the named entries leave (a number the named entries beat by more is
    not said: on the calibration's tuning part such sentences came only where every given number was right). A number
    said ("your given X is probably Y [interval]", with the measurement that decides it) caps the confidence at ``low``
    when it is such a rival, and is reported in a look-alike group with the entries examined (the named one and its
    look-alikes) whose signature is the same as its own within the noise (no shear test tells them apart), with the
    measurement that decides. A signature alike in the linearised screen does not make a twin of a number whose full
    fit the named entry beats by more than ``MARGIN`` (on the tuning part a time offset, s2065 and s4065: the clock's
    rate fitted in its place left 2.12 and 2.18 mm against 1.62 and 1.54 mm)."""
    named = {e.effect for e in draft.effects}
    examined = named | ({ev.best.effect, *(c.effect for c in ev.lookalikes)} if ev.best is not None else set())
    lead = drawing_lead(ev)
    for a in ev.given_numbers:
        least = _number_bar(ev) if a is not lead else min(_number_bar(ev), _lead_bar(ev))
        fit = a.fitted
        if fit is None or not fit.plausible or fit.improvement < least or _holds_given(a):
            continue
        close = fit.cv_error_mm <= MARGIN * draft.unexplained_mm
        twins = [g for g in a.group if g in examined] if close else []
        rival = bool(named) and close
        if named and not rival:
            continue
        _say_number(ev, draft, a, twins, rival, least)
        if a is lead and ev.rigidity is not None:
            draft.reasons.append(Reason(f"the rigid block's test points at it: {ev.rigidity.sentence}",
                                        "rigidity.instrument_or_drawing", ev.rigidity.statistic,
                                        ev.rigidity.threshold))
        if draft.confidence == "high" and rival:
            draft.confidence = "low"
            draft.effects = [_capped(e) for e in draft.effects]
    return draft


def _say_number(ev: Evidence, draft: _Draft, a: GivenAudit, twins: list[str], rival: bool, least: float) -> None:
    """The reasons (and the look-alike group) of a given number that explains (:func:`_given_numbers`)."""
    fit = a.fitted
    assert fit is not None
    p = fit.parameters[a.parameter]
    ci = "" if p.ci95 is None else f" [{p.ci95[0]:.4g}, {p.ci95[1]:.4g}]"
    draft.reasons.append(Reason(f"your given {a.name} = {a.screen.given:.4g} is probably {p.value:.4g}{ci} (it "
                                f"leaves {fit.cv_error_mm:.2f} mm {ev.where}; to decide: {a.deciding})",
                                "MIN_IMPROVEMENT", fit.improvement, least))
    if twins:
        members = [*twins, f"the given {a.name}"]
        deciding = a.deciding_with(twins)
        draft.groups.append({"members": [*twins, a.name], "source": "given", "deciding_measurement": deciding})
        draft.reasons.append(Reason(f"{' and '.join(members)} change the traces alike on these data (their "
                                    f"sensitivities agree within the noise, {ev.noise_floor_mm:.2f} mm): no shear "
                                    f"test tells them apart; to decide: {deciding}", "given.same_within_noise",
                                    fit.cv_error_mm, draft.unexplained_mm))
    elif rival:
        draft.reasons.append(Reason(f"the given {a.name} refitted leaves {fit.cv_error_mm:.2f} mm, within "
                                    f"{MARGIN:g} x the named entry's {draft.unexplained_mm:.2f} mm", "MARGIN",
                                    fit.cv_error_mm, MARGIN * draft.unexplained_mm))


def _holds_given(a: GivenAudit) -> bool:
    """Whether the fitted number's 95 % interval holds the value given: the data then do not say it is wrong."""
    assert a.fitted is not None
    ci = a.fitted.parameters[a.parameter].ci95
    return ci is not None and ci[0] <= a.screen.given <= ci[1]


def _number_bar(ev: Evidence) -> float:
    """What a given number must remove to be said: ``MIN_IMPROVEMENT``, as an entry; but when a bias shared by all tests
    below the scatter opened the bar for the entries (:func:`examined_entry`) and the entry examined removes less, what
    that entry removes (a number is held to the bar the entries were, and said only where it does at least as well as
    the entry named in its place: on the calibration's first beyond part, s6004, a clock 4 % fast, D 0.79, the time
    offset was named removing 19 % and the time base removed 23 %)."""
    best, scatter = ev.best, ev.repeat_scatter_mm
    quiet = math.isfinite(scatter) and ev.baseline_error_mm <= QUIET_FACTOR * scatter
    if quiet and best is not None and ev.systematic.get("p_value_all", 1.0) < HIDDEN_BIAS_ALPHA:
        return min(MIN_IMPROVEMENT, max(best.improvement, 1e-9))
    return MIN_IMPROVEMENT


def drawing_lead(ev: Evidence) -> GivenAudit | None:
    """The contact point's given number that the rigid block's test points at, if any: the test finds the contact
    points' mutual distances constant along the path but off the drawing's (``rigidity.kind``
    ``instrument_or_drawing``: a contact point machined off its drawing, or an offset on one position channel, which
    the library does not hold), and of the audited coordinates of the points of the pairs it finds off (plausible,
    their interval excluding the value given), this one removes the most. It is said when it removes more than every
    library entry (:func:`_lead_bar`), not only above ``MIN_IMPROVEMENT``: the test has already found the drawing
    wrong, the number says where.

    Why (2026-11-29, the calibration's tuning part with its three beyond parts, 428 datasets with kept evidence): the
    test said ``instrument_or_drawing`` for every moved pad (30 of 30: CP2 2-4 mm along x1, CP1-CP2 off by the move;
    CP3 along x3, CP1-CP3 and CP2-CP3) and for no other dataset; at the detectability limit (D 0.83-0.95, s6217,
    s6218, s6221) the moved coordinate removed 23-30 % (every library entry 1-8 %), its interval holding the truth,
    and the verdict was ``outside_library`` with nothing said."""
    rig = ev.rigidity
    if rig is None or rig.kind != "instrument_or_drawing":
        return None
    points = {p for pair in rig.broken for p in pair.replace("CP", "").split("-")}
    fits = [a for a in ev.given_numbers if a.fitted is not None and a.fitted.plausible and not _holds_given(a)
            and a.name.startswith("cp") and a.name[2] in points]
    return max(fits, key=lambda a: a.fitted.improvement, default=None)


def _lead_bar(ev: Evidence) -> float:
    """What the contact point's number the rigid block points at (:func:`drawing_lead`) must remove to be said:
    more than every plausible library entry (at most ``MIN_IMPROVEMENT``, the bar of any number)."""
    removed = [c.improvement for c in ev.ranked if c.plausible and math.isfinite(c.improvement)]
    return min(MIN_IMPROVEMENT, max([*removed, 0.0]) + 1e-9)


def _instrument_cap(ev: Evidence, draft: _Draft) -> _Draft:
    """No ``high`` for physics alone when the rigid block's contact points say an instrument is off
    (:mod:`~triplanar.workbench.rigidity`: their mutual distances change along the travel, which no force on the block
    can do): the named entries then act on the block only, and an instrument explanation was not ruled out. On the
    calibration's tuning part this changed no verdict (the test said ``instrument`` in 2 of the 102 datasets diagnosed
    with it, both a rangefinder gain named as one); it is the rule that keeps a physical cause from being named with
    confidence for an instrument fault the rigidity test sees."""
    rig = ev.rigidity
    if rig is None or rig.kind != "instrument" or draft.confidence != "high":
        return draft
    from ..effects import REGISTRY
    if any(REGISTRY[e.effect].acts_on == "instrument" for e in draft.effects if e.effect in REGISTRY):
        return draft
    draft.reasons.append(Reason(f"confidence low: {rig.sentence}", "rigidity.instrument", rig.statistic,
                                rig.threshold))
    draft.confidence = "low"
    draft.effects = [_capped(e) for e in draft.effects]
    return draft


def locates(ev: Evidence, verdict: Verdict) -> bool:
    """Whether the diagnosis locates a cause outside the library as one extra force
    (:func:`~triplanar.workbench.locate.locate`): for an ``outside_library`` verdict (evidence for the user), and for
    a ``high`` one naming more than one parameter (:func:`_outside_force` reads it; a ``low`` one it could not lower,
    and a force, one parameter at the least, is never simpler than one: on the tuning part 12 of the 64 ``high``
    verdicts named more)."""
    return verdict.kind is VerdictKind.OUTSIDE_LIBRARY or (verdict.confidence == "high"
                                                            and _named_parameters(ev, verdict)[1] > 1)


def _named_parameters(ev: Evidence, draft: _Draft | Verdict) -> tuple[Mapping[str, float], int]:
    """The named entries' held-out error per test (the combination's when it is named) and their parameter count."""
    if draft.kind is VerdictKind.LIBRARY_EFFECTS and ev.combination is not None:
        return ev.combination.held_out_mm, sum(len(e.params) for e in draft.effects)
    if ev.best is not None and draft.effects:
        return ev.best.held_out_mm, len(ev.best.params) + len(ev.best.per_test)
    return {}, 0


def outside_force_rival(ev: Evidence, draft: _Draft | Verdict) -> dict[str, Any] | None:
    """What :func:`_outside_force` compares (``None`` when no force was located or no held-out errors pair): the
    located force's parameters and held-out error, the named entries' (the combination's when it is named), the mean
    over the tests of the force's held-out squared error minus the named entries' (mm^2) with its standard error, and
    whether the rule fires."""
    loc = ev.located
    # the term with the least held-out error, whichever look-alike the sentence names (none when only weak)
    term = None if loc is None else loc.compared
    if term is None or not draft.effects:
        return None
    named_mm, count = _named_parameters(ev, draft)
    common = sorted(set(named_mm) & set(loc.held_out_mm))
    d = np.array([loc.held_out_mm[t] ** 2 - named_mm[t] ** 2 for t in common])
    d = d[np.isfinite(d)]
    if len(d) < 2:
        return None
    mean, se = float(d.mean()), float(d.std(ddof=1) / math.sqrt(len(d)))
    own = 3 if term.follows == "time" else 1        # a periodic force: amplitude, phase and its frequency
    return {"force": f"{term.label} ({term.size:.3g} {term.unit})", "force_parameters": own,
            "force_cv_mm": term.cv_error_mm, "named_parameters": count, "named_cv_mm": draft.unexplained_mm, "difference_mm2": mean,
            "difference_se_mm2": se, "fires": own < count and mean <= OUTSIDE_FORCE_SE * se}


def _outside_force(ev: Evidence, draft: _Draft) -> _Draft:
    """No ``high`` for library entries when one extra force outside the library (:mod:`~triplanar.workbench.locate`),
    with fewer parameters, predicts the held-out loads as well: its held-out squared error no worse than the named
    entries' by more than ``OUTSIDE_FORCE_SE`` standard errors of the difference (tests paired). The issue's rule for
    ``high``: no explanation comes within the uncertainty of the named one; the data then do not say that the named
    entries, rather than a cause the library does not hold, are at work (on the stand-in laboratory's data: a constant
    sideways pull named contact friction and a rangefinder drift, a viscous drag named rate and contact friction,
    ``tests/triplanar/workbench/test_outside_library_findings.py``)."""
    if draft.confidence != "high":
        return draft
    rival = outside_force_rival(ev, draft)
    if rival is None or not rival["fires"]:
        return draft
    draft.reasons.append(Reason(
        f"confidence low: one extra force outside the library, at the {rival['force']} ({rival['force_parameters']} "
        f"parameter(s) against the named {rival['named_parameters']}), predicts the held-out loads as well (its "
        f"held-out error {rival['force_cv_mm']:.2f} mm against {rival['named_cv_mm']:.2f} mm, within "
        f"{OUTSIDE_FORCE_SE:g} standard errors of the difference; the report's located field says what it is)",
        "located.outside_force",
        rival["difference_mm2"], OUTSIDE_FORCE_SE * rival["difference_se_mm2"]))
    draft.confidence = "low"
    draft.effects = [_capped(e) for e in draft.effects]
    return draft


def _capped(e: NamedEffect) -> NamedEffect:
    return replace(e, confidence="low", report={**e.report, "confidence": "low"} if "confidence" in e.report
                   else e.report)


def decide(ev: Evidence) -> Verdict:
    """The verdict on ``ev`` (module doc): the only place a :class:`~triplanar.workbench.verdict.Verdict` is made."""
    draft = _single(ev)
    if ev.experiments:
        draft.reasons += [Reason(e["sentence"], "experiment.deciding_experiment",
                                 (e.get("best") or {}).get("difference_mm")) for e in ev.experiments]
    if ev.combination is not None:
        draft = _combined(ev, draft)
    draft = _effect_groups(ev, draft)
    if any(a.fitted is not None for a in ev.given_numbers):
        draft = _given_numbers(ev, draft)
    draft = _instrument_cap(ev, draft)
    draft = _outside_force(ev, draft)
    return Verdict(draft.kind, tuple(draft.effects), draft.missing_effect, draft.confidence, tuple(draft.reasons),
                   draft.unexplained_mm, draft.combination, tuple(draft.groups))

"""Forward selection: diagnose, add the named effect, refit everything added so far, repeat.

Each round runs a :class:`~triplanar.workbench.diagnose.Diagnoser` on the current model (the user's model
plus the effects added so far). Each candidate is fitted jointly with the effects already added (their
parameters re-estimated, warm-started at their current values), so an early effect that absorbed part of a
later one's signature is corrected when the later one arrives. The named effect is added with the joint
fit's values. The loop stops when diagnose names nothing, when the addition removes less than
``min_fall`` of the current error, when what is left is within the repeats' own scatter (as diagnose would
conclude, without running it), or after ``max_effects`` additions. Every step records the error overall and
per load level: the
"watch the error fall" chart (:func:`triplanar.workbench.report.plot_error_fall`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

from ..measurement import MeasuredTest
from .candidates import Candidate
from .diagnose import Diagnoser
from .executor import ExecutorLike
from .fit import discrepancies, errors_by_load, evaluate_spec, overall_error
from .parameters import EffectParameters, FitParameter, listed, shared_values
from .rules import MIN_FALL, QUIET_FACTOR
from .spec import ModelSpec


@dataclass
class SelectionStep:
    """The model after one addition (step 0: the user's model, with the effects it started from held at their
    values). ``parameters``: every effect added so far as FitParameter objects from the joint fit of that round
    (:attr:`~triplanar.workbench.sweep.CandidateResult.joint`); ``effects``, ``stderr`` and ``ci95`` are views of
    it in the report's form."""

    added: str | None
    parameters: EffectParameters
    error_mm: float
    error_by_load: dict[float, float]
    confidence: str | None = None
    diagnosis: dict[str, Any] | None = field(default=None, repr=False)
    reason: str | None = None

    @property
    def effects(self) -> dict[str, dict[str, float]]:
        """``{effect: {param: value}}`` (held and shared parameters; per-test ones have no shared value)."""
        return shared_values(self.parameters)

    @property
    def stderr(self) -> dict[str, dict[str, float]]:
        """``{effect: {param: standard error}}`` of every fitted effect's free parameters."""
        return {e: {k: p.stderr for k, p in ps.items() if p.stderr is not None}
                for e, ps in self.parameters.items() if any(p.vary for p in ps.values())}

    @property
    def ci95(self) -> dict[str, dict[str, list[float] | None]]:
        """``{effect: {param: [low, high] or None}}`` of every fitted effect's shared parameters."""
        return {e: {k: listed(p.ci95) for k, p in ps.items() if p.shared}
                for e, ps in self.parameters.items() if any(p.vary for p in ps.values())}

    def as_json(self) -> dict[str, Any]:
        return {"added": self.added, "effects": self.effects, "param_stderr": self.stderr,
                "param_ci95": self.ci95,
                "error_mm": self.error_mm, "error_by_load_mm": {f"{k:g}": v for k, v in self.error_by_load.items()},
                "confidence": self.confidence, "reason": self.reason}


def held_parameters(values: Mapping[str, Mapping[str, float]]) -> EffectParameters:
    """``{effect: {param: value}}`` as FitParameter objects held at those values."""
    return {e: {k: FitParameter.held(e, k, v) for k, v in ps.items()} for e, ps in values.items()}


class ForwardSelection:
    """Add effects one at a time while the error keeps falling (scikit-learn style).

    Args:
        candidates: as for :class:`Diagnoser` (default: every screened registered effect).
        max_effects: most effects to add.
        min_fall: smallest fraction of the current error an addition must remove to be kept (default: the
            verdict rules' ``rules.MIN_FALL``, the one step rule of combinations).
        folds, executor, progress, max_nfev: passed to each :class:`Diagnoser` / :class:`EffectFit`.

    Fitted attributes: ``steps_`` (list of :class:`SelectionStep`, step 0 the user's model),
    ``added_`` (effect names in order), ``spec_`` (the final model), ``stop_reason_``.
    """

    def __init__(self, candidates: Sequence[str | Candidate] | None = None, max_effects: int = 3,
                 min_fall: float = MIN_FALL, folds: int = 3, executor: ExecutorLike = None, progress: bool = True,
                 max_nfev: int = 30):
        if isinstance(max_effects, bool) or not isinstance(max_effects, int) or max_effects < 1:
            raise ValueError(f"max_effects = {max_effects!r}: forward selection adds at least 1 effect")
        if isinstance(folds, bool) or not isinstance(folds, int) or folds < 2:
            raise ValueError(f"folds = {folds!r}: cross-validation needs at least 2 folds")
        self.candidates = candidates
        self.max_effects = max_effects
        self.min_fall = min_fall
        self.folds = folds
        self.executor = executor
        self.progress = progress
        self.max_nfev = max_nfev

    def fit(self, tests: Sequence[MeasuredTest], base: ModelSpec | None = None,
            initial: Mapping[str, Mapping[str, float]] | None = None) -> ForwardSelection:
        """Run the selection on ``tests`` from ``base`` (default case B). ``initial``: effects already added
        (``{name: {param: value}}``, e.g. from :class:`EffectFit`); they are refitted with every addition."""
        base = base or ModelSpec()
        tests = list(tests)
        values: dict[str, dict[str, float]] = {k: dict(v) for k, v in (initial or {}).items()}
        added: list[str] = list(values)
        diag = self._diagnoser().fit(tests, base, refit=values or None)
        self.steps_ = [SelectionStep(None, held_parameters(values), diag.baseline_error_mm_,
                                     dict(diag.baseline_by_load_))]
        self.diagnoses_ = [diag]
        self.stop_reason_ = f"{self.max_effects} effect(s) added (max_effects)"
        current = diag.base_
        while True:
            if diag.missing_effect_ is None:
                self.stop_reason_ = f"diagnose names no further effect: {diag.reason_}"
                break
            name = diag.missing_effect_
            best = next(c for c in diag.candidates_ if c.effect == name)
            spec = diag.best_spec()              # the joint fit of everything added so far, on all tests
            found = discrepancies(evaluate_spec(spec, tests))
            error = overall_error(found)
            previous = self.steps_[-1].error_mm
            fall = 1.0 - error / previous if previous > 0 else 0.0
            if not math.isfinite(fall) or fall < self.min_fall:
                self.stop_reason_ = (f"adding {name} removes only {fall:.0%} of the remaining error "
                                     f"(threshold {self.min_fall:.0%})")
                break
            added.append(name)
            values = {k: dict(best.all_values[k]) for k in added}
            current = spec
            self.steps_.append(SelectionStep(name, {k: dict(best.joint[k]) for k in added}, error,
                                             errors_by_load(found), diag.confidence_, diag.report_, diag.reason_))
            if len(added) - len(initial or {}) >= self.max_effects:
                break
            scatter = diag.repeat_scatter_mm_
            if math.isfinite(scatter) and error <= QUIET_FACTOR * scatter:
                self.stop_reason_ = (f"the model now matches the data to within the repeats' own scatter (error "
                                     f"{error:.2f} mm, scatter {scatter:.2f} mm): nothing is left to explain")
                break
            diag = self._diagnoser().fit(tests, base, refit=values)
            self.diagnoses_.append(diag)
        self.added_ = added
        self.spec_ = current
        return self

    def _diagnoser(self) -> Diagnoser:
        # no model-form step per round (as in diagnose's combinations): adding effects one at a time is itself the
        # search over the model's form, and the step would cost every round a refit per one-parameter effect
        return Diagnoser(self.candidates, self.folds, self.executor, self.progress, self.max_nfev, refit_given=False,
                         combine=False, model_form=False)

    @property
    def report_(self) -> dict[str, Any]:
        return {"steps": [s.as_json() for s in self.steps_], "added": self.added_, "stop_reason": self.stop_reason_,
                "model": self.spec_.describe()}

    def score(self, tests: Sequence[MeasuredTest]) -> float:
        """Fraction of the user's model's RMS discrepancy on ``tests`` that the selected effects remove."""
        base = overall_error(discrepancies(evaluate_spec(self.diagnoses_[0].base_, tests)))
        new = overall_error(discrepancies(evaluate_spec(self.spec_, tests)))
        return 1.0 - new / base if base > 0 else 0.0

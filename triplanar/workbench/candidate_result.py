"""What one candidate of a diagnosis is and gives: :class:`CandidateTask` (everything its cross-validated fit needs,
the unit of a sweep) and :class:`CandidateResult` (its line of the report). The fit itself is
:mod:`~triplanar.workbench.sweep`'s; these values live apart from it so that the rules, the verdict and the steps
that read results (parsimony, combinations, model-form alternatives) do not import the sweep."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any, Mapping, Sequence

from ..measurement import MeasuredTest
from .candidates import Candidate
from .parameters import EffectParameters, FitParameter, listed, shared_values, standard_errors
from .spec import ModelSpec


@dataclass
class CandidateResult:
    """One candidate's line of the report. ``parameters``: one
    :class:`~triplanar.workbench.parameters.FitParameter` per shared free parameter of the candidate (value, standard
    error, 95 % interval, status, and for the named entry its profile and model-form intervals); ``params``,
    ``param_stderr``, ``param_ci95``, ``param_status``, ``param_profile_ci95`` and ``param_model_ci95`` are views of
    it, in the report's form. ``intervals``: which further intervals were computed (``"profile"``: :func:`profile_result`;
    ``"model_form"``: :func:`~triplanar.workbench.alternatives.apply_alternatives`). ``joint``: every effect fitted
    with it (the candidate and the effects refitted jointly), each parameter the recipe names as a FitParameter from
    the fit on all tests (value, the sandwich standard error, the 95 % interval of a shared one, status);
    ``all_values``, ``all_stderr`` and ``all_ci95`` are views of it. (The candidate's own ``parameters`` take the
    larger of the sandwich and the jackknife over the folds as their standard error.)"""

    effect: str
    parameters: dict[str, FitParameter]
    cv_error_mm: float
    fit_error_mm: float
    improvement: float
    plausible: bool
    at_bound: list[str]
    cv_error_by_load: dict[float, float] = field(default_factory=dict)
    fold_params: list[dict[str, float]] = field(default_factory=list)
    seconds: float = 0.0
    nfev: int = 0
    joint: EffectParameters = field(default_factory=dict)
    kind: str = "candidate"     # "candidate" (added), "refit" (a given effect, freed) or "given" (a specimen number)
    given: dict[str, float] = field(default_factory=dict)   # refit: the values the user gave
    held_out_mm: dict[str, float] = field(default_factory=dict, repr=False)   # test_id -> its error when held out
    bias_ratio: float = 1.0      # evidence.bias_ratio of the full fit (the intervals' model-form allowance)
    model_form: dict[str, dict[str, Any]] = field(default_factory=dict)              # alternatives.py; named
    intervals: tuple[str, ...] = ()

    @property
    def key(self) -> tuple[str, str]:
        """``(kind, effect)``: what identifies an entry within one diagnosis (a candidate and a refit of the same
        effect are two entries). Entries are compared by it, never by identity, so that a diagnosis's Evidence read
        back from a file (:mod:`triplanar.plain_data`) gives the same verdict."""
        return (self.kind, self.effect)

    # -- views of ``joint`` ----------------------------------------------------------------------------------------
    @property
    def all_values(self) -> dict[str, dict[str, float]]:
        """``{effect: {param: value}}`` of every effect fitted with it (held and shared parameters)."""
        return shared_values(self.joint)

    @property
    def fixed(self) -> dict[str, float]:
        """``{param: value}`` of the parameters the candidate's recipe holds."""
        return {k: p.value for k, p in self.joint.get(self.effect, {}).items() if not p.vary}

    @property
    def per_test_values(self) -> dict[str, dict[str, dict[str, float]]]:
        """``{effect: {param: {test_id: value}}}`` of the per-test parameters of every effect fitted with it."""
        out = {e: {k: dict(p.per_test_values or {}) for k, p in ps.items() if p.per_test}
               for e, ps in self.joint.items()}
        return {e: v for e, v in out.items() if v}

    @property
    def per_test(self) -> dict[str, dict[str, Any]]:
        """``{param: summary}`` (:func:`~triplanar.workbench.pertest.summarize`) of the candidate's per-test
        parameters."""
        from .pertest import summarize
        return {k: summarize(p.per_test_values or {}) for k, p in self.joint.get(self.effect, {}).items()
                if p.per_test}

    @property
    def all_stderr(self) -> dict[str, dict[str, float]]:
        """``{effect: {param: sandwich standard error}}`` of the free parameters of every effect fitted with it."""
        return standard_errors(self.joint)

    @property
    def all_ci95(self) -> dict[str, dict[str, list[float] | None]]:
        """``{effect: {param: [low, high] or None}}`` of the shared parameters of every effect fitted with it."""
        return {e: {k: listed(p.ci95) for k, p in ps.items() if p.shared} for e, ps in self.joint.items()}

    # -- views of ``parameters`` (the report's dictionaries, in the recipe's order) -------------------------------
    @property
    def params(self) -> dict[str, float]:
        return {k: p.value for k, p in self.parameters.items()}

    @property
    def param_stderr(self) -> dict[str, float]:
        return {k: p.stderr for k, p in self.parameters.items() if p.stderr is not None}

    @property
    def param_ci95(self) -> dict[str, list[float] | None]:
        return {k: listed(p.ci95) for k, p in self.parameters.items()}

    @property
    def param_status(self) -> dict[str, str]:
        return {k: p.status for k, p in self.parameters.items()}

    @property
    def param_profile_ci95(self) -> dict[str, list[float] | None]:
        return {k: listed(p.profile_ci95) for k, p in self.parameters.items()} if "profile" in self.intervals else {}

    @property
    def param_model_ci95(self) -> dict[str, list[float] | None]:
        return ({k: listed(p.model_ci95) for k, p in self.parameters.items()} if "model_form" in self.intervals
                else {})

    def set_intervals(self, kind: str, found: Mapping[str, Sequence[float] | None]) -> None:
        """Record the ``"profile"`` or ``"model_form"`` intervals ``found`` (``{param: (low, high) or None}``)."""
        field_name = {"profile": "profile_ci95", "model_form": "model_ci95"}[kind]
        self.parameters = {k: replace(p, **{field_name: tuple(found[k]) if found.get(k) is not None else None})
                           for k, p in self.parameters.items()}
        self.intervals = (*(i for i in self.intervals if i != kind), kind)

    def as_json(self) -> dict[str, Any]:
        return {"effect": self.effect, "params": self.params, "param_ci95": self.param_ci95,
                **({"param_profile_ci95": self.param_profile_ci95} if self.param_profile_ci95 else {}),
                **({"param_model_ci95": self.param_model_ci95, "model_form": self.model_form}
                   if self.param_model_ci95 else {}),
                **({"per_test": self.per_test} if self.per_test else {}),
                "param_stderr": self.param_stderr,
                "cv_error_mm": self.cv_error_mm, "improvement": self.improvement, "kind": self.kind,
                "param_status": self.param_status, "fixed": self.fixed,
                **({"given": self.given} if self.kind in ("refit", "given") else {}),
                "fit_error_mm": self.fit_error_mm, "plausible": self.plausible, "at_bound": self.at_bound,
                "cv_error_by_load_mm": {f"{k:g}": v for k, v in self.cv_error_by_load.items()},
                "fold_params": self.fold_params, "fit_seconds": round(self.seconds, 3), "nfev": self.nfev,
                **({"refitted": {k: v for k, v in self.all_values.items() if k != self.effect}}
                   if len(self.all_values) > 1 else {})}


@dataclass(frozen=True)
class CandidateTask:
    """Everything one candidate's cross-validated fit needs (picklable: the unit of a diagnose sweep)."""

    base: ModelSpec
    candidate: Candidate
    tests: tuple[MeasuredTest, ...]
    folds: tuple[tuple[float, ...], ...]
    max_nfev: int = 30
    refit: tuple[Candidate, ...] = ()
    warm: Mapping[str, Mapping[str, float]] | None = None
    kind: str = "candidate"

    @property
    def key(self) -> str:
        return f"{self.kind}:{self.candidate.effect}"

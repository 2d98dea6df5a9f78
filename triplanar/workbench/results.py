"""The results of ``fit`` and ``diagnose`` as objects: what the command line prints (``report()``) and writes
(``to_json()``) comes from here, so a script gets the same report as the CLI.

* :class:`FitResult`: the model, the steps of a fit (the model as given, then one step per effect added, by
  :class:`~triplanar.workbench.fit.EffectFit` or by :class:`~triplanar.workbench.select.ForwardSelection`), the
  fitted model, why forward selection stopped, and the drawing the fit was made on (``fit.json``);
  :func:`fit_added` builds the steps of ``--add``.
* :class:`DiagnosisResult`: a :class:`~triplanar.workbench.diagnose.Diagnoser`'s report (``diagnose.json``)
  and the per-test discrepancies its figures show.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

from ..measurement import MeasuredTest
from .diagnose import Diagnoser
from .candidates import Candidate
from .discrepancy import TestDiscrepancy
from .executor import ExecutorLike
from .fit import EffectFit
from .parameters import (EffectParameters, FitParameter, at_bound_of, intervals_of, profiles_of, shared_values,
                         standard_errors, statuses_of)
from .pertest import describe, summarize
from .select import SelectionStep
from .spec import ModelSpec

__all__ = ["DiagnosisResult", "FitResult", "FitStep", "fit_added", "format_param"]


def format_param(name: str, value: float, ci: Sequence[float] | None, status: str | None,
                 profile: Sequence[float] | None = None, model: Sequence[float] | None = None) -> str:
    """``name = value [low, high]`` (then ``profile [low, high]`` and ``model form [low, high]`` when the
    profile-likelihood interval and the one that admits model-form error are given), or what kept it from having an
    interval."""
    if status == "fixed":
        return f"{name} = {value:.4g} (fixed)"
    if ci is None:
        why = {"not_moved": "never left its start", "degenerate": "the data do not pin it (degenerate covariance)"}
        return f"{name} = {value:.4g} ({why.get(status or '', 'no interval')})"
    note = {"at_bound": " (at the edge of its range)",
            "unidentified": " (not identified: the interval spans its whole plausible range)"}.get(status or "", "")
    more = f" profile [{profile[0]:.4g}, {profile[1]:.4g}]" if profile is not None else ""
    more += f" model form [{model[0]:.4g}, {model[1]:.4g}]" if model is not None else ""
    return f"{name} = {value:.4g} [{ci[0]:.4g}, {ci[1]:.4g}]{more}{note}"


def _by_load(errors: Mapping[float, float]) -> dict[str, float]:
    return {f"{k:g}": v for k, v in errors.items()}


@dataclass
class FitStep:
    """The model after one step of a fit. ``kind``: ``"given"`` (the model as given, before any addition),
    ``"fit"`` (an ``--add`` effect, fitted jointly with the earlier ones: :class:`EffectFit`) or ``"selection"``
    (an effect forward selection added, or its step 0). ``parameters``: every effect fitted so far, ``{effect:
    {param: FitParameter}}`` (value, vary, range, start, per-test values, standard error, intervals, status);
    ``effects``, ``stderr``, ``ci95``, ``status``, ``at_bound``, ``profile_ci95`` and ``per_test`` are views of it
    in the report's form. ``intervals``: which further intervals were computed (``"profile"``:
    :mod:`~triplanar.workbench.profile`)."""

    kind: str
    added: str | None
    parameters: EffectParameters
    error_mm: float
    error_by_load: dict[float, float]
    refitted: bool = False
    given: dict[str, float] | None = None
    confidence: str | None = None
    reason: str | None = None
    intervals: tuple[str, ...] = ()

    @classmethod
    def model_as_given(cls, fit: EffectFit) -> FitStep:
        return cls("given", None, {}, fit.baseline_error_mm_, dict(fit.baseline_by_load_))

    @classmethod
    def from_effect_fit(cls, added: str, fit: EffectFit) -> FitStep:
        return cls("fit", added, fit.parameters_, fit.error_mm_, dict(fit.error_by_load_), added in fit.refitted_,
                   fit.refitted_.get(added), intervals=fit.intervals_)

    @classmethod
    def from_selection(cls, step: SelectionStep) -> FitStep:
        return cls("selection", step.added, step.parameters, step.error_mm, dict(step.error_by_load),
                   confidence=step.confidence, reason=step.reason)

    # -- views of ``parameters`` ------------------------------------------------------------------------------
    @property
    def effects(self) -> dict[str, dict[str, float]]:
        """``{effect: {param: value}}``: held and shared values (per-test ones: ``per_test``)."""
        return shared_values(self.parameters)

    @property
    def stderr(self) -> dict[str, dict[str, float]]:
        """``{effect: {param: standard error}}`` of the fitted parameters."""
        return standard_errors(self.parameters)

    @property
    def ci95(self) -> dict[str, dict[str, list[float] | None]]:
        """``{effect: {param: [low, high] or None}}`` of the free parameters, shared ones first."""
        return intervals_of(self.parameters)

    @property
    def status(self) -> dict[str, dict[str, str]]:
        """``{effect: {param: status}}`` (:mod:`~triplanar.workbench.parameters`), free ones first."""
        return statuses_of(self.parameters)

    @property
    def at_bound(self) -> tuple[str, ...]:
        """``effect.param`` of the free parameters fitted to an end of their range (implausible)."""
        return at_bound_of(self.parameters)

    @property
    def profile_ci95(self) -> dict[str, dict[str, list[float] | None]]:
        """``{effect: {param: [low, high] or None}}``: the profile-likelihood intervals, when computed."""
        return profiles_of(self.parameters) if "profile" in self.intervals else {}

    @property
    def per_test(self) -> dict[str, dict[str, Any]]:
        """``{effect: {param: summary}}`` of the per-test parameters (:func:`~triplanar.workbench.pertest.summarize`)."""
        out = {e: {k: summarize(p.per_test_values or {}) for k, p in ps.items() if p.per_test}
               for e, ps in self.parameters.items()}
        return {e: v for e, v in out.items() if v}

    def to_json(self) -> dict[str, Any]:
        if self.kind == "selection":
            return SelectionStep(self.added, self.parameters, self.error_mm, self.error_by_load, self.confidence,
                                 None, self.reason).as_json()
        if self.kind == "given":
            return {"added": None, "effects": self.effects, "param_stderr": self.stderr, "error_mm": self.error_mm,
                    "error_by_load_mm": _by_load(self.error_by_load)}
        per_test, profile = self.per_test, self.profile_ci95
        return {"added": self.added, "refitted": self.refitted, "given": self.given, "effects": self.effects,
                "param_stderr": self.stderr, "param_ci95": self.ci95,
                **({"param_profile_ci95": profile} if profile else {}), "param_status": self.status,
                "at_bound": list(self.at_bound), "error_mm": self.error_mm,
                **({"per_test": per_test} if per_test else {}),
                "error_by_load_mm": _by_load(self.error_by_load)}

    def _param(self, p: FitParameter) -> str:
        if self.kind == "given":
            return f"{p.name} = {p.value:.4g} (fixed)"
        return format_param(p.name, p.value, p.ci95 if p.shared else None, p.status, p.profile_ci95)

    def report(self) -> str:
        """The step's line(s) of ``triplanar fit``'s printout."""
        what = ("model as given" if self.added is None else
                f"refit {self.added}" if self.refitted else f"+ {self.added}")
        params = "; ".join(f"{e}: " + ", ".join(self._param(p) for p in ps.values() if not p.per_test)
                           for e, ps in self.parameters.items())
        per_test = self.per_test
        if per_test:
            params += "; " + "; ".join(f"{e}: {describe(p, summary)}" for e, ps in per_test.items()
                                       for p, summary in ps.items())
        lines = [f"  {what:24s} RMS discrepancy {self.error_mm:8.3f} mm   {params}"]
        if self.confidence:
            lines.append(f"  {'':24s} confidence {self.confidence}: {self.reason or ''}")
        return "\n".join(lines)


def fit_added(add: Sequence[str | Candidate], tests: Sequence[MeasuredTest], base: ModelSpec,
              start: Mapping[str, Mapping[str, float]] | None = None, executor: ExecutorLike = None,
              per_test: Mapping[str, Sequence[str]] | None = None) -> tuple[list[FitStep], EffectFit | None]:
    """Add the effects ``add`` one at a time, each fit joint with the earlier ones and warm-started at their
    values (``start`` for the rest); the steps (the model as given first) and the last fit (``None`` without
    ``add``)."""
    steps: list[FitStep] = []
    values: dict[str, dict[str, float]] = {}
    fit = None
    per_test = per_test or {}
    for i, name in enumerate(add):
        fit = EffectFit(add[:i + 1], {**(start or {}), **values}, executor,
                        per_test={k: v for k, v in per_test.items() if k in add[:i + 1]}).fit(tests, base)
        if not steps:
            steps.append(FitStep.model_as_given(fit))
        values = fit.params_
        steps.append(FitStep.from_effect_fit(name if isinstance(name, str) else name.effect, fit))
    return steps, fit


@dataclass
class FitResult:
    """``triplanar fit``'s result (``fit.json``): the model as given, its ``steps``, the ``fitted_model``, why
    forward selection stopped (``None`` without forward selection) and the ``drawing`` it was fitted on
    (:func:`triplanar.prior.drawing_record`)."""

    model: str
    fitted_model: str
    steps: list[FitStep]
    stop_reason: str | None
    drawing: dict[str, Any]

    def to_json(self) -> dict[str, Any]:
        return {"model": self.model, "fitted_model": self.fitted_model, "steps": [s.to_json() for s in self.steps],
                "stop_reason": self.stop_reason, "drawing": self.drawing}

    def report(self) -> str:
        lines = [f"model: {self.model}", *(s.report() for s in self.steps)]
        if self.stop_reason:
            lines.append(f"forward selection stopped: {self.stop_reason}")
        return "\n".join(lines)


@dataclass
class DiagnosisResult:
    """``triplanar diagnose``'s result: the :class:`~triplanar.workbench.diagnose.Diagnoser`'s report
    (``diagnose.json``, described in ``docs/workbench.md``), and for the figures the per-test discrepancies of
    the model as given (``baseline``) and with the named entry (``after``, ``None`` without one)."""

    data: dict[str, Any]
    baseline: list[TestDiscrepancy] = field(repr=False)
    after: list[TestDiscrepancy] | None = field(repr=False)
    model: str
    best_label: str | None

    @classmethod
    def of(cls, diag: Diagnoser) -> DiagnosisResult:
        """The result of a fitted :class:`~triplanar.workbench.diagnose.Diagnoser`."""
        return cls(diag.report_, diag.baseline_, diag.after_, diag.base_.describe(), diag.best_label_)

    @property
    def verdict(self) -> str:
        return self.data["verdict"]

    @property
    def missing_effect(self) -> str | None:
        return self.data["missing_effect"]

    @property
    def confidence(self) -> str:
        return self.data["confidence"]

    @property
    def reason(self) -> str:
        return self.data["reason"]

    def to_json(self) -> dict[str, Any]:
        return self.data

    def report(self) -> str:
        return format_diagnosis(self.data)


def _candidate_lines(report: Mapping[str, Any]) -> list[str]:
    ranked = sorted([(c["cv_error_mm"], c["effect"], c) for c in report["candidates"]]
                    + [(c["cv_error_mm"], f"{c['effect']} (refit)", c) for c in report.get("refit_results", [])],
                    key=lambda x: (x[0] != x[0], x[0]))
    lines = []
    for i, (_, label, c) in enumerate(ranked, start=1):
        params = ", ".join(format_param(k, v, c.get("param_ci95", {}).get(k), c.get("param_status", {}).get(k),
                                        (c.get("param_profile_ci95") or {}).get(k),
                                        (c.get("param_model_ci95") or {}).get(k)) for k, v in c["params"].items())
        if c.get("per_test"):
            params = ", ".join([params, *(describe(k, summary) for k, summary in c["per_test"].items())])
        given = (" (given " + ", ".join(f"{k} = {v:.4g}" for k, v in c["given"].items()) + ")") if c.get("given") else ""
        flag = "" if c["plausible"] else f"  [implausible: {', '.join(c['at_bound'])} at the edge of its range]"
        lines.append(f"  {i:4d}  {label:24s}  {c['cv_error_mm']:11.3f}  {c['improvement']:10.0%}   "
                     f"{params}{given}{flag}")
    return lines


def _time_domain_lines(report: Mapping[str, Any]) -> list[str]:
    td = report.get("time_domain") or {}
    if not td.get("has_time"):
        return []
    freq = td.get("dominant_frequency_hz")
    return ["", f"in time (model as given): arrival error {td['arrival_error_s']:+.3f} s on average, travel lag "
                f"{td['lag_rms_mm']:.2f} mm RMS (mean path distance {td['mean_distance_mm']:.2f} mm); residual "
                + (f"periodic at {freq:.1f} Hz in {td['periodic_fraction']:.0%} of the tests" if freq is not None
                   else f"spectrum without a dominant frequency ({td['periodic_fraction']:.0%} of tests with a peak)")]


def _lookalike_lines(report: Mapping[str, Any]) -> list[str]:
    if not report.get("indistinguishable_from"):
        return []
    lines = ["", f"indistinguishable from the named entry on these data: {', '.join(report['indistinguishable_from'])}"]
    for exp in report.get("deciding_experiments") or []:
        lines.append(f"  {exp['sentence']}")
        lines.append("    load N  difference mm  / scatter  repeats for 95 %")
        for r in exp["rows"]:
            if r["difference_mm"] is not None:
                lines.append(f"    {r['load_N']:6.1f}  {r['difference_mm']:13.3f}  {r['ratio']:9.2f}  {r['repeats']:8d}")
            elif r.get("holds"):
                lines.append(f"    {r['load_N']:6.1f}  {r['note']}")
    return lines


def _given_number_lines(report: Mapping[str, Any]) -> list[str]:
    """The given numbers fitted in full by the audit (``given_numbers``), as the candidates are listed."""
    fitted = [a for a in report.get("given_numbers") or [] if "fitted" in a]
    if not fitted:
        return []
    error = "cv error mm" if report.get("cross_validated", True) else "in-sample mm"
    lines = ["", f"given numbers, screened and fitted ({error}, the given -> the fitted [95% interval]):"]
    for a in fitted:
        group = f"   same within the noise as {', '.join(a['group'])}" if a["group"] else ""
        lines.append(f"  {a['name']:24s} {a['cv_error_mm']:8.3f}   {a['given']:.4g} -> "
                     f"{format_param(a['name'], a['fitted'], a['ci95'], None)}   screen {a['screen_share']:.0%}{group}")
    return lines


def format_diagnosis(report: Mapping[str, Any]) -> str:
    """``triplanar diagnose``'s printout of a report (``diagnose.json``)."""
    noise = report.get("noise", {})
    lines = [f"model: {report['model']}  ({report['n_tests']} tests)",
             f"baseline RMS discrepancy {report['baseline_error_mm']:.3f} mm"
             + (f"; repeat scatter {report['repeat_scatter_mm']:.3f} mm" if report.get("repeat_scatter_mm") else "")
             + (f"; instrument noise {noise['instrument_noise_mm']:.3f} mm, scatter it and the specimen explain "
                f"{noise['expected_scatter_mm']:.3f} mm" if noise.get("expected_scatter_mm") else ""),
             "", "  rank  effect                    " + ("cv error mm" if report.get("cross_validated", True) else
                                                         "in-sample mm") + "  improvement  parameters [95% interval]"
             " (the named entry's profile-likelihood one, and the one that admits model-form error)"]
    lines += _candidate_lines(report)
    lines += _time_domain_lines(report)
    verdict = report["missing_effect"] or "none"
    many = report.get("missing_effects") or []
    if len(many) > 1:
        verdict = " + ".join(m["effect"] for m in many)
        lines += ["", "missing effects, in the order forward selection added them (parameters from their joint fit):"]
        for m in many:
            params = ", ".join(format_param(k, v, m["param_ci95"].get(k), None) for k, v in m["params"].items())
            lines.append(f"  {m['effect']:24s} {m['share_of_improvement']:6.0%} of the error   {params}   "
                         f"(confidence {m['confidence']})")
    lines += _lookalike_lines(report) + _given_number_lines(report)
    if report.get("rigidity"):
        lines += ["", f"rigidity ({report['rigidity']['kind']}): {report['rigidity']['sentence']}"]
    if report.get("located"):
        lines += ["", f"located outside the library: {report['located']['sentence']}"]
    kind = f" ({report['missing_kind']})" if report.get("missing_kind") else ""
    named = f"missing effect: {verdict}{kind}"
    if report.get("verdict") == "refit_given_effect":
        # nothing is missing: a value given was wrong; say which, and its new value
        wrong = [format_param(f"{w['effect']}.{w['param']}", w["fitted"], w["ci95"], None)
                 + ("" if w["given"] is None else f" (given {w['given']:.4g})") for w in report.get("wrong_given") or []]
        named = "wrong given parameter: " + ("; ".join(wrong) or ", ".join(m["effect"] for m in many))
    lines += ["", f"verdict: {report.get('verdict', '?')}   {named}   confidence: "
                  f"{report['confidence']}",
              f"why: {report['reason']}", f"time: {report['seconds']:.1f} s"]
    return "\n".join(lines)

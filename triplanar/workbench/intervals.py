"""95 % intervals of fitted parameters that account for test-to-test scatter and for model-form error.

The standard error is the larger of two estimates that both treat *tests* as the independent units:

* the cluster-robust sandwich of the full fit (one cluster per test; ``fit.sandwich_stderr``): the scatter of
  the tests' own pulls on the parameter, whatever its cause (noise, friction that differs per repeat);
* the delete-a-fold jackknife over the cross-validation fits (folds are load levels): how far the estimate
  moves when a third of the loads is left out, which also sees a parameter that drifts with load.

Model-form error: when the fitted model still leaves more error than the repeats scatter (``fit_error`` above
``scatter``), the residuals are not only scatter, and the part that is shared by all tests is invisible to
both estimates. The standard error is then multiplied by ``fit_error / scatter`` (a Birge ratio: the intervals
widen in proportion to the unexplained error; at or below the scatter the factor is 1). A model-form error smaller
than the scatter of one test still shows in the means of the repeats: the per-load means of signed residuals stand
away from zero by more than their standard errors. Their Birge ratio (``bias``,
:func:`triplanar.workbench.evidence.model_form_allowance`: applied where those means hint at a shared bias)
multiplies the standard error instead when it is the larger.

The interval is ``value +- t(0.975, n_tests - p) * stderr``, widened by the effect's form allowance
(:func:`form_allowance`: where the paper leaves the effect's equations a choice, ``Effect.form_tolerance_m``), and
clipped to the parameter's physical bounds.
A parameter that never left its start (the fit did not move it, or a snap set it back) gets no interval and
the status ``not_moved``; a zero or non-finite standard error (a degenerate covariance: the data do not pull
on the parameter) gets the status ``degenerate``; an interval that spans the whole fit range keeps its numbers
with the status ``unidentified`` (the data do not pin the parameter within its plausible range).
"""

from __future__ import annotations

import math

from scipy.stats import t as student_t


def inflation(fit_error_mm: float, scatter_mm: float) -> float:
    """The model-form factor ``max(1, fit_error / scatter)`` (1 without a scatter estimate)."""
    if not (math.isfinite(fit_error_mm) and math.isfinite(scatter_mm) and scatter_mm > 0):
        return 1.0
    return max(1.0, fit_error_mm / scatter_mm)


def standard_error(sandwich_se: float, jackknife_se: float, fit_error_mm: float, scatter_mm: float,
                   bias: float = 1.0) -> float:
    """The interval's standard error: the larger of the sandwich and the jackknife, times the model-form factor (the
    larger of :func:`inflation` and ``bias``); 0 when the sandwich is not finite (a degenerate covariance)."""
    se = max(sandwich_se if math.isfinite(sandwich_se) else 0.0, jackknife_se if math.isfinite(jackknife_se) else 0.0)
    if not math.isfinite(sandwich_se) or se <= 0.0:
        return 0.0
    return se * max(inflation(fit_error_mm, scatter_mm), bias if math.isfinite(bias) else 1.0)


def form_allowance(value: float, start: float, baseline_mm: float, fit_error_mm: float,
                   tolerance_mm: float) -> float:
    """The change of a parameter that moves the traces by ``tolerance_mm`` (the effect's form tolerance), at the
    fitted effect's own sensitivity: the error it removes, ``sqrt(baseline^2 - fit_error^2)``, per unit of its move
    from ``start`` (linear). 0 without a tolerance or a move. Added to the interval's half-width: two faithful
    implementations of the effect would fit values this far apart, whatever the data's scatter (on an independent
    implementation's actuator rise a 95 % interval of +-1.4 % held tau 4.7 % away, issue 32)."""
    removed = math.sqrt(max(baseline_mm ** 2 - fit_error_mm ** 2, 0.0)) if math.isfinite(fit_error_mm) else 0.0
    moved = abs(value - start)
    if tolerance_mm <= 0 or removed <= 0 or moved <= 0 or not math.isfinite(baseline_mm):
        return 0.0
    return tolerance_mm * moved / removed


def quantile(n_tests: int, n_free: int) -> float:
    """``t(0.975, n_tests - n_free)`` (at least one degree of freedom): tests are the independent units."""
    return float(student_t.ppf(0.975, max(1, n_tests - n_free)))


def interval95(value: float, sandwich_se: float, jackknife_se: float, n_tests: int, n_free: int,
               fit_error_mm: float, scatter_mm: float, bounds: tuple[float, float], start: float,
               fit_range: tuple[float, float], bias: float = 1.0, allowance: float = 0.0
               ) -> tuple[list[float] | None, str]:
    """(``[low, high]`` or ``None``, status) for one fitted parameter (module doc). ``bias``: the fitted model's
    :func:`~triplanar.workbench.evidence.bias_ratio` (the allowance for model-form error below the scatter);
    ``allowance``: :func:`form_allowance`, added to the half-width."""
    span = fit_range[1] - fit_range[0]
    if abs(value - start) <= 1e-9 * max(span, 1e-300):
        return None, "not_moved"
    se = standard_error(sandwich_se, jackknife_se, fit_error_mm, scatter_mm, bias)
    if se <= 0.0:
        return None, "degenerate"
    q = quantile(n_tests, n_free)
    half = q * se + (allowance if math.isfinite(allowance) else 0.0)
    ci = [max(bounds[0], value - half), min(bounds[1], value + half)]
    return ci, status_of(ci, fit_range)


def status_of(ci: list[float], fit_range: tuple[float, float]) -> str:
    """``unidentified`` when ``ci`` spans the whole fit range (the data allow anything over the plausible range, e.g.
    10 +- 2.7e9 Hz), else ``fitted``."""
    return "unidentified" if ci[0] <= fit_range[0] and ci[1] >= fit_range[1] else "fitted"

"""Profile-likelihood intervals: equal to the curvature interval where the model is linear in the parameter,
asymmetric where it is not, and each end where the calibrated profile statistic reaches the quantile; the model-form
interval, the hull of the supported alternatives."""

from __future__ import annotations

import numpy as np
import pytest

from triplanar.workbench.fitbase import ScaledBox
from triplanar.workbench.profile import Profile, curvature_variance, forward_jacobian, profile_interval

X = np.linspace(0.0, 1.0, 40)
RNG = np.random.default_rng(3)
NOISE = 0.05 * RNG.standard_normal(X.size)


class Curve(ScaledBox):
    """Residuals ``model(theta, x) - data`` over the box ``lo``-``hi`` (the part of a fit's Problem a profile uses)."""

    def __init__(self, model, truth: list[float], lo: list[float], hi: list[float]):
        self.model, self.lo, self.hi = model, np.array(lo, float), np.array(hi, float)
        self.names = [("curve", f"p{i}") for i in range(len(truth))]
        self.data = model(np.array(truth, float)) + NOISE

    def residuals(self, u: np.ndarray) -> np.ndarray:
        return self.model(self.natural(np.asarray(u, float))) - self.data


def fitted(problem: Curve) -> np.ndarray:
    from scipy.optimize import least_squares
    return least_squares(problem.residuals, np.full(problem.n, 0.5), bounds=(0.0, 1.0), xtol=1e-12,
                         ftol=1e-12).x


def curvature_interval(problem: Curve, u: np.ndarray, se: float, q: float, index: int = 0) -> list[float]:
    value = problem.natural(u)[index]
    return [value - q * se, value + q * se]


@pytest.mark.parametrize("two", [False, True])
def test_the_profile_interval_is_the_curvature_interval_where_the_model_is_linear(two: bool) -> None:
    if two:      # a slope and an offset: the offset is profiled out at every trial slope
        problem = Curve(lambda p: p[0] * X + p[1], [2.0, 0.3], [0.0, -1.0], [5.0, 1.0])
    else:
        problem = Curve(lambda p: p[0] * X, [2.0], [0.0], [5.0])
    u = fitted(problem)
    jac = forward_jacobian(problem, u)
    se = 3.0 * np.sqrt(curvature_variance(problem, jac, 0)) * 0.05   # any positive se: the profile is calibrated to it
    ci = profile_interval(problem, u, jac, 0, se, 2.0, (0.0, 5.0))
    expected = curvature_interval(problem, u, se, 2.0)
    assert ci is not None
    assert ci == pytest.approx(expected, abs=0.03 * se)


def test_the_profile_interval_is_asymmetric_where_the_model_saturates() -> None:
    # exp(-k x): the data pull less on k the larger it is, so the interval reaches further up than down
    problem = Curve(lambda p: np.exp(-p[0] * X), [3.0], [0.0], [20.0])
    u = fitted(problem)
    jac = forward_jacobian(problem, u)
    value = float(problem.natural(u)[0])
    se = 0.3 * value
    ci = profile_interval(problem, u, jac, 0, se, 2.0, (0.0, 20.0))
    assert ci is not None
    up, down = ci[1] - value, value - ci[0]
    assert up > 1.15 * down, (ci, value)                       # the curvature interval is symmetric by construction
    # each end is where the calibrated statistic reaches q^2 = 4
    prof = Profile(problem, u, 0)
    c = curvature_variance(problem, jac, 0)
    for end in ci:
        w = (prof.objective(end) - prof.s_min) * c / se ** 2
        assert w == pytest.approx(4.0, rel=0.05)


def test_no_profile_interval_without_a_standard_error() -> None:
    problem = Curve(lambda p: p[0] * X, [2.0], [0.0], [5.0])
    u = fitted(problem)
    jac = forward_jacobian(problem, u)
    assert profile_interval(problem, u, jac, 0, float("nan"), 2.0, (0.0, 5.0)) is None
    assert profile_interval(problem, u, jac, 0, 0.0, 2.0, (0.0, 5.0)) is None


def test_an_end_the_objective_never_reaches_is_the_bound() -> None:
    problem = Curve(lambda p: p[0] * X, [0.2], [0.0], [5.0])
    u = fitted(problem)
    jac = forward_jacobian(problem, u)
    value = float(problem.natural(u)[0])
    ci = profile_interval(problem, u, jac, 0, 0.5, 2.0, (0.0, 5.0))
    assert ci is not None and ci[0] == 0.0 and ci[1] == pytest.approx(value + 1.0, abs=0.02)


def test_the_model_form_interval_is_the_hull_of_the_supported_alternatives() -> None:
    from triplanar.workbench.alternatives import model_interval
    from triplanar.workbench.rules import moved_outside
    from triplanar.workbench.parameters import FitParameter
    from triplanar.workbench.sweep import CandidateResult
    phi = FitParameter("end_friction", "phi_deg", 8.6, True, 0.0, 20.0, stderr=0.2, ci95=(8.2, 9.0), status="fitted")
    best = CandidateResult("end_friction", {"phi_deg": phi}, 0.5, 0.5, 0.9, True, [])
    best.set_intervals("profile", {"phi_deg": [8.25, 9.1]})
    best.model_form = {
        "rate_friction": {"params": {"phi_deg": 7.7}, "added": {"a": 0.1}, "supported": True},
        "cohesion": {"params": {"phi_deg": 6.0}, "added": {"c_N": 0.01}, "supported": False},   # not asked for
        "tip_offset": {"params": {"phi_deg": 8.5}, "added": {"offset_m": 0.001}, "supported": True},
    }
    assert model_interval(best) == {"phi_deg": [7.7, 9.1]}
    moved = moved_outside(best)
    assert [(m["alternative"], m["value"]) for m in moved] == [("rate_friction", 7.7)]
    best.model_form["rate_friction"]["supported"] = False
    assert moved_outside(best) == [] and model_interval(best) == {"phi_deg": [8.2, 9.1]}
    best.set_intervals("model_form", model_interval(best))
    report = best.as_json()
    assert report["param_profile_ci95"] == {"phi_deg": [8.25, 9.1]} and report["param_model_ci95"] == {"phi_deg": [8.2, 9.1]}
    assert best.parameters["phi_deg"].model_ci95 == (8.2, 9.1) and report["param_stderr"] == {"phi_deg": 0.2}
    assert report["param_ci95"] == {"phi_deg": [8.2, 9.0]} and report["param_status"] == {"phi_deg": "fitted"}

"""The model-form allowance of a named entry's intervals: how far its parameters move when the model's form changes.

A 95 % interval from the curvature (or the profile) of one model's objective says how well the data pin a
parameter *if that model's form is right*. When something the model lacks mimics the named effect (an unmodelled
viscous drag resists the motion more at higher speed and load, as end friction does), the fit absorbs it into the
parameter and leaves no residual: no allowance built from residuals can see it. What can be seen is how much the
estimate depends on the form chosen. So the named entry is fitted again jointly with each *alternative*: every
registered one-parameter effect, physical or instrumental (library and plugin effects alike: a load cell that reads
5 % high is taken for a friction angle 5 deg too large), that is neither in the model nor named, on all tests, warm-started at the named values (the grid scan tries the alternative's parameter with the
named ones moved along: :func:`triplanar.workbench.fit.grid_start`). An alternative is *supported* by the data when
its parameter stands away from its neutral value by more than ``t(1 - 0.025 / k, n_tests - 1 - p)`` cluster-robust
standard errors (``k`` alternatives: a family-wise 5 % test, Bonferroni) and does not rest at the edge of its range;
the others are forms the data do not ask for (on clean data each moves the named parameters by chance, by about
the extra correlation they bring) and are ignored.

``param_model_ci95`` is the hull of the curvature interval, the profile interval and the named parameters' values
under every supported alternative: the interval that admits the model-form error the library can express (an
effect outside the library that mimics none of them still goes unseen; ``docs/workbench.md`` gives the measured
coverage). ``model_form`` lists, per alternative, the named parameters' values and the in-sample error. When an
alternative moves a named parameter outside its curvature interval, the confidence is not ``high``: the value
depends on a choice of model the data do not make.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, Sequence

from scipy.stats import t as student_t

from ..effects import REGISTRY
from ..measurement import MeasuredTest
from .candidates import default_candidate, screened_names
from .executor import ExecutorLike, run_tasks
from .fit import FitTask, run_fit
from .fitbase import FitOutcome

from .spec import ModelSpec

if TYPE_CHECKING:
    from .candidate_result import CandidateResult, CandidateTask

#: Least-squares evaluations of an alternative's joint fit (after its grid scan).
ALTERNATIVE_NFEV = 10


def alternative_names(user_base: ModelSpec, refit: Sequence[str], best: CandidateResult) -> list[str]:
    """The one-parameter effects ``diagnose`` screens (physics or instrument; :func:`.candidates.screened_names`),
    neither in the model (``user_base`` and the forward-selection effects ``refit``) nor the named ``best``."""
    taken = {*user_base.effect_names, *refit, best.effect}
    out = []
    for name in screened_names():
        free = [p for p in REGISTRY[name].parameters.values() if p.free or p.per_test]
        if name not in taken and len(free) == 1 and not free[0].per_test:
            out.append(name)
    return out


def model_form_of(best: CandidateResult, task: CandidateTask, tests: Sequence[MeasuredTest], user_base: ModelSpec,
                  refit: Sequence[str], executor: ExecutorLike = None) -> dict[str, dict[str, Any]] | None:
    """``best`` fitted with each alternative (module doc): per alternative, the named parameters' values, the
    alternative's own, its standard error, the in-sample error and whether the data support it (``None`` for an
    entry with per-test parameters or without intervals: nothing to widen)."""
    if best.per_test or not best.param_ci95:
        return None
    names = alternative_names(user_base, refit, best)
    warm = {best.effect: dict(best.all_values[best.effect]),
            **{c.effect: dict(best.all_values[c.effect]) for c in task.refit}}
    fits = [FitTask(task.base, (default_candidate(n, user_base.specimen), task.candidate, *task.refit),
                    tuple(tests), (), None, ALTERNATIVE_NFEV, f"alternative:{n}", warm) for n in names]
    outcomes: list[FitOutcome] = run_tasks(run_fit, fits, executor, False, desc="alternatives")
    found = {}
    # each alternative's parameter is tested against its neutral value at a family-wise 5 % (Bonferroni over them)
    level = float(student_t.ppf(1 - 0.025 / max(1, len(names)), max(1, len(tests) - 1 - len(best.params))))
    for name, out in zip(names, outcomes):
        (param,) = default_candidate(name).free
        value = out.values[name][param]
        start = default_candidate(name, user_base.specimen).start_values()[param]
        se = out.stderr.get(name, {}).get(param, math.nan)
        z = abs(value - start) / se if math.isfinite(se) and se > 0 else 0.0
        supported = f"{name}.{param}" not in out.at_bound and z > level
        found[name] = {"params": {p: out.values[best.effect][p] for p in best.params},
                       "added": {param: value}, "added_stderr": {param: se}, "error_mm": out.train_error_mm,
                       "supported": supported}
    return found


def model_interval(best: CandidateResult) -> dict[str, list[float] | None]:
    """The hull of the curvature and profile intervals and the values under the supported alternatives."""
    out: dict[str, list[float] | None] = {}
    for p, ci in best.param_ci95.items():
        if ci is None:
            out[p] = None
            continue
        values = [*ci, *(best.param_profile_ci95.get(p) or [])]
        values += [alt["params"][p] for alt in best.model_form.values() if alt["supported"]]
        out[p] = [min(values), max(values)]
    return out

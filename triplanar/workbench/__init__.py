"""The model-vs-measurement workbench: compare, see where it fails, diagnose, fit.

Python API (each step is also a CLI command: ``triplanar compare|diagnose|fit``)::

    from triplanar.workbench import load_tests, ModelSpec, compare, Diagnoser, EffectFit, ForwardSelection
    tests = load_tests("data/lab_traces.csv")              # validated against the reference specimen
    model = ModelSpec()                                     # case B: bare actuator, no end friction
    cmp = compare(tests, model); print(cmp.summary())       # discrepancy table + where it fails
    diag = Diagnoser().fit(tests, model)                    # which effect is missing?
    print(diag.report_["verdict"], diag.report_["missing_effect"], diag.report_["confidence"])
    fit = EffectFit(["end_friction"]).fit(tests, model)     # add it, fit its parameter
    print(fit.params_, fit.stderr_, fit.baseline_error_mm_, "->", fit.error_mm_)
    sel = ForwardSelection().fit(tests, model)              # diagnose-and-add until the error stops falling

Evaluation is a pure function over picklable tasks (:func:`evaluate` of an :class:`EvalTask`;
:func:`run_candidate` of a :class:`CandidateTask` for diagnose), mapped by a pluggable executor (default a
2-process pool; ``"serial"``; or any object with ``map``, e.g. a Ray pool). See ``docs/workbench.md``.
"""

from .candidates import BUILTIN, Candidate, builtin_candidates, candidate_library
from .compare import Comparison, compare, describe_pattern, load_tests
from .diagnose import CandidateResult, CandidateTask, Diagnoser, run_candidate
from .discrepancy import TestDiscrepancy, discrepancy, repeat_scatter_mm
from .executor import SerialExecutor, run_tasks
from .fit import EffectFit, FitOutcome, FitTask, errors_by_load, evaluate_spec, overall_error, run_fit
from .parameters import FitParameter
from .results import DiagnosisResult, FitResult, FitStep, fit_added
from .select import ForwardSelection, SelectionStep
from .spec import EvalResult, EvalTask, ModelSpec, evaluate

__all__ = ["BUILTIN", "Candidate", "builtin_candidates", "candidate_library", "Comparison", "compare",
           "describe_pattern", "load_tests", "CandidateResult", "CandidateTask", "Diagnoser", "run_candidate",
           "TestDiscrepancy", "discrepancy", "repeat_scatter_mm", "SerialExecutor", "run_tasks", "EffectFit",
           "FitOutcome", "FitTask", "errors_by_load", "evaluate_spec", "overall_error", "run_fit",
           "ForwardSelection", "SelectionStep", "EvalResult", "EvalTask", "ModelSpec", "evaluate", "FitParameter",
           "DiagnosisResult", "FitResult", "FitStep", "fit_added"]

"""The given numbers as candidates, the specimen's and the instruments': ``fit --free NAME`` and the audit in
``diagnose``.

A freed number of the specimen is a parameter of the ``specimen`` effect (:mod:`triplanar.specimen_numbers`), one of
the instruments a parameter of its instrument effect (:mod:`triplanar.instrument_numbers`), so each is fitted by the
same machinery that refits a given effect's parameter (:class:`~triplanar.workbench.fit.EffectFit`, its intervals
and profiles): :func:`specimen_candidate` and :func:`instrument_candidates` are their recipes (:func:`free_candidates`
either), over the drawing's or the calibration's tolerance unless a range is given.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import TYPE_CHECKING, Callable, Mapping, Sequence

import numpy as np

from ..effects import REGISTRY, EffectError
from ..instrument_numbers import INSTRUMENT_NUMBERS, check_instrument_range, number_of
from ..measurement import MeasuredTest
from ..specimen import Foundation, Specimen, reference
from ..specimen_numbers import NUMBERS, check_range, given_values, refusal
from . import rules
from .candidates import Candidate
from .executor import ExecutorLike
from .spec import EvalTask, ModelSpec, group_by_force
from .candidate_result import CandidateTask
from .given_audit import GivenAudit, Signature

if TYPE_CHECKING:
    from .verdict import Evidence

__all__ = ["GivenAudit", "audit_given", "free_candidates", "instrument_candidates", "parse_free", "specimen_candidate"]


def parse_free(items: list[str]) -> dict[str, tuple[float, float] | None]:
    """``--free NAME[=LOW:HIGH]`` (repeatable, SI units) as ``{name: (low, high) or None}``; names checked later."""
    out: dict[str, tuple[float, float] | None] = {}
    for item in items:
        name, eq, rng = (part.strip() for part in item.partition("="))
        if name in out:
            raise EffectError(f"--free {name}: given twice")
        if not eq:
            out[name] = None
            continue
        low, colon, high = rng.partition(":")
        try:
            if not colon:
                raise ValueError
            out[name] = (float(low), float(high))
        except ValueError:
            raise EffectError(f"--free {item!r}: expected NAME or NAME=LOW:HIGH (SI units), e.g. mass_kg=5.0:6.0") \
                from None
    return out


def specimen_candidate(free: Mapping[str, tuple[float, float] | None], specimen: Specimen | None = None,
                       foundation: Foundation | None = None) -> Candidate:
    """The recipe that frees the named numbers of ``specimen`` (default: the reference) from their given values,
    each over its range (``None``: the drawing's tolerance, :data:`triplanar.specimen_numbers.NUMBERS`). A name no
    specimen has, or a range the specimen cannot take, is refused naming the number (nothing is fitted)."""
    if not free:
        raise EffectError(f"nothing to free; freeable numbers: {', '.join(NUMBERS)}")
    if specimen is None or foundation is None:
        specimen, foundation = reference()
    for name in free:
        if name not in NUMBERS:
            check_range(name, 0.0, 1.0, specimen, foundation)      # refuses, listing the freeable numbers
    given = given_values(specimen)
    bounds = {}
    for name, rng in free.items():
        low, high = rng if rng is not None else _physical(name, given[name], specimen, foundation)
        check_range(name, low, high, specimen, foundation)
        if not low <= given[name] <= high:
            raise EffectError(f"{name}: the range {low:g}:{high:g} does not hold the given value {given[name]:g} "
                              f"{NUMBERS[name].unit} (a fit starts there)")
        bounds[name] = (low, high)
    return Candidate("specimen", tuple(bounds), bounds, {k: given[k] for k in bounds})


def _physical(name: str, given: float, specimen: Specimen, foundation: Foundation) -> tuple[float, float]:
    """The drawing's range of ``name`` about ``given``, each end drawn toward ``given`` (halving the distance, at most
    10 times) until the specimen passes its own check there (a flat block's inertia +-15 % can break the triangle
    inequality of its principal moments)."""
    ends = []
    for end in NUMBERS[name].drawing_range(given):
        for _ in range(10):
            if refusal(name, end, specimen, foundation) is None:
                break
            end = given + 0.5 * (end - given)
        ends.append(end)
    return ends[0], ends[1]


def instrument_candidates(free: Mapping[str, tuple[float, float] | None]) -> list[Candidate]:
    """The recipes that free the named numbers of the instruments (:data:`~triplanar.instrument_numbers.
    INSTRUMENT_NUMBERS`) from the calibration as given (the effect's identity value), each over its range (``None``:
    the calibration's tolerance), one candidate per instrument effect, its other parameters held at identity. A range
    the number cannot take is refused naming it (nothing is fitted)."""
    by_effect: dict[str, dict[str, tuple[float, float]]] = {}
    for name, rng in free.items():
        number = INSTRUMENT_NUMBERS[name]
        low, high = rng if rng is not None else number.calibration_range()
        check_instrument_range(name, low, high)
        by_effect.setdefault(number.effect, {})[number.param] = (low, high)
    out = []
    for effect, bounds in by_effect.items():
        params = REGISTRY[effect].parameters
        single = next(iter(bounds)) if len(bounds) == 1 else None      # scanned first, as a library candidate is
        out.append(Candidate(effect, tuple(bounds), bounds, {k: params[k].neutral_value for k in bounds},
                             fixed={k: p.neutral_value for k, p in params.items() if k not in bounds},
                             grid=(params[single].grid or 7) if single else 0))
    return out


def free_candidates(free: Mapping[str, tuple[float, float] | None], specimen: Specimen | None = None,
                    foundation: Foundation | None = None) -> list[Candidate]:
    """The recipes of ``fit --free``: the specimen's numbers in one candidate (:func:`specimen_candidate`), the
    instruments' one per effect (:func:`instrument_candidates`). A name neither has is refused listing both."""
    unknown = [n for n in free if n not in NUMBERS and n not in INSTRUMENT_NUMBERS]
    if unknown and not (unknown[0].startswith("cp") and unknown[0].endswith("_x2_m")):
        raise EffectError(f"no given number {unknown[0]!r}; freeable numbers: of the specimen {', '.join(NUMBERS)}; "
                          f"of the instruments {', '.join(INSTRUMENT_NUMBERS)}")
    of_specimen = {k: v for k, v in free.items() if k not in INSTRUMENT_NUMBERS}
    out = [specimen_candidate(of_specimen, specimen, foundation)] if of_specimen else []
    return out + instrument_candidates({k: v for k, v in free.items() if k in INSTRUMENT_NUMBERS})


# -- diagnose's audit of the given numbers ---------------------------------------------------------------------------

def _trials(base: ModelSpec, cand: Candidate, tests: Sequence[MeasuredTest]) -> tuple[
        list[ModelSpec], list[tuple[str, float, tuple[float, float], float]]]:
    """The models of a forward-difference Jacobian of ``cand`` at its start (the start first, then one per free
    parameter moved by :data:`~triplanar.workbench.rules.SCREEN_STEP` of its range) and, per parameter,
    ``(name, start, (lo, hi), step)`` in natural units."""
    from .fit import Problem
    problem = Problem(base, [cand], tests)
    u0 = problem.start()
    specs, steps = [problem.spec(problem.natural(u0))], []
    for i, (_, name) in enumerate(problem.names):
        h = rules.SCREEN_STEP if u0[i] + rules.SCREEN_STEP <= 1.0 else -rules.SCREEN_STEP
        u = u0.copy()
        u[i] += h
        specs.append(problem.spec(problem.natural(u)))
        span = float(problem.hi[i] - problem.lo[i])
        steps.append((name, float(problem.lo[i] + u0[i] * span), (float(problem.lo[i]), float(problem.hi[i])),
                      h * span))
    return specs, steps


def _residuals(specs: Sequence[ModelSpec], tests: Sequence[MeasuredTest], mapper: Callable) -> list[np.ndarray]:
    """The fit's residual vector of each model (in one ``map`` over every model and load level)."""
    from .fitbase import safe_evaluate
    groups = group_by_force(tests)
    tasks = [EvalTask(spec, f, groups[f], report=False) for spec in specs for f in groups]
    results = list(mapper(safe_evaluate, tasks))
    n = len(groups)
    return [np.concatenate([d.residuals for r in results[k * n:(k + 1) * n] for d in r.discrepancies])
            for k in range(len(specs))]


def _column(r: np.ndarray, r0: np.ndarray, step: float) -> np.ndarray:
    return (r - r0) / step if len(r) == len(r0) else np.zeros_like(r0)


def _columns(base: ModelSpec, cand: Candidate, tests: Sequence[MeasuredTest], mapper: Callable,
             r0: np.ndarray | None = None) -> tuple[np.ndarray, list[tuple[str, float, tuple[float, float],
                                                                         np.ndarray]]]:
    """``cand``'s residual at its start (``r0`` if given) and its Jacobian columns: ``(r0, [(param, start, (lo, hi),
    column)])``."""
    specs, steps = _trials(base, cand, tests)
    found = _residuals(specs if r0 is None else specs[1:], tests, mapper)
    if r0 is None:
        r0, found = found[0], found[1:]
    return r0, [(n, g, b, _column(r, r0, h)) for (n, g, b, h), r in zip(steps, found)]


def _signature(label: str, given: float, bounds: tuple[float, float], column: np.ndarray,
               r0: np.ndarray) -> Signature:
    """The share of ``|r0|^2`` the best step along ``column`` removes, the step clipped to ``bounds``."""
    norm = float(column @ column)
    total = float(r0 @ r0)
    if norm <= 0 or total <= 0 or not np.all(np.isfinite(column)):
        return Signature(label, given, column, 0.0, given)
    step = float(np.clip(-(column @ r0) / norm, bounds[0] - given, bounds[1] - given))
    left = r0 + step * column
    return Signature(label, given, column, max(0.0, 1.0 - float(left @ left) / total), given + step)


def same_within_noise(a: Signature, b: Signature, r0: np.ndarray, n_tests: int, noise_mm: float) -> bool:
    """Whether what ``a`` does to explain the discrepancy, ``b`` does too within the noise: the part of ``a``'s
    least-squares change of the traces that no multiple of ``b``'s column reproduces leaves an RMS error per test
    below ``noise_mm`` (the traces' own noise floor)."""
    assert a.column is not None and b.column is not None
    na, nb = float(a.column @ a.column), float(b.column @ b.column)
    if na <= 0 or nb <= 0:
        return False
    change = a.column * (-(a.column @ r0) / na)
    rest = change - b.column * ((b.column @ change) / nb)
    return math.sqrt(float(rest @ rest) / max(n_tests, 1)) <= noise_mm


def audit_given(ev: Evidence, tasks: Sequence[CandidateTask], tests: Sequence[MeasuredTest], executor: ExecutorLike,
                progress: bool = False) -> tuple[GivenAudit, ...]:
    """The audit of the given numbers, the specimen's and the instruments' (module doc of
    :mod:`triplanar.workbench.rules`, ``SCREEN_*``): every number screened by its linearised sensitivity at the model
    diagnosed; those that could remove at least ``SCREEN_SHARE`` of the squared discrepancy within their tolerance
    (at most ``MAX_AUDITED`` of the specimen's and ``MAX_AUDITED_INSTRUMENTS`` of the instruments', largest first)
    fitted in full (cross-validated, as a candidate), but an instrument's number whose effect the diagnosis tries as a
    candidate (that fit is the candidate's); each grouped with the numbers
    and the leading effects whose signature is the same within the noise. Nothing is audited when the model already
    sets numbers through a ``specimen`` effect (``--effect specimen:...``): write them in the specimen file instead."""
    from .executor import executor_scope
    if "specimen" in ev.base.effect_names:
        return ()           # numbers already set by an effect: the audit would re-give them (write them in the file)
    specimen, foundation = ev.base.specimen, ev.base.foundation
    if specimen is None or foundation is None:
        specimen, foundation = reference()
    specs, steps, n_numbers = _screen_models(ev, tasks, tests, specimen, foundation)
    with executor_scope(executor, len({t.shear_force_N for t in tests})) as ex:
        r0, *found = _residuals(specs, tests, ex.map)     # one map: every model at every load level
    signatures = [_signature(n, g, b, _column(r, r0, h), r0) for (n, g, b, h), r in zip(steps, found)]
    numbers, effects = signatures[:n_numbers], signatures[n_numbers:]
    tried = {t.candidate.effect for t in tasks if t.kind == "candidate"}
    likely = sorted((s for s in numbers if s.share >= rules.SCREEN_SHARE and _fitted_here(s.label, tried)),
                    key=lambda s: -s.share)
    chosen = ([s for s in likely if s.label not in INSTRUMENT_NUMBERS][:rules.MAX_AUDITED]
              + [s for s in likely if s.label in INSTRUMENT_NUMBERS][:rules.MAX_AUDITED_INSTRUMENTS])
    fitted = _fit_in_full(ev, tasks, tests, executor, progress, [s.label for s in chosen], specimen, foundation)
    out = []
    for s in numbers:
        group = _group(s, [*effects, *numbers], r0, len(tests), ev.noise_floor_mm) if s.label in fitted else ()
        out.append(GivenAudit(s.label, replace(s, column=None), fitted.get(s.label), group))
    return tuple(sorted(out, key=lambda a: -a.screen.share))


def _screen_models(ev: Evidence, tasks: Sequence[CandidateTask], tests: Sequence[MeasuredTest], specimen: Specimen,
                   foundation: Foundation) -> tuple[list[ModelSpec], list[tuple[str, float, tuple[float, float], float]],
                                                    int]:
    """The models of the audit's screen (the model diagnosed first), the step of each column (:func:`_trials`) and how
    many of them are given numbers: the specimen's, the instruments' (those whose effect the model does not set: a
    given instrument effect is refitted as one), then the leading one-parameter candidates' (``effect.param``)."""
    specs, steps = _trials(ev.base, specimen_candidate(dict.fromkeys(NUMBERS), specimen, foundation), tests)
    unset = {k: None for k, n in INSTRUMENT_NUMBERS.items() if n.effect not in ev.base.effect_names}
    for cand in instrument_candidates(unset):      # (their start is the model as given: the first model stands for it)
        more, found = _trials(ev.base, cand, tests)
        specs += more[1:]
        steps += [(number_of(cand.effect, p) or p, g, b, h) for p, g, b, h in found]
    n_numbers = len(steps)
    leading = [t for t in sorted(tasks, key=lambda t: _rank(ev, t)) if t.kind == "candidate"
               and len(t.candidate.shared) == 1 and not t.candidate.per_test][:rules.SCREEN_EFFECTS]
    for t in leading:
        more, [(p, g, b, h)] = _trials(ev.base, t.candidate, tests)
        specs.append(more[1])
        steps.append((f"{t.candidate.effect}.{p}", g, b, h))
    return specs, steps, n_numbers


def _fitted_here(label: str, tried: set[str]) -> bool:
    """Whether the audit fits ``label`` in full: a specimen number, or an instrument's whose effect is not a
    candidate of the diagnosis (else the candidate's fit is that number's, ranked with the others)."""
    number = INSTRUMENT_NUMBERS.get(label)
    return number is None or number.effect not in tried


def _fit_in_full(ev: Evidence, tasks: Sequence[CandidateTask], tests: Sequence[MeasuredTest], executor: ExecutorLike,
                 progress: bool, names: Sequence[str], specimen: Specimen, foundation: Foundation) -> dict:
    """The cross-validated fit of each named number alone, as a candidate: ``{name: CandidateResult}``."""
    from .executor import run_tasks
    from .sweep import assemble, run_candidate
    cands = [instrument_candidates({n: None})[0] if n in INSTRUMENT_NUMBERS
             else specimen_candidate({n: None}, specimen, foundation) for n in names]
    fit_tasks = [CandidateTask(ev.user_base, c, tuple(tests), tuple(tuple(f) for f in ev.folds),
                               tasks[0].max_nfev if tasks else 30, tasks[0].refit if tasks else (), kind="given")
                 for c in cands]
    outcomes = run_tasks(run_candidate, fit_tasks, executor, progress, desc="audit") if fit_tasks else []
    # (each task is assembled from its own outcomes: two numbers of the specimen share the key "given:specimen")
    return {n: assemble(t, {f"{t.key}/{k}": v for k, v in out.items()}, len(ev.folds), len(tests),
                        ev.baseline_error_mm, ev.repeat_scatter_mm)
            for n, t, out in zip(names, fit_tasks, outcomes)}


def _cause(label: str) -> str:
    """What a screened column stands for in a look-alike group: an effect's name (an instrument number's is its
    effect's: ``rangefinder_gain_x1`` and the candidate ``rangefinder_gain`` are one instrument), or a specimen number's."""
    number = INSTRUMENT_NUMBERS.get(label)
    return number.effect if number is not None else label.split(".")[0]


def _group(s: Signature, others: Sequence[Signature], r0: np.ndarray, n_tests: int, noise_mm: float) -> tuple[str, ...]:
    """The causes whose signature is the same as ``s``'s within the noise (:func:`same_within_noise`), each once,
    ``s``'s own cause left out."""
    if s.share <= 0:
        return ()
    alike = [_cause(o.label) for o in others if o is not s and same_within_noise(s, o, r0, n_tests, noise_mm)]
    return tuple(c for c in dict.fromkeys(alike) if c != _cause(s.label))


def _rank(ev: Evidence, task: CandidateTask) -> float:
    found = next((r for r in ev.ranked if r.key == (task.kind, task.candidate.effect)), None)
    return found.cv_error_mm if found is not None and math.isfinite(found.cv_error_mm) else math.inf

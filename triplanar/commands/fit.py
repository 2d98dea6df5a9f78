"""``triplanar fit DATA.csv --add NAME``: add effects, fit their parameters, watch the error fall."""

from __future__ import annotations

import argparse
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

from .options import load_specimen
from ..effects import EffectError
from ..measurement import MeasuredTest
from ..prior import drawing_record
from .workbench_options import (add_data_arguments, add_start_arguments, add_worker_arguments, check_effect_names,
                                drop_figures, executor_for, model_and_tests, out_dir, parse_per_test, parse_starts,
                                refuse_overwriting_inputs)

if TYPE_CHECKING:  # (the workbench is imported when the command runs: building the parser needs none of it)
    from ..workbench.candidates import Candidate
    from ..workbench.compare import Comparison
    from ..workbench.fit import EffectFit
    from ..workbench.results import FitResult
    from ..workbench.spec import EvalResult, ModelSpec

NAME = "fit"
HELP = ("add effects to your model and fit their parameters (--add NAME, repeatable), or let forward "
        "selection add effects until the error stops falling (--forward); plots the error after each addition")
FIGURES = ("error_fall.png", "overhead.png", "residuals.png", "deviations.png")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_data_arguments(parser, "out/fit")
    parser.add_argument("--add", action="append", default=[], metavar="NAME",
                        help="effect to add and fit (repeatable; fitted jointly, in the order given); an effect the "
                             "model already has (--effect) is refitted: its parameters are freed, starting at the "
                             "values given")
    parser.add_argument("--free", action="append", default=[], metavar="NAME[=LOW:HIGH]",
                        help="a given number to fit instead of taking it as given (repeatable; fitted jointly, "
                             "after the --add effects): of the specimen mass_kg, com_g1_m..com_g3_m, cp1_x1_m, "
                             "cp1_x3_m, ..., load_point_A_m, load_point_B_m, inertia_g1_kg_m2..; of the instruments "
                             "time_base_rate, time_offset_s, load_cell_gain, rangefinder_gain_x1, _x3, "
                             "rangefinder_offset_x1_m, _x3_m, rangefinder_drift_x1_m_s, _x3_m_s; over the drawing's "
                             "tolerance (mass +-10 %%, lengths +-5 mm, inertia +-15 %%), the calibration's (the "
                             "instrument effect's fit range) or LOW:HIGH in SI units")
    add_start_arguments(parser)
    parser.add_argument("--forward", action="store_true",
                        help="forward selection: diagnose, add the named effect, repeat until the error stops falling "
                             "(after the --add effects, if any)")
    parser.add_argument("--max-effects", type=int, default=3, metavar="N",
                        help="forward selection: most effects to add")
    parser.add_argument("--json", metavar="FIT.json", help="also write the JSON result here (always DIR/fit.json)")
    add_worker_arguments(parser)


def check_arguments(args: argparse.Namespace) -> None:
    """Refuse what cannot run, before anything is read or fitted."""
    if not args.add and not args.forward and not args.free:
        raise EffectError("nothing to fit: give --add NAME (repeatable), --free NAME and/or --forward")
    if args.forward and args.max_effects < 1:
        raise ValueError(f"--max-effects {args.max_effects}: forward selection needs at least 1")
    if len(set(args.add)) != len(args.add):
        raise EffectError(f"--add: {', '.join(sorted({a for a in args.add if args.add.count(a) > 1}))} given twice")
    refuse_overwriting_inputs(args, [("--json", args.json)] * bool(args.json) + [
        ("--out", Path(args.out) / name) for name in ("fit.json", *FIGURES)])


def effects_to_add(args: argparse.Namespace) -> tuple[list[str | Candidate], dict[str, dict[str, float]],
                                                     dict[str, list[str]]]:
    """The ``--add`` names (and the ``--free`` numbers' candidates after them), ``--start`` values and
    ``--per-test`` parameters, checked against each other (before anything is read or written)."""
    from ..workbench.given import free_candidates, parse_free
    starts = parse_starts(args.start)
    per_test = parse_per_test(args.per_test)
    add: list[str | Candidate] = list(check_effect_names(args.add))
    if args.free:
        freed = free_candidates(parse_free(args.free), *load_specimen(args.specimen))
        both = sorted({c.effect for c in freed} & set(add))
        if both:
            raise EffectError(f"--free: {both[0]}'s numbers are freed and --add {both[0]} fits it too: give one")
        add += freed
    missing = sorted(set(per_test) - set(add))
    if missing:
        raise EffectError(f"--per-test {missing[0]}: that effect is not fitted; add it with --add {missing[0]}")
    return add, starts, per_test


def fit_steps(args: argparse.Namespace, spec: ModelSpec, tests: list[MeasuredTest], add: list[str | Candidate],
              starts: dict[str, dict[str, float]],
              per_test: dict[str, list[str]]) -> tuple[FitResult, ModelSpec, EffectFit | None]:
    """The ``--add`` fits, then forward selection from them (``--forward``): the result, the fitted model and
    the last ``--add`` fit when the figures show it (``None`` without ``--add`` or after forward selection)."""
    from ..workbench.results import FitResult, FitStep, fit_added
    from ..workbench.select import ForwardSelection
    with executor_for(args) as ex:
        steps, fit = fit_added(add, tests, spec, starts, ex, per_test)
        current = fit.spec_ if fit is not None else spec
        stop = None
        if args.forward:
            sel = ForwardSelection(max_effects=args.max_effects, executor=ex, progress=not args.no_progress)
            sel.fit(tests, spec, initial=fit.params_ if fit is not None else None)
            more = [FitStep.from_selection(s) for s in sel.steps_]
            steps = (steps or more[:1]) + more[1:]
            current, stop = sel.spec_, sel.stop_reason_
    result = FitResult(spec.describe(), current.describe(), steps, stop,
                       drawing_record(*load_specimen(args.specimen)))
    return result, current, (fit if stop is None else None)


def per_test_comparison(fitted: Comparison, fit: EffectFit,
                        tests: list[MeasuredTest]) -> tuple[Comparison, dict[str, EvalResult]]:
    """Every test against its own fitted model (its own values of the per-test parameters)."""
    from ..workbench.fit import safe_evaluate
    from ..workbench.spec import EvalTask
    own = {t.test_id: safe_evaluate(EvalTask(fit.spec_for(t.test_id), float(t.shear_force_N), (t,), True))
           for t in tests}
    return replace(fitted, discrepancies=[own[t.test_id].discrepancies[0] for t in tests]), own


def plot(result: FitResult, current: ModelSpec, fit: EffectFit | None, tests: list[MeasuredTest], out: Path) -> None:
    """The error fall and the fitted model's overhead, residual and deviation figures."""
    from ..workbench.compare import compare
    from ..workbench.report import plot_deviations, plot_error_fall, plot_overhead, plot_residuals  # matplotlib
    plot_error_fall([s.to_json() for s in result.steps], out / "error_fall.png")
    fitted = compare(tests, current)
    own = None
    if fit is not None and fit.per_test_:
        fitted, own = per_test_comparison(fitted, fit, tests)
    note = " (each test with its own per-test values)" if own else ""
    plot_overhead(fitted, out / "overhead.png", f"measured (black) vs {current.describe()} (grey){note}", own)
    plot_residuals(fitted, out / "residuals.png")
    plot_deviations(fitted, out / "deviations.png", f"after fitting: deviations from {current.describe()} (mm){note}",
                    own)


def run(args: argparse.Namespace) -> int:
    from ..workbench.report import write_json
    check_arguments(args)
    add, starts, per_test = effects_to_add(args)
    spec, tests = model_and_tests(args)
    out = out_dir(args)
    result, current, fit = fit_steps(args, spec, tests, add, starts, per_test)
    for path in (out / "fit.json", *([args.json] if args.json else [])):
        write_json(result.to_json(), path)
    if args.no_plots:
        drop_figures(out, FIGURES)
    else:
        plot(result, current, fit, tests, out)
    print(result.report())
    written = [str(out / "fit.json"), *([args.json] if args.json else []), *([] if args.no_plots else FIGURES)]
    print(f"\nwrote {', '.join(written)}")
    return 0

"""``triplanar diagnose DATA.csv``: which effect is the model missing?"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

from .workbench_options import (add_data_arguments, add_start_arguments, add_worker_arguments, check_effect_names,
                                drop_figures, executor_for, model_and_tests, out_dir, parse_per_test, parse_starts,
                                refuse_overwriting_inputs)

if TYPE_CHECKING:  # (the workbench is imported when the command runs: building the parser needs none of it)
    from ..workbench.results import DiagnosisResult

NAME = "diagnose"
HELP = ("try each candidate effect added to your model, fit it, rank by cross-validated error over load "
        "levels, and name the missing effect (or say that none explains the discrepancy)")
FIGURES = ("diagnose.png", "time_residuals.png", "deciding.png")   # deciding.png: figures_of


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_data_arguments(parser, "out/diagnose")
    add_start_arguments(parser)
    parser.add_argument("--no-refit", action="store_true",
                        help="do not free the parameters of the --effect effects you gave (by default each is "
                             "refitted and ranked with the candidates)")
    parser.add_argument("--json", metavar="REPORT.json", help="also write the JSON report here "
                        "(it is always written to DIR/diagnose.json)")
    parser.add_argument("--candidates", metavar="NAME[,NAME...]",
                        help="only these candidate effects (default: every registered effect but those tried only "
                             "when named, such as time_base)")
    parser.add_argument("--folds", type=int, default=3, metavar="K", help="cross-validation folds over load levels")
    add_worker_arguments(parser)


def candidate_names(args: argparse.Namespace) -> list[str] | None:
    """``--candidates`` as checked effect names (``None``: every registered effect)."""
    if args.candidates is None:
        return None
    names = check_effect_names([n.strip() for n in args.candidates.split(",") if n.strip()])
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise ValueError(f"--candidates: {', '.join(twice)} given twice")
    if not names:
        raise ValueError(f"--candidates {args.candidates!r}: no candidate named")
    return names


def figures_of(report: dict) -> list[str]:
    """The figures a run with ``report`` draws: deciding.png only when the report has deciding experiments."""
    return [name for name in FIGURES if name != "deciding.png" or report.get("deciding_experiments")]


def plot(result: DiagnosisResult, report: dict, out: Path) -> None:
    """The candidates' ranking, the deciding experiments (when ``report``, the result's, has any) and the time
    residuals."""
    from ..workbench.report import plot_candidates, plot_deciding_experiments, plot_time_residuals  # matplotlib
    plot_candidates(report, out / "diagnose.png")
    if report.get("deciding_experiments"):
        plot_deciding_experiments(report["deciding_experiments"], out / "deciding.png")
    else:
        drop_figures(out, ("deciding.png",))     # an earlier run's, which this report does not support
    plot_time_residuals(result.baseline, result.after, out / "time_residuals.png", result.model, result.best_label)


def run(args: argparse.Namespace) -> int:
    from ..workbench.diagnose import Diagnoser
    from ..workbench.executor import TaskCheckpoint
    from ..workbench.report import write_json
    from ..workbench.results import DiagnosisResult
    if args.folds < 2:
        raise ValueError(f"--folds {args.folds}: cross-validation needs at least 2 folds")
    refuse_overwriting_inputs(args, [("--json", args.json)] * bool(args.json) + [
        ("--out", Path(args.out) / name) for name in ("diagnose.json", *FIGURES)])
    spec, tests = model_and_tests(args)
    starts = parse_starts(args.start)
    per_test = parse_per_test(args.per_test)
    names = candidate_names(args)
    out = out_dir(args)
    partial = TaskCheckpoint(out / ".diagnose-partial")  # an interrupted run resumes from the finished candidates
    with executor_for(args) as ex:
        diag = Diagnoser(names, folds=args.folds, executor=ex, progress=not args.no_progress,
                         checkpoint=partial, refit_given=not args.no_refit, start=starts,
                         per_test=per_test).fit(tests, spec)
    result = DiagnosisResult.of(diag)
    report = result.to_json()
    for path in (out / "diagnose.json", *([args.json] if args.json else [])):
        write_json(report, path)
    if args.no_plots:
        drop_figures(out, FIGURES)
    else:
        plot(result, report, out)
    partial.clear()
    print(result.report())
    figures = [] if args.no_plots else figures_of(report)
    print(f"\nwrote {', '.join([str(out / 'diagnose.json'), *([args.json] if args.json else []), *figures])}")
    return 0

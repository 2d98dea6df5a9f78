"""``triplanar diagnose DATA.csv``: which effect is the model missing?"""

from __future__ import annotations

import argparse

NAME = "diagnose"
HELP = ("try each candidate effect added to your model, fit it, rank by cross-validated error over load "
        "levels, and name the missing effect (or say that none explains the discrepancy)")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from ..workbench.cli_common import add_data_arguments, add_worker_arguments
    add_data_arguments(parser, "out/diagnose")
    parser.add_argument("--json", metavar="REPORT.json", help="also write the JSON report here "
                        "(it is always written to DIR/diagnose.json)")
    parser.add_argument("--candidates", metavar="NAME[,NAME...]",
                        help="only these candidate effects (default: every registered effect)")
    parser.add_argument("--folds", type=int, default=3, metavar="K", help="cross-validation folds over load levels")
    add_worker_arguments(parser)


def format_report(report: dict) -> str:
    lines = [f"model: {report['model']}  ({report['n_tests']} tests)",
             f"baseline RMS discrepancy {report['baseline_error_mm']:.3f} mm"
             + (f"; repeat scatter {report['repeat_scatter_mm']:.3f} mm" if report.get("repeat_scatter_mm") else ""),
             "", "  rank  effect              cv error mm  improvement  parameters (+- stderr)"]
    for i, c in enumerate(report["candidates"], start=1):
        params = ", ".join(f"{k} = {v:.4g} +- {c['param_stderr'][k]:.2g}" for k, v in c["params"].items())
        flag = "" if c["plausible"] else f"  [implausible: {', '.join(c['at_bound'])} at the edge of its range]"
        lines.append(f"  {i:4d}  {c['effect']:18s}  {c['cv_error_mm']:11.3f}  {c['improvement']:10.0%}   "
                     f"{params}{flag}")
    verdict = report["missing_effect"] or "none (no candidate explains the discrepancy)"
    lines += ["", f"missing effect: {verdict}   confidence: {report['confidence']}", f"why: {report['reason']}",
              f"time: {report['seconds']:.1f} s"]
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    from pathlib import Path

    from ..workbench.cli_common import (check_effect_names, executor_for, model_and_tests, out_dir,
                                        refuse_overwriting_inputs)
    from ..workbench.diagnose import Diagnoser
    from ..workbench.executor import TaskCheckpoint
    from ..workbench.report import plot_candidates, write_json
    if args.folds < 2:
        raise ValueError(f"--folds {args.folds}: cross-validation needs at least 2 folds")
    refuse_overwriting_inputs(args, [("--json", args.json)] * bool(args.json) + [
        ("--out", Path(args.out) / name) for name in ("diagnose.json", "diagnose.png")])
    spec, tests = model_and_tests(args)
    names = None
    if args.candidates is not None:
        names = check_effect_names([n.strip() for n in args.candidates.split(",") if n.strip()])
        twice = sorted({n for n in names if names.count(n) > 1})
        if twice:
            raise ValueError(f"--candidates: {', '.join(twice)} given twice")
        if not names:
            raise ValueError(f"--candidates {args.candidates!r}: no candidate named")
    out = out_dir(args)
    partial = TaskCheckpoint(out / ".diagnose-partial")  # an interrupted run resumes from the finished candidates
    with executor_for(args) as ex:
        diag = Diagnoser(names, folds=args.folds, executor=ex, progress=not args.no_progress,
                         checkpoint=partial).fit(tests, spec)
    report = diag.report_
    write_json(report, out / "diagnose.json")
    if args.json:
        write_json(report, args.json)
    plot_candidates(report, out / "diagnose.png")
    partial.clear()
    print(format_report(report))
    print(f"\nwrote {out / 'diagnose.json'}{', ' + args.json if args.json else ''}, diagnose.png")
    return 0

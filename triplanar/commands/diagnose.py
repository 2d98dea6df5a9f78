"""``triplanar diagnose DATA.csv``: which effect is the model missing?"""

from __future__ import annotations

import argparse

NAME = "diagnose"
HELP = ("try each candidate effect added to your model, fit it, rank by cross-validated error over load "
        "levels, and name the missing effect (or say that none explains the discrepancy)")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from ..workbench.cli_common import add_data_arguments, add_start_arguments, add_worker_arguments
    add_data_arguments(parser, "out/diagnose")
    add_start_arguments(parser)
    parser.add_argument("--no-refit", action="store_true",
                        help="do not free the parameters of the --effect effects you gave (by default each is "
                             "refitted and ranked with the candidates)")
    parser.add_argument("--json", metavar="REPORT.json", help="also write the JSON report here "
                        "(it is always written to DIR/diagnose.json)")
    parser.add_argument("--candidates", metavar="NAME[,NAME...]",
                        help="only these candidate effects (default: every registered effect)")
    parser.add_argument("--folds", type=int, default=3, metavar="K", help="cross-validation folds over load levels")
    add_worker_arguments(parser)


def format_param(name: str, value: float, ci: list[float] | None, status: str | None,
                 profile: list[float] | None = None, model: list[float] | None = None) -> str:
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
    prof = f" profile [{profile[0]:.4g}, {profile[1]:.4g}]" if profile is not None else ""
    prof += f" model form [{model[0]:.4g}, {model[1]:.4g}]" if model is not None else ""
    return f"{name} = {value:.4g} [{ci[0]:.4g}, {ci[1]:.4g}]{prof}{note}"


def format_report(report: dict) -> str:
    noise = report.get("noise", {})
    lines = [f"model: {report['model']}  ({report['n_tests']} tests)",
             f"baseline RMS discrepancy {report['baseline_error_mm']:.3f} mm"
             + (f"; repeat scatter {report['repeat_scatter_mm']:.3f} mm" if report.get("repeat_scatter_mm") else "")
             + (f"; instrument noise {noise['instrument_noise_mm']:.3f} mm, scatter it and the specimen explain "
                f"{noise['expected_scatter_mm']:.3f} mm" if noise.get("expected_scatter_mm") else ""),
             "", "  rank  effect                    " + ("cv error mm" if report.get("cross_validated", True) else
                                                         "in-sample mm") + "  improvement  parameters [95% interval]"
             " (the named entry's profile-likelihood one, and the one that admits model-form error)"]
    ranked = sorted([(c["cv_error_mm"], c["effect"], c) for c in report["candidates"]]
                    + [(c["cv_error_mm"], f"{c['effect']} (refit)", c) for c in report.get("refit_results", [])],
                    key=lambda x: (x[0] != x[0], x[0]))
    for i, (_, label, c) in enumerate(ranked, start=1):
        params = ", ".join(format_param(k, v, c.get("param_ci95", {}).get(k), c.get("param_status", {}).get(k),
                                        (c.get("param_profile_ci95") or {}).get(k),
                                        (c.get("param_model_ci95") or {}).get(k)) for k, v in c["params"].items())
        if c.get("per_test"):
            from ..workbench.pertest import describe
            params = ", ".join([params, *(describe(k, summary) for k, summary in c["per_test"].items())])
        given = (" (given " + ", ".join(f"{k} = {v:.4g}" for k, v in c["given"].items()) + ")") if c.get("given") else ""
        flag = "" if c["plausible"] else f"  [implausible: {', '.join(c['at_bound'])} at the edge of its range]"
        lines.append(f"  {i:4d}  {label:24s}  {c['cv_error_mm']:11.3f}  {c['improvement']:10.0%}   "
                     f"{params}{given}{flag}")
    td = report.get("time_domain") or {}
    if td.get("has_time"):
        freq = td.get("dominant_frequency_hz")
        lines += ["", f"in time (model as given): arrival error {td['arrival_error_s']:+.3f} s on average, travel lag "
                      f"{td['lag_rms_mm']:.2f} mm RMS (mean path distance {td['mean_distance_mm']:.2f} mm); residual "
                      + (f"periodic at {freq:.1f} Hz in {td['periodic_fraction']:.0%} of the tests" if freq is not None
                         else f"spectrum without a dominant frequency ({td['periodic_fraction']:.0%} of tests with a peak)")]
    verdict = report["missing_effect"] or "none"
    many = report.get("missing_effects") or []
    if len(many) > 1:
        verdict = " + ".join(m["effect"] for m in many)
        lines += ["", "missing effects, in the order forward selection added them (parameters from their joint fit):"]
        for m in many:
            params = ", ".join(format_param(k, v, m["param_ci95"].get(k), None) for k, v in m["params"].items())
            lines.append(f"  {m['effect']:24s} {m['share_of_improvement']:6.0%} of the error   {params}   "
                         f"(confidence {m['confidence']})")
    if report.get("indistinguishable_from"):
        lines += ["", f"indistinguishable from the named entry on these data: {', '.join(report['indistinguishable_from'])}"]
        for exp in report.get("deciding_experiments") or []:
            lines.append(f"  {exp['sentence']}")
            lines.append("    load N  difference mm  / scatter  repeats for 95 %")
            for r in exp["rows"]:
                if r["difference_mm"] is not None:
                    lines.append(f"    {r['load_N']:6.1f}  {r['difference_mm']:13.3f}  {r['ratio']:9.2f}  {r['repeats']:8d}")
                elif r.get("holds"):
                    lines.append(f"    {r['load_N']:6.1f}  {r['note']}")
    kind = f" ({report['missing_kind']})" if report.get("missing_kind") else ""
    lines += ["", f"verdict: {report.get('verdict', '?')}   missing effect: {verdict}{kind}   confidence: "
                  f"{report['confidence']}",
              f"why: {report['reason']}", f"time: {report['seconds']:.1f} s"]
    return "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    from pathlib import Path

    from ..workbench.cli_common import (check_effect_names, executor_for, model_and_tests, out_dir, parse_per_test,
                                        parse_starts, refuse_overwriting_inputs)
    from ..workbench.diagnose import Diagnoser
    from ..workbench.executor import TaskCheckpoint
    from ..workbench.report import plot_candidates, plot_deciding_experiments, plot_time_residuals, write_json
    if args.folds < 2:
        raise ValueError(f"--folds {args.folds}: cross-validation needs at least 2 folds")
    refuse_overwriting_inputs(args, [("--json", args.json)] * bool(args.json) + [
        ("--out", Path(args.out) / name) for name in ("diagnose.json", "diagnose.png", "time_residuals.png",
                                                                      "deciding.png")])
    spec, tests = model_and_tests(args)
    starts = parse_starts(args.start)
    per_test = parse_per_test(args.per_test)
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
                         checkpoint=partial, refit_given=not args.no_refit, start=starts,
                         per_test=per_test).fit(tests, spec)
    report = diag.report_
    write_json(report, out / "diagnose.json")
    if args.json:
        write_json(report, args.json)
    plot_candidates(report, out / "diagnose.png")
    if report.get("deciding_experiments"):
        plot_deciding_experiments(report["deciding_experiments"], out / "deciding.png")
    else:
        (out / "deciding.png").unlink(missing_ok=True)     # an earlier run's, which this report does not support
    plot_time_residuals(diag.baseline_, diag.after_, out / "time_residuals.png", diag.base_.describe(),
                        diag.best_label_)
    partial.clear()
    print(format_report(report))
    print(f"\nwrote {out / 'diagnose.json'}{', ' + args.json if args.json else ''}, diagnose.png, time_residuals.png"
          + (", deciding.png" if report.get("deciding_experiments") else ""))
    return 0

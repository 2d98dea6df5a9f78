"""``triplanar fit DATA.csv --add NAME``: add effects, fit their parameters, watch the error fall."""

from __future__ import annotations

import argparse

from ..cli_args import load_specimen
from ..prior import drawing_record

NAME = "fit"
HELP = ("add effects to your model and fit their parameters (--add NAME, repeatable), or let forward "
        "selection add effects until the error stops falling (--forward); plots the error after each addition")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from ..workbench.cli_common import add_data_arguments, add_start_arguments, add_worker_arguments
    add_data_arguments(parser, "out/fit")
    parser.add_argument("--add", action="append", default=[], metavar="NAME",
                        help="effect to add and fit (repeatable; fitted jointly, in the order given); an effect the "
                             "model already has (--effect) is refitted: its parameters are freed, starting at the "
                             "values given")
    add_start_arguments(parser)
    parser.add_argument("--forward", action="store_true",
                        help="forward selection: diagnose, add the named effect, repeat until the error stops falling "
                             "(after the --add effects, if any)")
    parser.add_argument("--max-effects", type=int, default=3, metavar="N",
                        help="forward selection: most effects to add")
    parser.add_argument("--json", metavar="FIT.json", help="also write the JSON result here (always DIR/fit.json)")
    add_worker_arguments(parser)


def run(args: argparse.Namespace) -> int:
    from ..effects import EffectError
    from ..workbench.cli_common import check_effect_names, executor_for, model_and_tests, out_dir
    from ..workbench.compare import compare
    from ..workbench.fit import EffectFit
    from ..workbench.cli_common import parse_per_test, parse_starts
    from ..workbench.report import plot_deviations, plot_error_fall, plot_overhead, plot_residuals, write_json
    from ..workbench.select import ForwardSelection
    from pathlib import Path

    from ..workbench.cli_common import refuse_overwriting_inputs
    if not args.add and not args.forward:
        raise EffectError("nothing to fit: give --add NAME (repeatable) and/or --forward")
    if args.forward and args.max_effects < 1:
        raise ValueError(f"--max-effects {args.max_effects}: forward selection needs at least 1")
    if len(set(args.add)) != len(args.add):
        raise EffectError(f"--add: {', '.join(sorted({a for a in args.add if args.add.count(a) > 1}))} given twice")
    refuse_overwriting_inputs(args, [("--json", args.json)] * bool(args.json) + [
        ("--out", Path(args.out) / name) for name in ("fit.json", "error_fall.png", "overhead.png", "residuals.png", "deviations.png")])
    spec, tests = model_and_tests(args)
    starts = parse_starts(args.start)
    per_test = parse_per_test(args.per_test)
    add = check_effect_names(args.add)
    missing = sorted(set(per_test) - set(add))
    if missing:
        raise EffectError(f"--per-test {missing[0]}: that effect is not fitted; add it with --add {missing[0]}")
    out = out_dir(args)
    steps: list[dict] = []
    values: dict[str, dict[str, float]] = {}
    with executor_for(args) as ex:
        current = spec
        for i in range(len(add)):
            fit = EffectFit(add[:i + 1], spec, {**starts, **values}, ex,
                            per_test={k: v for k, v in per_test.items() if k in add[:i + 1]}).fit(tests)
            if not steps:
                steps.append({"added": None, "effects": {}, "param_stderr": {}, "error_mm": fit.baseline_error_mm_,
                              "error_by_load_mm": {f"{k:g}": v for k, v in fit.baseline_by_load_.items()}})
            values = fit.params_
            current = fit.spec_
            steps.append({"added": add[i], "refitted": add[i] in fit.refitted_,
                          "given": fit.refitted_.get(add[i]), "effects": fit.params_, "param_stderr": fit.stderr_,
                          "param_ci95": fit.ci95_, "param_profile_ci95": fit.profile_ci95_, "param_status": fit.status_,
                          "at_bound": list(fit.at_bound_), "error_mm": fit.error_mm_,
                          **({"per_test": fit.per_test_summary_} if fit.per_test_ else {}),
                          "error_by_load_mm": {f"{k:g}": v for k, v in fit.error_by_load_.items()}})
        stop = None
        if args.forward:
            sel = ForwardSelection(max_effects=args.max_effects, executor=ex, progress=not args.no_progress)
            sel.fit(tests, spec, initial=values or None)
            more = sel.report_["steps"]
            steps = steps or more[:1]
            steps += more[1:]
            current, stop = sel.spec_, sel.stop_reason_
    result = {"model": spec.describe(), "fitted_model": current.describe(), "steps": steps, "stop_reason": stop,
              "drawing": drawing_record(*load_specimen(args.specimen))}
    write_json(result, out / "fit.json")
    if args.json:
        write_json(result, args.json)
    plot_error_fall(steps, out / "error_fall.png")
    fitted = compare(tests, current)
    own = None
    if stop is None and add and fit.per_test_:
        # per-test parameters: every test against its own fitted model (its own values of those parameters)
        from dataclasses import replace as _replace

        from ..workbench.fit import safe_evaluate
        from ..workbench.spec import EvalTask
        own = {t.test_id: safe_evaluate(EvalTask(fit.spec_for(t.test_id), float(t.shear_force_N), (t,), True))
               for t in tests}
        fitted = _replace(fitted, discrepancies=[own[t.test_id].discrepancies[0] for t in tests])
    note = " (each test with its own per-test values)" if own else ""
    plot_overhead(fitted, out / "overhead.png", f"measured (black) vs {current.describe()} (grey){note}", own)
    plot_residuals(fitted, out / "residuals.png")
    plot_deviations(fitted, out / "deviations.png", f"after fitting: deviations from {current.describe()} (mm){note}",
                    own)
    from .diagnose import format_param
    print(f"model: {spec.describe()}")
    for s in steps:
        what = ("model as given" if s["added"] is None else
                f"refit {s['added']}" if s.get("refitted") else f"+ {s['added']}")
        errs, cis, status = s["param_stderr"], s.get("param_ci95") or {}, s.get("param_status") or {}
        params = "; ".join(f"{e}: " + ", ".join(
            format_param(k, v, cis.get(e, {}).get(k),
                         status.get(e, {}).get(k) or (None if k in cis.get(e, {}) else "fixed"),
                         (s.get("param_profile_ci95") or {}).get(e, {}).get(k)) if cis else
            (f"{k} = {v:.4g} +- {errs[e][k]:.2g}" if k in errs.get(e, {}) else f"{k} = {v:.4g} (fixed)")
            for k, v in ps.items()) for e, ps in s["effects"].items())
        if s.get("per_test"):
            from ..workbench.pertest import describe
            params += "; " + "; ".join(f"{e}: {describe(p, summary)}" for e, ps in s["per_test"].items()
                                       for p, summary in ps.items())
        print(f"  {what:24s} RMS discrepancy {s['error_mm']:8.3f} mm   {params}")
        if s.get("confidence"):
            print(f"  {'':24s} confidence {s['confidence']}: {s.get('reason') or ''}")
    if stop:
        print(f"forward selection stopped: {stop}")
    print(f"\nwrote {out / 'fit.json'}{', ' + args.json if args.json else ''}, error_fall.png, overhead.png, "
          "residuals.png, deviations.png")
    return 0

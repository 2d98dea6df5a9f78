"""``triplanar compare DATA.csv``: how far is the model from the measured traces, and where does it fail."""

from __future__ import annotations

import argparse

NAME = "compare"
HELP = ("simulate every measured test with your model (default: case B, no end friction) and report the "
        "discrepancy: table, summary, overhead plots, residual plots, error map")


FIGURES = ("overhead.png", "residuals.png", "error_map.png", "deviations.png", "time_residuals.png")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from .workbench_options import add_data_arguments
    add_data_arguments(parser, "out/compare")


def run(args: argparse.Namespace) -> int:
    from pathlib import Path

    from ..atomic import write_atomic
    from .workbench_options import drop_figures, model_and_tests, out_dir, refuse_overwriting_inputs
    from ..workbench.compare import compare
    refuse_overwriting_inputs(args, [("--out", Path(args.out) / name) for name in (
        "compare.csv", "summary.txt", *FIGURES)])
    spec, tests = model_and_tests(args)
    out = out_dir(args)
    cmp = compare(tests, spec)
    cmp.write_csv(out / "compare.csv")
    summary = cmp.summary()
    write_atomic(out / "summary.txt", lambda tmp: tmp.write_text(summary + "\n", encoding="utf-8"))
    if args.no_plots:
        drop_figures(out, FIGURES)
    else:
        from ..workbench.report import (plot_deviations, plot_error_map, plot_overhead, plot_residuals,
                                        plot_time_residuals)
        plot_overhead(cmp, out / "overhead.png")
        plot_residuals(cmp, out / "residuals.png")
        plot_error_map(cmp, out / "error_map.png")
        plot_deviations(cmp, out / "deviations.png")
        plot_time_residuals(cmp.discrepancies, None, out / "time_residuals.png", spec.describe())
    print(summary)
    print(f"\nwrote {', '.join([str(out / 'compare.csv'), 'summary.txt', *([] if args.no_plots else FIGURES)])}")
    return 0

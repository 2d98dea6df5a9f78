"""``triplanar simulate``: one constant-force test of the paper's case A, B or C."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from . import add_model_arguments, load_specimen, parse_effects, refuse_overwriting

NAME = "simulate"
HELP = "simulate one shear test (case A, B or C) and print what happened"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--case", choices=["A", "B", "C"], default="A",
                        help="A: actuator with end friction, B: without, C: hydrostatic (default A)")
    parser.add_argument("--force", type=float, required=True, metavar="N", help="shear force F_T in newtons")
    add_model_arguments(parser)
    parser.add_argument("--method", choices=["dopri5", "rk4", "euler"], default="dopri5")
    parser.add_argument("--dt", type=float, default=None, help="fixed step for rk4/euler (s)")
    parser.add_argument("--travel", type=float, default=0.08, metavar="M", help="stop at this CP1 travel (m)")
    parser.add_argument("--t-max", type=float, default=5.0, metavar="S", help="time limit (s)")
    parser.add_argument("--out", metavar="trace.csv", help="write the trace in the measurement CSV format")
    parser.add_argument("--plot", metavar="trace.png", help="overhead view of the trace (paper Fig. 6 style)")


def run(args: argparse.Namespace) -> int:
    from ..measurement import MIN_SAMPLES
    from ..model import paper_model
    from ..simulate import simulate

    for option, value in (("--out", args.out), ("--plot", args.plot)):
        if value is not None and not value.strip():
            raise ValueError(f"{option}: empty file name")
    if args.out and args.plot and Path(args.out).resolve() == Path(args.plot).resolve():
        raise ValueError(f"--out and --plot name the same file {args.out}")
    refuse_overwriting([("--out", args.out), ("--plot", args.plot)], [("--specimen", args.specimen)])
    specimen, foundation = load_specimen(args.specimen)
    model = paper_model(args.case, args.force, specimen, foundation, parse_effects(args.effect))
    result = simulate(model, method=args.method, dt=args.dt, travel_m=args.travel, t_max_s=args.t_max)
    summary = result.summary()
    print(f"case {args.case}, F_T = {args.force:g} N, {', '.join(map(repr, model.effects)) or 'no extra effects'}")
    print(f"status: {result.status}\n{result.message}")
    if result.status != "held":
        print(f"time to {summary['travel_m'] * 100:.2f} cm travel: {summary['duration_s']:.4f} s")
        print(f"peak contact-point speed: {summary['peak_speed_m_s']:.3f} m/s")
        dil = ", ".join(f"CP{i + 1} {d * 1e3:+.2f}" for i, d in enumerate(summary["lateral_dilation_m"]))
        print(f"lateral dilation (mm, +e3): {dil}")
        print(f"rotation about the vertical: {summary['rotation_deg']:+.3f} deg (+ = counter-clockwise in overhead "
              "plots)")
        print(f"energy balance residual: {np.abs(result.energy['residual']).max():.2e} J; constraint residual: "
              f"{summary['max_constraint_residual_m']:.1e} m")
    if args.plot:
        _plot(result, args)
        print(f"plot written to {args.plot}")
    if args.out:
        if len(result.t) < MIN_SAMPLES:
            raise ValueError(f"--out {args.out}: not written: the block {result.status} and the trace has "
                             f"{len(result.t)} sample(s); the measurement format needs at least {MIN_SAMPLES}")
        Path(args.out).parent.mkdir(parents=True, exist_ok=True)
        result.write_csv(args.out, test_id=f"{args.case}-{args.force:g}")
        print(f"trace written to {args.out}")
    return 0 if result.success else 1


def _plot(result, args: argparse.Namespace) -> None:
    from ..plotting import label_contact_points, overhead_axes, panel_grid, plot_traces, save_figure

    fig, (ax,) = panel_grid(1, ncols=1, size=5.0)
    overhead_axes(ax, result.model.foundation, f"case {args.case}, {args.force:g} N: {result.status}")
    plot_traces(ax, result.contact_points, color="black")
    label_contact_points(ax, result.contact_points[0])
    save_figure(fig, args.plot)

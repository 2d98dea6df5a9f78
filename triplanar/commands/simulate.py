"""``triplanar simulate``: one constant-force test of the paper's case A, B or C."""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from . import add_model_arguments, load_specimen, parse_effects, refuse_overwriting
from ..outcome import Outcome

NAME = "simulate"
HELP = "simulate one shear test (case A, B or C) and print what happened"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from .options import effects_help
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.epilog = effects_help()
    parser.add_argument("--case", choices=["A", "B", "C"], default="A",
                        help="A: actuator with end friction, B: without, C: hydrostatic (default A)")
    parser.add_argument("--force", type=float, required=True, metavar="N", help="shear force F_T in newtons")
    add_model_arguments(parser)
    parser.add_argument("--plugin", action="append", default=[], metavar="MODULE",
                        help="import this module (a name on the Python path, or a .py file) first, so that the "
                             "effects it registers can be used with --effect (repeatable)")
    parser.add_argument("--method", choices=["dopri5", "rk4", "euler"], default="dopri5")
    parser.add_argument("--dt", type=float, default=None, help="fixed step for rk4/euler (s)")
    parser.add_argument("--travel", type=float, default=0.08, metavar="M", help="stop at this CP1 travel (m)")
    parser.add_argument("--t-max", type=float, default=5.0, metavar="S", help="time limit (s)")
    parser.add_argument("--out", metavar="trace.csv", help="write the trace in the measurement CSV format")
    parser.add_argument("--sample-rate", type=float, metavar="HZ",
                        help="with --out: write uniform samples at t = k / HZ (interpolated in time, cubic Hermite) "
                             "instead of the integrator's own, uneven steps")
    parser.add_argument("--plot", metavar="trace.png", help="overhead view of the trace (paper Fig. 6 style)")


def run(args: argparse.Namespace) -> int:
    from .options import refuse_idle_effects
    from ..measurement import MIN_SAMPLES
    from ..model import paper_model
    from ..plugins import import_plugins
    from ..simulate import simulate

    for option, value in (("--out", args.out), ("--plot", args.plot)):
        if value is not None and not value.strip():
            raise ValueError(f"{option}: empty file name")
    if args.sample_rate is not None:
        if not (np.isfinite(args.sample_rate) and args.sample_rate > 0):
            raise ValueError(f"--sample-rate {args.sample_rate:g}: give a positive rate in Hz")
        if not args.out:
            raise ValueError("--sample-rate: it sets the samples of --out; give --out trace.csv too")
    if args.out and args.plot and Path(args.out).resolve() == Path(args.plot).resolve():
        raise ValueError(f"--out and --plot name the same file {args.out}")
    refuse_overwriting([("--out", args.out), ("--plot", args.plot)],
                       [("--specimen", args.specimen)] + [("--plugin", p) for p in args.plugin if p.endswith(".py")])
    import_plugins(args.plugin)
    specimen, foundation = load_specimen(args.specimen)
    effects = parse_effects(args.effect)
    refuse_idle_effects(args.effect, effects, paper_model(args.case, args.force, specimen, foundation))
    model = paper_model(args.case, args.force, specimen, foundation, effects)
    result = simulate(model, method=args.method, dt=args.dt, travel_m=args.travel, t_max_s=args.t_max)
    summary = result.summary()
    print(f"case {args.case}, F_T = {args.force:g} N, {', '.join(map(repr, model.effects)) or 'no extra effects'}")
    print(f"status: {result.status}\n{result.message}")
    if result.status is not Outcome.HELD:
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
        _write(result, args, MIN_SAMPLES)
    return 0 if result.success else 1


def _write(result, args: argparse.Namespace, min_samples: int) -> None:
    """The trace as a measured-trace CSV: the integrator's steps, or uniform samples at ``--sample-rate``, with what
    instrument effects make of them (``Effect.read``)."""
    test_id = f"{args.case}-{args.force:g}"
    if args.sample_rate is None:
        if len(result.t) < min_samples:
            raise ValueError(f"--out {args.out}: not written: the block {result.status} and the trace has "
                             f"{len(result.t)} sample(s); the measurement format needs at least {min_samples}")
        Path(args.out).parent.mkdir(parents=True, exist_ok=True)
        result.write_csv(args.out, test_id=test_id)
        print(f"trace written to {args.out} ({len(result.t)} integrator steps)")
        return
    from ..measurement import MeasuredTest, write_measurements
    t_s = np.arange(0, int(np.floor(result.t[-1] * args.sample_rate + 1e-9)) + 1) / args.sample_rate
    if len(t_s) < min_samples:
        raise ValueError(f"--out {args.out}: not written: {len(t_s)} sample(s) at {args.sample_rate:g} Hz over "
                         f"{result.t[-1]:.4g} s (the block {result.status}); the measurement format needs at least "
                         f"{min_samples}: raise --sample-rate or --travel")
    positions = result.contact_points_at(t_s)
    for effect in result.model.effects:
        t_s, positions = effect.read(t_s, positions, result.model.specimen.contact_points_m)
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    write_measurements(args.out, [MeasuredTest(test_id, float(args.force), positions, t_s)])
    print(f"trace written to {args.out} ({len(t_s)} samples at {args.sample_rate:g} Hz)")


def _plot(result, args: argparse.Namespace) -> None:
    from ..plotting import label_contact_points, overhead_axes, panel_grid, plot_traces, save_figure

    fig, (ax,) = panel_grid(1, ncols=1, size=5.0)
    overhead_axes(ax, result.model.foundation, f"case {args.case}, {args.force:g} N: {result.status}")
    plot_traces(ax, result.contact_points, color="black")
    label_contact_points(ax, result.contact_points[0])
    save_figure(fig, args.plot)

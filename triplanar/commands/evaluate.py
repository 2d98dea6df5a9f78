"""``triplanar evaluate --controller NAME --out DIR``: a scripted, model-based (mpc, limit) or shipped controller on the held-out, stress or
nominal benches of ``TriPlanarShear-v1`` (thin wrapper over :mod:`experiments.evaluate`).

The options are declared here and :mod:`experiments` is imported only in :func:`run`, so building the CLI needs
neither the agents nor torch. Shipped agents are read from the repository's ``agents/zoo`` by a name pinned in
``agents.zoo.SHIPPED``, without unpickling (``agents/zoo/__init__.py``), and run on their model card's bench only.
"""

from __future__ import annotations

import argparse

from .options import add_executor_arguments, executor_from_args
from ..output_set import output_lock
from . import require
from .train import positive_int

NAME = "evaluate"
HELP = ("evaluate a scripted, model-based or shipped controller on TriPlanarShear-v1's held-out, stress or nominal benches: CSV, "
        "JSON and plot with confidence intervals")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--controller", required=True, help="a scripted controller (steel_tip, teflon_tip, "
                        "frictionless_tip, tracking_tip, moment_matching, pi_feedback, adaptive), a model-based one "
                        "(mpc; limit and information_bound: the references, perfect knowledge and what the bench's "
                        "sensors allow) or a shipped agent (pinned in agents/zoo); an unknown name lists them all")
    parser.add_argument("--design", help="actuator design of the bench study's sweep, or 'default' (omitted: the "
                        "default bench, and a shipped agent its model card's bench, known tip included; a shipped "
                        "agent named with another design is refused naming the argument that differs); an unknown "
                        "name lists them")
    parser.add_argument("--benches", default="heldout", choices=("heldout", "stress", "nominal"),
                        help="held-out specimens (the training ranges), stress specimens (outside them), or the "
                             "nominal specimen at the paper's 12 loads (default heldout)")
    parser.add_argument("--n", type=positive_int, default=200, help="number of held-out or stress benches "
                        "(default 200; the nominal set has 12)")
    parser.add_argument("--seeds", type=int, nargs="+", help="shipped agent: training seeds (default: all of its "
                        "card's); scripted: sensor-noise replicates (default 0)")
    parser.add_argument("--out", required=True, help="directory for BENCHES.csv, BENCHES_episodes.csv, BENCHES.json, "
                        "BENCHES.png")
    add_executor_arguments(parser)  # the tasks: one per seed


def run(args: argparse.Namespace) -> int:
    require()
    from experiments.evaluate import evaluate, write  # (the RL stack, only when run)
    with output_lock(args.out):    # checked and held before any episode: one run at a time into --out
        with executor_from_args(args) as executor:
            result = evaluate(args.controller, design=args.design, bench_set=args.benches, n=args.n,
                              seeds=args.seeds, executor=executor)
        paths = write(result, args.out)
    s = result.stats
    print(f"{args.controller} on {s['n_benches']} {args.benches} benches x {len(result.seeds)} seed(s): success "
          f"{100 * s['success_rate']:.1f} % ({100 * s['success_low']:.1f}-{100 * s['success_high']:.1f}), error over "
          f"successes {s['mimicry_error_mm']:.3f} mm ({s['error_low_mm']:.3f}-{s['error_high_mm']:.3f}), CVaR 10 % "
          f"{s['cvar10_mm']:.3f} mm, score {s['score']:.3f} mm, mean return {s['mean_return']:.3f} "
          f"({s['return_low']:.3f}-{s['return_high']:.3f}); {result.wall_s:.1f} s")
    print("wrote " + ", ".join(str(p) for p in paths))
    return 0

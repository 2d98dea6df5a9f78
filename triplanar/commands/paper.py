"""``triplanar paper``: regenerate the paper's results section (Figs. 6, 11-16, tables, claim verdicts)
against a laboratory dataset (default: the shipped ``data/lab_traces.csv``)."""

from __future__ import annotations

import argparse
import time

from .options import add_executor_arguments, executor_from_args
from . import add_model_arguments, load_specimen, parse_effects

NAME = "paper"
HELP = ("reproduce the paper's figures 6 and 11-16, the tables per case and load, and the claim-by-claim "
        "verdicts, against a measured dataset")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--out", required=True, metavar="DIR", help="directory for the PNGs, tables and report")
    parser.add_argument("--data", metavar="FILE.csv", help="measured traces (default: the shipped "
                        "data/lab_traces.csv)")
    add_model_arguments(parser)
    parser.add_argument("--workers", type=int, default=None, help="processes simulating and drawing figures "
                        "(default: up to 2; with --executor ray, the CPUs of a Ray started here)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bars")
    add_executor_arguments(parser)


def run(args: argparse.Namespace) -> int:
    from ..paper import run_paper
    t0 = time.perf_counter()
    specimen, foundation = load_specimen(args.specimen)
    effects = parse_effects(args.effect)
    with executor_from_args(args, args.workers) as executor:
        rep = run_paper(args.out, args.data, specimen, foundation, effects, args.workers,
                        progress=not args.no_progress, executor=executor)
    print(f"dataset {rep.data_path} ({sum(len(v) for v in rep.tests_by_load.values())} tests, "
          f"{len(rep.loads)} loads); wrote figures, tables.md, claims.md, report.md, results.json to {args.out}")
    for claim in rep.claims:
        print(f"  claim {claim.number}: {claim.verdict}")
    timing = ", ".join(f"{k} {v:.1f} s" for k, v in rep.seconds.items())
    print(f"done in {time.perf_counter() - t0:.1f} s ({timing})")
    return 0

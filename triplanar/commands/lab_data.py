"""``triplanar lab-data``: write a stand-in laboratory dataset (measured traces + a truth file beside it).

See :mod:`triplanar.labdata` for how the traces are made (paper section 5.1: 12 loads x 4 repeats,
manual termination between 5 and 8 cm, laser rangefinder noise).
"""

from __future__ import annotations

import argparse

from .options import add_executor_arguments, executor_from_args
from . import add_model_arguments, load_specimen, parse_effects, refuse_overwriting

NAME = "lab-data"
HELP = ("write simulated laboratory traces (measurement CSV) and the truth used to make them (JSON beside it); "
        "the same seed writes the same file")


def _loads(text: str) -> list[float]:
    try:
        return [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated newtons, e.g. 27.8,32.5, got {text!r}") from None


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from .. import PAPER_LOADS_N
    parser.add_argument("--out", required=True, metavar="FILE.csv", help="measurement CSV to write")
    parser.add_argument("--truth", metavar="FILE.json", help="truth JSON (default: FILE.csv.truth.json)")
    parser.add_argument("--loads", type=_loads, default=list(PAPER_LOADS_N), metavar="F1,F2,...",
                        help="shear forces, N (default: the paper's 12 levels)")
    parser.add_argument("--repeats", type=int, default=4, help="tests per load (default 4)")
    parser.add_argument("--noise-m", type=float, default=2e-4, help="rangefinder noise sd per coordinate, m "
                        "(default 2e-4)")
    parser.add_argument("--rate-hz", type=float, default=200.0, help="sampling rate, Hz (default 200)")
    parser.add_argument("--scatter-deg", type=float, default=0.2, help="repeat-to-repeat sd of every friction "
                        "angle, degrees (default 0.2)")
    parser.add_argument("--stop-range-m", type=float, nargs=2, default=(0.05, 0.08), metavar=("LOW", "HIGH"),
                        help="each test stops at a CP1 travel drawn uniformly from [LOW, HIGH] m (default 0.05 0.08)")
    parser.add_argument("--seed", type=int, default=0, help="seed (default 0)")
    parser.add_argument("--case", default="B", choices=["A", "B", "C"],
                        help="paper case the effects are added to (default B: actuator without end friction)")
    add_model_arguments(parser)
    parser.add_argument("--no-effects", action="store_true",
                        help="no effects at all (default without --effect: end_friction:phi_deg=8)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_executor_arguments(parser)


def run(args: argparse.Namespace) -> int:
    from ..labdata import generate_lab_data, write_lab_data
    refuse_overwriting([("--out", args.out), ("--truth", args.truth or f"{args.out}.truth.json")],
                       [("--specimen", args.specimen)])
    if args.no_effects and args.effect:
        raise ValueError("give either --no-effects or --effect, not both")
    effects = () if args.no_effects else (parse_effects(args.effect) if args.effect else None)
    specimen, foundation = load_specimen(args.specimen)
    with executor_from_args(args) as executor:
        tests, truth = generate_lab_data(loads=args.loads, repeats=args.repeats, effects=effects,
                                         noise_m=args.noise_m, rate_hz=args.rate_hz, scatter_deg=args.scatter_deg,
                                         stop_range_m=tuple(args.stop_range_m), seed=args.seed, specimen=specimen,
                                         foundation=foundation, case=args.case, executor=executor,
                                         progress=not args.no_progress)
    data, truth_file = write_lab_data(args.out, tests, truth, args.truth)
    rows = sum(t.n_samples for t in tests)
    print(f"wrote {data} ({len(tests)} tests, {rows} samples) and {truth_file}")
    for skipped in truth["skipped"]:
        print(f"  skipped {skipped['test_id']}: {skipped['reason']}")
    return 0

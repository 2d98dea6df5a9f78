"""``triplanar demo``: the project's main job, end to end, on the shipped laboratory dataset.

Runs, in order, each through its own CLI command (so the demo is what a user would type): one test of each
paper case, the paper's results regenerated (``paper``), and the workbench on the shipped dataset: compare
with case B, diagnose the missing effect, add it and watch the error fall (``compare``, ``diagnose``,
``fit``); then the RL side: a scripted controller and a shipped agent on a few held-out benches of the realistic bench
(``evaluate``), and one rendered episode (``rl/pi_feedback.gif``, frames with a legend). Parts whose command is not
installed are reported and skipped.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

NAME = "demo"
HELP = ("run the whole project on the shipped dataset: simulate, reproduce the paper, compare/diagnose/fit, and "
        "a controller and a shipped agent on the realistic bench")
RL_BENCHES = "5"   # held-out benches per controller: seconds, not the tables' hundreds
DATASET = Path(__file__).resolve().parents[2] / "data" / "lab_traces.csv"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--out", default="out/demo", help="output folder (default out/demo)")
    parser.add_argument("--data", default=str(DATASET), help="measured traces (default: the shipped dataset)")


def run(args: argparse.Namespace) -> int:
    from ..cli import build_parser, command_modules

    out = Path(args.out)
    parser = build_parser()
    known = {module.NAME for module in command_modules()}  # the commands this installation has
    steps = [["simulate", "--case", case, "--force", "32.5", "--out", str(out / f"case{case}_32.5N.csv"),
              "--plot", str(out / f"case{case}_32.5N.png")] for case in "ABC"]
    steps += [["paper", "--data", args.data, "--out", str(out / "paper")],
              ["compare", args.data, "--out", str(out / "compare")],
              ["diagnose", args.data, "--out", str(out / "diagnose"), "--json", str(out / "diagnose" / "report.json")],
              ["fit", args.data, "--forward", "--out", str(out / "fit")],
              ["evaluate", "--controller", "pi_feedback", "--n", RL_BENCHES, "--out", str(out / "rl" / "pi_feedback")],
              ["evaluate", "--controller", "ppo_robust", "--n", RL_BENCHES, "--seeds", "0",
               "--out", str(out / "rl" / "ppo_robust")]]
    failures = 0
    for step in steps:
        if step[0] not in known:
            print(f"\n== skipped: triplanar {step[0]} (not part of this installation yet)")
            continue
        print(f"\n== triplanar {' '.join(step)}", flush=True)
        start = time.perf_counter()
        sub = parser.parse_args(step)
        code = int(sub.handler(sub) or 0)
        print(f"== {step[0]} finished in {time.perf_counter() - start:.1f} s (exit {code})", flush=True)
        failures += code != 0
    failures += _rendered_episode(out / "rl" / "pi_feedback.gif")
    print(f"\nDemo outputs in {out}/")
    return 1 if failures else 0


def _rendered_episode(path: Path) -> int:
    """One episode of ``pi_feedback`` rendered to ``path`` (the env's frames, with their legend); 1 if it failed."""
    print(f"\n== python -m experiments.render_episode pi_feedback {path}", flush=True)
    start = time.perf_counter()
    try:
        from experiments.render_episode import render_episode  # (the env layer, imported only for this step)
        outcome = render_episode("pi_feedback", path)
    except ImportError as err:
        print(f"== skipped: rendering needs the environments ({err})")
        return 0
    print(f"== pi_feedback on held-out bench 0: {outcome['reason']}, {outcome['mimicry_error_mm']:.2f} mm "
          f"({time.perf_counter() - start:.1f} s)", flush=True)
    return 0

"""Reference figures for RL on the realistic bench (``TriPlanarShearRealistic-v0``): what random and zero actions,
PPO at a small budget, each shipped agent and ``mpc`` reach on the held-out benches (specimens no training or
tuning draws), as ``docs/rl_reference.csv``: mean return, success rate and mimicry error over successful episodes,
each with its 95 % interval (hierarchical bootstrap over seeds and benches; success: Wilson's interval united with
it), and the number of episodes and seeds pooled::

    nice -n 19 python benchmarks/rl_reference.py                      # every row (resumes: finished rows are kept)
    nice -n 19 python benchmarks/rl_reference.py --rows random zero   # some rows

Each row is kept in ``--work`` (``out/rl_reference/NAME.json``) as it finishes, so an interrupted run resumes; the
CSV is rewritten whole from the rows done so far. The PPO row trains with the README's script
(``examples/train_ppo_v1.py``, the adapter route, seed 0) and scores the result on the same benches. The 2M-step row
trains ``agents/robust.yaml``'s recipe (the script's PPO settings, with its start bank) with ``triplanar train``, which
checkpoints every 100k steps, so that a killed run continues where it was when the command is run again: about
2,950 steps per CPU-second, so about 12 CPU-minutes (``docs/environment.md``, beside the table).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path
from typing import Any, Callable

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
CSV = ROOT / "docs" / "rl_reference.csv"
N_BENCHES = 50
SHIPPED_BENCHES = 20   # x each shipped agent's seeds (3 or 5): 60-100 episodes, a few minutes of CPU each
MPC_BENCHES = 20       # mpc costs about 1 s of CPU per episode, more on hard benches
PPO_TIMESTEPS = 100_000
PPO_LONG_TIMESTEPS = 2_000_000
RANDOM_SEED = 40_040
SHIPPED = ("ppo_robust", "ppo_recurrent", "ppo_tracked", "ppo_banked", "ppo_rolling_slow_noisy", "ppo_steel_slow_noisy")
ROWS = ("random", "zero", "ppo_100k", "ppo_2m", *SHIPPED, "mpc")
FIELDS = ("row", "n_episodes", "n_seeds", "n_benches", "mean_return", "return_low", "return_high", "success_rate",
          "success_low", "success_high", "mimicry_error_mm", "error_low_mm", "error_high_mm", "bench", "command")


def _stats(returns: np.ndarray, success: np.ndarray, errors: np.ndarray) -> dict[str, Any]:
    """The row's figures from ``(seeds, benches)`` tables."""
    from agents.heldout import FAILURE_SCORE_MM
    from experiments.stats import return_stats, row_stats
    stats = row_stats(errors, success, FAILURE_SCORE_MM)
    return {**{k: stats[k] for k in ("n_episodes", "n_seeds", "n_benches", "success_rate", "success_low",
                                     "success_high", "mimicry_error_mm", "error_low_mm", "error_high_mm")},
            **return_stats(returns)}


def _tables(outcomes: list[list[Any]]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    returns = np.array([[o.episode_return for o in seed] for seed in outcomes])
    success = np.array([[o.success for o in seed] for seed in outcomes])
    errors = np.array([[o.mimicry_error_mm for o in seed] for seed in outcomes])
    return returns, success, errors


def _fixed_policy(name: str, n: int) -> dict[str, Any]:
    """Random (uniform, seeded per bench) or zero actions on ``n`` held-out benches (sensor noise seed = index)."""
    from agents.heldout import heldout_benches, run_episode
    outcomes = []
    for index, bench in enumerate(heldout_benches(n)):
        rng = np.random.default_rng([RANDOM_SEED, index])
        policy: Callable[[np.ndarray], np.ndarray] = (
            (lambda obs: rng.uniform(-1.0, 1.0, 2)) if name == "random" else (lambda obs: np.zeros(2)))
        outcomes.append(run_episode(name, bench, policy=policy, seed=index, index=index))
    return {**_stats(*_tables([outcomes])), "bench": "default",
            "command": f"python benchmarks/rl_reference.py --rows {name}"}


def _ppo(work: Path, n: int) -> dict[str, Any]:
    """The README's script at PPO_TIMESTEPS (trains, then scores on the held-out benches)."""
    out = work / "ppo_100k"
    command = ["examples/train_ppo_v1.py", "--timesteps", str(PPO_TIMESTEPS), "--seed", "0",
               "--eval-benches", str(n), "--out", str(out)]
    if not (out / "summary.json").exists():
        subprocess.run([sys.executable, *command], cwd=ROOT, check=True)
    rows = list(csv_rows(out / "heldout_episodes.csv"))
    success = np.array([[r["success"] == "True" for r in rows]])
    errors = np.where(success, [[float(r["mimicry_error_mm"]) for r in rows]], np.nan)
    returns = np.array([[float(r["return"]) for r in rows]])
    return {**_stats(returns, success, errors), "bench": "default",
            "command": "python " + " ".join(command[:-1] + ["OUT"])}


def _ppo_long(work: Path, n: int) -> dict[str, Any]:
    """``agents/robust.yaml`` at PPO_LONG_TIMESTEPS, seed 0, through ``triplanar train`` (resumable), scored on the
    held-out benches as the other rows (one episode per bench, sensor noise seeded by its index)."""
    from agents.heldout import heldout_benches
    from agents.robust_policy import evaluate_policy_on, load_policy, run_config
    from agents.train_config import BATCH_KEYS
    out = work / "ppo_2m"
    command = ["train", "--env", "TriPlanarShearRealistic-v0", "--seed", "0", "--timesteps", str(PPO_LONG_TIMESTEPS),
               "--out", str(out), "--executor", "serial", "--no-progress"]
    subprocess.run([sys.executable, "-m", "triplanar.cli", *command], cwd=ROOT, check=True)  # resumes; done: returns
    run_dir = out / "seed_0"
    env_kwargs = {k: v for k, v in run_config(run_dir)["env"].items() if k not in BATCH_KEYS}
    outcomes = evaluate_policy_on(load_policy(run_dir), heldout_benches(n), env_kwargs, "heldout")
    return {**_stats(*_tables([outcomes])), "bench": "default",
            "command": "triplanar " + " ".join(command[:-5] + ["--out", "OUT"])}


def csv_rows(path: Path):
    import csv
    with open(path, newline="") as f:
        yield from csv.DictReader(f)


def _evaluated(name: str, n: int) -> dict[str, Any]:
    """A controller ``triplanar evaluate`` knows (a shipped agent over its card's seeds, or ``mpc``)."""
    from experiments.evaluate import evaluate
    result = evaluate(name, n=n, progress=False)
    return {**_stats(*_tables(result.outcomes)), "bench": bench_of(name),
            "command": f"triplanar evaluate --controller {name} --n {n} --out OUT"}


def bench_of(name: str) -> str:
    """The bench a row runs on: the default, or a shipped agent's card's design (its known tip and hardware)."""
    from agents.zoo import bench_arguments, read_card
    card_kwargs = read_card(name)["env_kwargs"] if name in SHIPPED else {}
    if "tip_friction_deg" not in card_kwargs:
        return "default"
    bench = bench_arguments(card_kwargs)   # (the card's, the bench's defaults filled in)
    return (f"its card's (tip {bench['tip_friction_deg']:g} deg known, {bench['stage_bandwidth_hz']:g} Hz, "
            f"{1e3 * bench['latency_s']:g} ms, {1e3 * bench['sensor_noise_m']:g} mm)")


def make_row(name: str, work: Path) -> dict[str, Any]:
    if name in ("random", "zero"):
        return _fixed_policy(name, N_BENCHES)
    if name == "ppo_100k":
        return _ppo(work, N_BENCHES)
    if name == "ppo_2m":
        return _ppo_long(work, N_BENCHES)
    return _evaluated(name, MPC_BENCHES if name == "mpc" else SHIPPED_BENCHES)


def write_table(work: Path) -> Path:
    """Rewrite the CSV whole: the rows finished in ``work``, and the CSV's other rows as they were (a run of some
    rows in a new ``--work`` keeps the rest of the table)."""
    from experiments.tables import fmt, write_csv
    kept = {row["row"]: [row[k] for k in FIELDS] for row in csv_rows(CSV)} if CSV.exists() else {}
    for name in ROWS:
        if (work / f"{name}.json").exists():
            row = json.loads((work / f"{name}.json").read_text())
            kept[name] = [fmt(row[k]) for k in FIELDS]
    write_csv(CSV, FIELDS, [kept[name] for name in ROWS if name in kept])
    return CSV


def markdown(path: Path = CSV) -> str:
    """The CSV as the Markdown table of docs/environment.md."""
    def span(row: dict[str, str], key: str, low: str, high: str, scale: float = 1.0, unit: str = "") -> str:
        if row[key] in ("nan", ""):
            return "-"
        value, lo, hi = (float(row[k]) * scale for k in (key, low, high))
        return f"{value:.3g}{unit} [{lo:.3g}, {hi:.3g}]"
    lines = ["| row | episodes (seeds x benches) | return [95 % CI] | success, % [95 % CI] | error over successes, "
             "mm [95 % CI] | bench | command |", "|---|---|---|---|---|---|---|"]
    for row in csv_rows(path):
        lines.append(f"| {row['row']} | {row['n_episodes']} ({row['n_seeds']} x {row['n_benches']}) | "
                     f"{span(row, 'mean_return', 'return_low', 'return_high')} | "
                     f"{span(row, 'success_rate', 'success_low', 'success_high', 100.0)} | "
                     f"{span(row, 'mimicry_error_mm', 'error_low_mm', 'error_high_mm')} | {row['bench']} | "
                     f"`{row['command']}` |")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--rows", nargs="+", choices=ROWS, default=list(ROWS))
    parser.add_argument("--work", type=Path, default=ROOT / "out" / "rl_reference")
    parser.add_argument("--markdown", action="store_true", help="print docs/rl_reference.csv as a Markdown table")
    args = parser.parse_args(argv)
    if args.markdown:
        print(markdown())
        return
    args.work.mkdir(parents=True, exist_ok=True)
    for name in args.rows:
        path = args.work / f"{name}.json"
        if path.exists():
            continue
        row = {"row": name, **make_row(name, args.work)}
        path.write_text(json.dumps(row, indent=2, default=float) + "\n")
        print(f"{name}: return {row['mean_return']:.2f}, success {row['success_rate']:.0%}, "
              f"error {row['mimicry_error_mm']:.2f} mm ({row['n_episodes']} episodes)", flush=True)
        write_table(args.work)
    print(f"wrote {write_table(args.work)}")


if __name__ == "__main__":
    main()

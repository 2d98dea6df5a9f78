"""Ship trained robust PPO runs as an agent of ``agents/zoo`` (the format is :mod:`agents.zoo`'s): copy each seed's
model and normalisation statistics, evaluate them on the held-out and stress benches, write the model card.

``python -m experiments.shipping --name NAME --algo ppo --runs RUN/seed_0 RUN/seed_1 ... --command "how they were
trained" [--env-kwargs JSON] [--n 200] [--zoo DIR]``. The card's figures come from the runs' own files; ``triplanar
evaluate --controller NAME`` on the shipped copies reproduces them. The agent's directory is written under a
temporary name and renamed, so a shipped agent is complete or absent.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import shutil
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Sequence

from agents.heldout import FAILURE_SCORE_MM
from agents.zoo import CARD, ZOO_DIR, card_markdown, model_files, observation_layout
from triplanar.workbench.executor import ExecutorLike, run_tasks

from .episodes import EpisodeBatch, outcome_table, run_batch
from .stats import row_stats

ENV_ID = "TriPlanarShear-v1"
SHIPPED_SETS = ("heldout", "stress")


def run_hyperparameters(runs: Sequence[Path]) -> dict[str, Any]:
    """What the runs trained with (each run's ``config.json``, written by :func:`agents.train_robust.train_robust`),
    for the card; runs of one agent must share it (the seed and the step budget aside)."""
    from agents.train_robust import run_config
    configs = []
    for run in runs:
        config = run_config(run)
        configs.append({k: v for k, v in config.items() if k != "train"}
                       | {"train": {k: v for k, v in config.get("train", {}).items() if k != "total_timesteps"}})
    if any(c != configs[0] for c in configs[1:]):
        raise ValueError(f"runs {[str(r) for r in runs]} were trained with different configurations (config.json)")
    return configs[0]


def _run_seed(run_dir: Path) -> tuple[int, int]:
    """(seed, timesteps) of a finished run of :func:`agents.train_robust.train_robust`."""
    done = run_dir / "done.json"
    if not done.is_file():
        raise ValueError(f"{run_dir}: not a finished run (no done.json)")
    summary = json.loads(done.read_text())
    return int(summary["seed"]), int(summary["timesteps"])


def figures(run_dirs: Sequence[Path], algo: str, env_kwargs: dict[str, Any], n: int,
            executor: ExecutorLike = None) -> dict[str, dict[str, Any]]:
    """Held-out and stress statistics of the runs (one seed each), as the card gives them."""
    kind = "ppo_recurrent" if algo == "recurrent" else "ppo"
    kwargs = tuple(sorted((k, v) for k, v in env_kwargs.items() if k != "randomize"))
    tip = env_kwargs.get("tip_friction_deg")
    out = {}
    for bench_set in SHIPPED_SETS:
        batches = [EpisodeBatch(kind, f"{kind}:{run}", (), bench_set, n, tip, kwargs, _run_seed(run)[0])
                   for run in run_dirs]
        results = run_tasks(run_batch, batches, executor=executor, progress=True, desc=f"card: {bench_set}")
        out[bench_set] = row_stats(*outcome_table(batches, results), FAILURE_SCORE_MM)
    return out


def ship(name: str, run_dirs: Sequence[str | Path], *, algo: str, command: str,
         env_kwargs: dict[str, Any] | None = None, hyperparameters: dict[str, Any] | None = None, n: int = 200,
         zoo_dir: Path | None = None, executor: ExecutorLike = None, overwrite: bool = False) -> Path:
    """Copy the runs into ``zoo_dir/name`` with a model card; returns the agent's directory."""
    if not name.isidentifier():
        raise ValueError(f"agent name {name!r}: letters, digits and underscores only")
    runs = [Path(r) for r in run_dirs]
    if not runs:
        raise ValueError("give at least one run directory")
    seeds = [_run_seed(r) for r in runs]
    if len({s for s, _ in seeds}) != len(seeds):
        raise ValueError(f"runs {runs}: two runs have the same seed")
    steps = {t for _, t in seeds}
    env_kwargs = {"observation_mode": "bench", "randomize": True, **(env_kwargs or {})}
    zoo = Path(zoo_dir or ZOO_DIR)
    final = zoo / name
    if final.exists() and not overwrite:
        raise ValueError(f"{final} exists: ship under another name or pass overwrite")
    # A directory, not a file: write_atomic replaces one file, so the agent's folder is filled under a hidden name
    # and renamed here by hand.
    tmp = zoo / f".{name}.tmp"
    shutil.rmtree(tmp, ignore_errors=True)
    try:
        files = {}
        for run, (seed, _) in zip(runs, seeds):
            for source, rel in zip(("final_model.zip", "vecnormalize.pkl"), model_files(seed)):
                (tmp / rel).parent.mkdir(parents=True, exist_ok=True)
                shutil.copyfile(run / source, tmp / rel)
                files[rel] = hashlib.sha256((tmp / rel).read_bytes()).hexdigest()
        hyperparameters = hyperparameters or run_hyperparameters(runs)
        frames = hyperparameters.get("env", {}).get("frame_stack")
        card = {"name": name, "env_id": ENV_ID, "env_kwargs": env_kwargs, "algo": algo,
                "hyperparameters": hyperparameters,
                "timesteps": max(steps), "timesteps_by_seed": {str(s): t for s, t in seeds},
                "seeds": [s for s, _ in seeds], "observation": observation_layout(env_kwargs, algo, frames),
                "figures": figures(runs, algo, env_kwargs, n, executor),
                "date": datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC"), "command": command,
                "files": files}
        (tmp / CARD).write_text(json.dumps(card, indent=2, default=float) + "\n")
        (tmp / "README.md").write_text(card_markdown(card))
        if final.exists():
            shutil.rmtree(final)
        tmp.rename(final)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    return final


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m experiments.shipping", description=__doc__.splitlines()[0])
    parser.add_argument("--name", required=True)
    parser.add_argument("--algo", choices=("ppo", "recurrent"), default="ppo")
    parser.add_argument("--runs", nargs="+", required=True, help="finished run directories (OUT/seed_S)")
    parser.add_argument("--command", required=True, help="the command that trained the runs (for the card)")
    parser.add_argument("--env-kwargs", default="{}", help="JSON: the TriPlanarShear-v1 arguments of the training")
    parser.add_argument("--n", type=int, default=200, help="held-out and stress benches for the card's figures")
    parser.add_argument("--zoo", help="zoo directory (default: the repository's agents/zoo)")
    parser.add_argument("--overwrite", action="store_true")
    args = parser.parse_args(None if argv is None else list(argv))
    if args.n <= 0:
        parser.error("--n must be positive")
    path = ship(args.name, args.runs, algo=args.algo, command=args.command, env_kwargs=json.loads(args.env_kwargs),
                n=args.n, zoo_dir=Path(args.zoo) if args.zoo else None, overwrite=args.overwrite)
    print(f"shipped {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""``triplanar study --out DIR``: the actuator design study (thin wrapper over :mod:`experiments.study`).

The options are declared here and :mod:`experiments` is imported only in :func:`run`, so building the CLI needs
neither the agents nor torch; :func:`run` calls :func:`experiments.study.run_study` with plain arguments.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from .options import add_executor_arguments, executor_from_args
from . import require
from .train import positive_int

NAME = "study"
# experiments.evaluate.MODEL_BASED's names (a test keeps them equal; experiments is not imported to build the CLI)
MODEL_BASED = ("mpc", "limit", "information_bound")
DESIGN_MODEL_BASED = ("limit", "information_bound")   # experiments.bench_study.DESIGN_MODEL_BASED (the same test)
SHIPPED_ROWS = ("ppo_tracked", "ppo_banked")          # experiments.bench_study.SHIPPED_ROWS (the same test)
HELP = "actuator design study: train PPO, evaluate every controller at the 12 loads, write tables, plots, report"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--out", required=True, help="directory for tables and plots")
    parser.add_argument("--ppo-dir", default=None, help="PPO runs (trained here unless --skip-train; default "
                        "runs/ppo, which must then hold no earlier run). Its final_model.zip and vecnormalize.pkl are "
                        "loaded with (cloud)pickle, which runs code: use only runs you trained or that come from a "
                        "trusted source")
    parser.add_argument("--seeds", type=int, nargs="+", default=None,
                        help="PPO seeds (default 0 1 2; with --bench 0 1 2 3 4)")
    parser.add_argument("--timesteps", type=positive_int, help="PPO timesteps per seed (default: the YAML's)")
    parser.add_argument("--config", help="PPO hyperparameter YAML (default agents/ppo.yaml)")
    parser.add_argument("--doc", default=None, metavar="REPORT.md",
                        help="also write the Markdown report here (default: none; an existing file is refused "
                             "unless --overwrite-doc)")
    parser.add_argument("--overwrite-doc", action="store_true", help="allow --doc to replace an existing file")
    parser.add_argument("--skip-train", action="store_true", help="use finished runs in --ppo-dir as they are")
    parser.add_argument("--bench", action="store_true",
                        help="the bench study on TriPlanarShear-v1 instead (experiments.bench_study): held-out and "
                             "stress benches, feedback/adaptive controllers, robust PPO (--seeds, default 0-4; "
                             "--timesteps, default 2000000; recurrent: --recurrent-timesteps), the design sweep; "
                             "every row with 95 %% intervals; resumable in --out; --doc writes its report")
    parser.add_argument("--recurrent-timesteps", type=int, default=None,
                        help="with --bench: recurrent PPO (sb3-contrib RecurrentPPO, LSTM) timesteps per seed "
                             "(default: as --timesteps; 0 leaves it out)")
    parser.add_argument("--design-seeds", type=int, nargs="+", default=[0, 1, 2],
                        help="with --bench: robust PPO seeds per design of the sweep (default 0 1 2)")
    parser.add_argument("--design-timesteps", type=positive_int, default=1_000_000,
                        help="with --bench: robust PPO timesteps per design and seed (default 1000000)")
    parser.add_argument("--n-heldout", type=positive_int, default=200,
                        help="with --bench: held-out benches, and as many stress benches (default 200)")
    parser.add_argument("--in-sample-run", help="with --bench: a finished v0 PPO run directory (OUT/seed_S of "
                        "`triplanar train`) to evaluate on the held-out benches as ppo_in_sample")
    parser.add_argument("--model-based", nargs="*", default=list(MODEL_BASED), choices=list(MODEL_BASED),
                        help="with --bench: the model-based controllers and references to evaluate (default: "
                             f"{' '.join(MODEL_BASED)}; give the option alone to leave them out)")
    parser.add_argument("--design-model-based", nargs="*", default=list(DESIGN_MODEL_BASED),
                        choices=list(MODEL_BASED),
                        help="with --bench: the design sweep's model-based rows (default: "
                             f"{' '.join(DESIGN_MODEL_BASED)}, the references; mpc does not run in real time and "
                             "costs ~7 CPU-hours over the designs)")
    parser.add_argument("--shipped", nargs="*", default=list(SHIPPED_ROWS), metavar="AGENT",
                        help="with --bench: shipped agents of the default bench (agents/zoo) to evaluate beside the "
                             f"study's own rows (default: {' '.join(SHIPPED_ROWS)}; the option alone: none)")
    parser.add_argument("--n-model-based", type=positive_int, default=50,
                        help="with --bench: benches per design of the sweep for the model-based controllers (default "
                             "50: limit costs ~10 s of CPU per episode)")
    parser.add_argument("--rerun", nargs="+", default=[], metavar="CONTROLLER",
                        help="with --bench: run these scripted or model-based controllers' evaluation batches again "
                             "though the output folder holds them (their code changed); give it once, not on every "
                             "resume")
    add_executor_arguments(parser)  # the tasks: one per PPO seed, then one per controller (its episodes at every load)


DEFAULT_PPO_DIR = "runs/ppo"


def refuse_unnamed_runs(ppo_dir: str, seeds: list[int], skip_train: bool) -> None:
    """The default ``--ppo-dir`` is nobody's choice: the runs the study would load from it (pickles) must be named."""
    if skip_train:
        raise ValueError("--skip-train loads the finished runs in --ppo-dir (pickles, which run code): name the "
                         "folder, e.g. --ppo-dir runs/ppo")
    for seed in seeds:
        run_dir = Path(ppo_dir) / f"seed_{seed}"
        if run_dir.is_dir() and any(run_dir.iterdir()):
            raise ValueError(f"{run_dir} holds an earlier run, which the study would load (pickles, which run "
                             f"code): give --ppo-dir {ppo_dir} to use it, or another --ppo-dir")


def run(args: argparse.Namespace) -> int:
    require()
    with executor_from_args(args) as executor:
        if args.bench:
            from experiments.bench_study import SEEDS, run_bench_study
            timesteps = args.timesteps or 2_000_000
            recurrent = timesteps if args.recurrent_timesteps is None else args.recurrent_timesteps
            if recurrent < 0:
                raise SystemExit("--recurrent-timesteps must be >= 0")
            if args.doc and Path(args.doc).exists() and not args.overwrite_doc:
                raise SystemExit(f"--doc {args.doc} exists; pass --overwrite-doc to replace it")
            run_bench_study(args.out, seeds=args.seeds or list(SEEDS), ppo_timesteps=timesteps,
                            recurrent_timesteps=recurrent or None,
                            design_seeds=args.design_seeds, design_ppo_timesteps=args.design_timesteps,
                            n_heldout=args.n_heldout, in_sample_run=args.in_sample_run, doc=args.doc,
                            model_based=args.model_based, n_model_based=args.n_model_based,
                            design_model_based=args.design_model_based, shipped=args.shipped, rerun=args.rerun,
                            executor=executor)
            return 0
        from experiments.study import run_study  # the RL stack, only when run
        ppo_dir = args.ppo_dir or DEFAULT_PPO_DIR
        if args.ppo_dir is None:
            refuse_unnamed_runs(ppo_dir, args.seeds or [0, 1, 2], args.skip_train)
        run_study(args.out, ppo_dir=ppo_dir, seeds=args.seeds or [0, 1, 2], timesteps=args.timesteps,
                  train=not args.skip_train, doc=args.doc or None, overwrite_doc=args.overwrite_doc,
                  executor=executor, **({"config": args.config} if args.config else {}))
        return 0

"""``triplanar train``: train a controller on TriPlanarShear-v0 (PPO) or -v1 (robust or recurrent PPO) from an
rl-zoo-style YAML in ``agents/``; resumable, one run per seed through the executor.

The options are declared and parsed here; :mod:`agents.training` takes a plain :class:`~agents.training.TrainRequest`
(imported only in :func:`run`, so building the CLI, and ``triplanar --help``, needs neither the agents nor torch).
"""

from __future__ import annotations

import argparse
from typing import Any

from ..gym_registration import IDEAL_ID, REALISTIC_ID
from .options import add_executor_arguments, executor_from_args
from ..output_set import output_lock
from . import require

NAME = "train"
HELP = ("train PPO on TriPlanarShear-v0, or robust/recurrent PPO on TriPlanarShear-v1 (hyperparameters in a YAML "
        "file; resumes from checkpoints)")
ENV_IDS = ("TriPlanarShear-v0", "TriPlanarShear-v1")
TASK_IDS = {IDEAL_ID: "TriPlanarShear-v0", REALISTIC_ID: "TriPlanarShear-v1"}   # the tasks' names: the same envs
DEFAULT_OUT = {"TriPlanarShear-v0": "runs/ppo", "TriPlanarShear-v1": "runs/robust", "recurrent": "runs/recurrent"}


def positive_int(text: str) -> int:
    """argparse type: an integer > 0."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}") from None
    if value <= 0:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}")
    return value


def key_value(text: str) -> tuple[str, Any]:
    """argparse type: ``KEY=VALUE``, the value read as YAML (``3``, ``0.01``, ``true``, ``[27.8, 55.6]``, ``bench``)."""
    key, sep, value = text.partition("=")
    if not sep or not key.strip():
        raise argparse.ArgumentTypeError(f"expected KEY=VALUE, got {text!r}")
    from ..yaml_input import YAMLInputError, load_text  # PyYAML: the rl extra, checked by require() before use
    try:
        return key.strip(), load_text(value, key.strip())
    except YAMLInputError as err:
        raise argparse.ArgumentTypeError(str(err)) from None
    except ModuleNotFoundError:
        raise argparse.ArgumentTypeError("reading KEY=VALUE needs PyYAML (pip install '.[rl]')") from None


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--env", default="TriPlanarShear-v0", choices=ENV_IDS + tuple(TASK_IDS),
                        help=f"the env id (default TriPlanarShear-v0, the same as {IDEAL_ID}); TriPlanarShear-v1 "
                             f"({REALISTIC_ID}) trains robust PPO on the realistic bench")
    parser.add_argument("--config", help="hyperparameter YAML (default agents/ppo.yaml for v0; agents/robust.yaml "
                                         "for v1, agents/recurrent.yaml with --algo recurrent)")
    parser.add_argument("--algo", choices=("ppo", "recurrent"),
                        help="v1 only: ppo (frame stack) or recurrent (LSTM); default: the YAML's")
    parser.add_argument("--env-arg", metavar="KEY=VALUE", type=key_value, action="append", default=[],
                        help="an env argument over the YAML's (repeatable), e.g. latency_s=0.01 or randomize=false")
    parser.add_argument("--set", metavar="KEY.PATH=VALUE", type=key_value, action="append", default=[],
                        dest="overrides", help="any YAML value (repeatable), e.g. hyperparams.learning_rate=1e-4 "
                                               "(v1) or ppo.learning_rate=1e-4 (v0)")
    parser.add_argument("--out", help="output directory; the run goes to OUT/seed_S (default runs/ppo for v0, "
                                      "runs/robust for v1, runs/recurrent with --algo recurrent)")
    parser.add_argument("--seed", type=int, action="append", help="seed (repeatable; default 0)")
    parser.add_argument("--timesteps", type=positive_int, help="total environment steps (default: the YAML's)")
    resume = parser.add_mutually_exclusive_group()
    resume.add_argument("--resume", action="store_true",
                        help="continue the run at the default output folder from its checkpoints (with --out, the "
                             "folder named there is continued anyway); a checkpoint's SB3 zip is unpickled: only "
                             "runs you made")
    resume.add_argument("--no-resume", action="store_true",
                        help="start afresh even if checkpoints exist (the previous run's checkpoints are removed)")
    parser.add_argument("--eval-freq", type=positive_int, metavar="STEPS",
                        help="env steps between the learning curve's evaluations (train.eval_freq; v1's default: "
                             "20 points over the run)")
    parser.add_argument("--tensorboard-log", metavar="DIR",
                        help="TensorBoard logs under DIR (episode return, length, success rate, error over successes, "
                             "evaluations, SB3's losses; `tensorboard --logdir DIR`); default: v0 in each seed's "
                             "tb/, v1 none")
    parser.add_argument("--no-progress", action="store_true", help="no progress bars (neither the seeds' nor a run's)")
    parser.add_argument("--verbose", type=int, default=0, choices=(0, 1, 2),
                        help="SB3's verbosity: 1 prints its table (rollout/ep_rew_mean, success_rate, error_mm_mean, "
                             "train/ losses) at every update")
    add_executor_arguments(parser)  # the seeds are the tasks (each seed's run directory must be shared on a cluster)


def run(args: argparse.Namespace) -> int:
    require()
    from agents.training import TrainRequest, train  # the RL stack, only when training
    args.env = TASK_IDS.get(args.env, args.env)
    if args.algo is not None and args.env == "TriPlanarShear-v0":
        raise ValueError("--algo is for --env TriPlanarShear-v1 (v0 trains PPO with agents/ppo.yaml)")
    seeds = tuple(args.seed or [0])
    if len(set(seeds)) != len(seeds) or not all(0 <= s < 2**32 for s in seeds):
        raise ValueError(f"--seed: each seed once, in [0, {2**32 - 1}], got {', '.join(map(str, seeds))}")
    out = args.out or DEFAULT_OUT[args.algo if args.algo == "recurrent" else args.env]
    named = args.out is not None or args.resume   # else the default folder's checkpoints are refused, not loaded
    from agents.checkpoint_files import new_token
    overrides = dict(args.overrides)
    if args.eval_freq is not None:
        overrides["train.eval_freq"] = args.eval_freq
    request = TrainRequest(env_id=args.env, config=args.config, algo=args.algo, env_kwargs=dict(args.env_arg),
                           overrides=overrides, seeds=seeds, timesteps=args.timesteps,
                           out_dir=out, resume=not args.no_resume, token=new_token(), named=named,
                           verbose=args.verbose, progress=not args.no_progress,
                           tensorboard_log=args.tensorboard_log or "")
    with output_lock(out), executor_from_args(args) as executor:   # one run at a time into a folder
        results = train(request, executor)
    for result in results:
        print(f"seed {result.seed}: {result.timesteps} steps in {result.wall_s:.0f} s -> {result.run_dir}")
    return 0

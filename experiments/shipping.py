"""Ship trained PPO runs as an agent of ``agents/zoo`` (the format is :mod:`agents.zoo`'s): convert each
seed's SB3 model and normalisation statistics into the zoo's data files (safetensors weights, JSON statistics),
check that the converted policy acts bitwise as the run's own on a few hundred steps, evaluate the runs on the
held-out and stress benches, write the model card, and print the pins to add to ``agents.zoo.SHIPPED``.

``python -m experiments.shipping --name NAME --algo ppo --runs RUN/seed_0 RUN/seed_1 ... --command "how they were
trained" [--env-kwargs JSON] [--n 200] [--zoo DIR]`` (``--algo recurrent``: RecurrentPPO runs; ``--algo banked``:
``reference_deviation`` runs, shipped with a specimen bank beside the policy, :mod:`agents.zoo.banked_agent`: the
size they were trained with in their loop, else ``banked:RUN``'s 16; ``--starter AGENT:N``: the project's shipped
AGENT, its seed of each run's number, drives the first N decisions, named in the card). The runs' own files are
SB3 pickles, unpickled here (the runs are the ones you name and trained). The card's figures come from the runs'
files; ``triplanar evaluate --controller NAME`` on the shipped copies reproduces them. The agent's directory is
written under a temporary name and renamed, so a shipped agent is complete or absent.

``python -m experiments.shipping --convert NAME [--zoo DIR]`` converts an agent shipped in the earlier pickled
format (``seed_S/model.zip``, ``seed_S/vecnormalize.pkl``, checked against its card's SHA-256) in place, with the
same bitwise check, and deletes the pickled files.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import shutil
import sys
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from agents.controller_specs import BankedSpec, PPOSpec
from agents.heldout import FAILURE_SCORE_MM

import agents.zoo as zoo_package
from agents.zoo import (CARD, ZOO_DIR, card_markdown, load_shipped, load_starter, model_files, observation_layout,
                        parse_card, read_card, read_pinned)
from triplanar.workbench.executor import ExecutorLike

from .episodes import EpisodeBatch, outcome_table
from .evaluate import run_in_parts
from .stats import row_stats

ENV_ID = "TriPlanarShear-v1"
SHIPPED_SETS = ("heldout", "stress")
CHECK_STEPS = 600      # steps of the bitwise check of a converted seed (two episodes or more)


def write_seed(model: Any, normalizer: Any, agent_dir: Path, seed: int) -> None:
    """One seed's data files from its SB3 model and VecNormalize (the weights as safetensors, the statistics as
    JSON); nothing of the pickles is kept."""
    from safetensors.torch import save as save_tensors

    from agents.zoo.agent import ObsNormalizer
    if not normalizer.norm_obs or normalizer.norm_obs_keys:
        raise ValueError("only VecNormalize with norm_obs=True on a Box observation is shipped")
    policy_rel, norm_rel = model_files(seed)
    (agent_dir / policy_rel).parent.mkdir(parents=True, exist_ok=True)
    tensors = {k: v.detach().cpu().contiguous() for k, v in model.policy.state_dict().items()}
    (agent_dir / policy_rel).write_bytes(save_tensors(tensors))
    rms = normalizer.obs_rms
    (agent_dir / norm_rel).write_text(ObsNormalizer(rms.mean, rms.var, normalizer.epsilon, normalizer.clip_obs,
                                                    rms.count).to_json())


def check_converted(agent: Any, model: Any, normalizer: Any, steps: int = CHECK_STEPS) -> int:
    """Roll the original (unpickled) policy out on the card's env and feed the same observations to the converted
    agent: every action must be bitwise equal (refused otherwise, naming the step). Also checks the rebuilt policy's
    spaces and arguments against the model's. Returns the number of steps compared."""
    card = agent.card
    for attr in ("observation_space", "action_space"):
        want, have = getattr(model.policy, attr), getattr(agent.policy, attr)
        if not (want.shape == have.shape and np.array_equal(want.low, have.low)
                and np.array_equal(want.high, have.high)):
            raise ValueError(f"{card['name']} seed {agent.seed}: the card env's {attr} differs from the model's")
    original = _original(card, model, normalizer, agent.frames, agent.seed)
    env, compared, episode = agent.make_env(), 0, 0
    try:
        while compared < steps:
            obs, _ = env.reset(seed=episode)
            bench = (env.unwrapped.episode_bench.load_N, env.unwrapped.config)   # (a banked agent's bank needs it)
            original.reset(*bench)
            agent.reset(*bench)
            done = False
            while not done and compared < steps:
                want, have = original.act(obs), agent.predict(obs)[0]
                if want.tobytes() != np.asarray(have, dtype=np.float32).tobytes():
                    raise ValueError(f"{card['name']} seed {agent.seed}: converted action differs at episode "
                                     f"{episode} step {compared}: {have} against {want}")
                obs, _, terminated, truncated, _ = env.step(want)
                done, compared = terminated or truncated, compared + 1
            episode += 1
    finally:
        env.close()
    return compared


def _original(card: dict[str, Any], model: Any, normalizer: Any, frames: int, seed: int) -> Any:
    """The run's own controller of the card's kind, on the unpickled model and statistics (a card's ``starter``:
    the project's shipped agent of that name, its seed ``seed``)."""
    from agents.robust_policy import DeviationPolicy, RecurrentPolicy, RobustPolicy
    if card["algo"] == "recurrent":
        return RecurrentPolicy(model, normalizer)
    if card["algo"] == "banked":
        from agents.banked_deviation import BankedDeviationPolicy
        named = card.get("starter")
        start = {"starter": load_starter(named["agent"], seed), "start_periods": named["periods"]} if named else {}
        return BankedDeviationPolicy.with_bank(DeviationPolicy(model, normalizer, frames=frames), card["bank_size"],
                                               bool(card.get("tracker", False)), **start)
    return RobustPolicy(model, normalizer, frames=frames)


def pins_of(agent_dir: Path) -> dict[str, str]:
    """The SHA-256 of the card and every file it lists (what ``agents.zoo.SHIPPED`` pins)."""
    card = parse_card((agent_dir / CARD).read_bytes(), str(agent_dir / CARD))
    return {rel: hashlib.sha256((agent_dir / rel).read_bytes()).hexdigest() for rel in [CARD, *sorted(card["files"])]}


def _finish_card(card: dict[str, Any], agent_dir: Path, sources: dict[int, tuple[Any, Any]],
                 zoo_tmp: Path) -> dict[str, str]:
    """Write the card and its README into ``agent_dir`` (the card listing the new files' hashes), load each seed
    back through the zoo's loader and check it against its source model bitwise (a starter copied beside it from
    the project's zoo, its pinned files); returns the pins."""
    card["files"] = {rel: hashlib.sha256((agent_dir / rel).read_bytes()).hexdigest()
                     for seed in card["seeds"] for rel in model_files(seed)}
    (agent_dir / CARD).write_text(json.dumps(card, indent=2, default=float) + "\n")
    (agent_dir / "README.md").write_text(card_markdown(card))
    pins = pins_of(agent_dir)
    loaded = {card["name"]: pins}
    if card.get("starter"):
        starter = card["starter"]["agent"]
        loaded[starter] = zoo_package.SHIPPED[starter]
        for rel in zoo_package.SHIPPED[starter]:
            (zoo_tmp / starter / rel).parent.mkdir(parents=True, exist_ok=True)
            (zoo_tmp / starter / rel).write_bytes(read_pinned(starter, rel))
    for seed, (model, normalizer) in sources.items():
        agent = load_shipped(card["name"], seed, zoo_tmp, loaded)
        steps = check_converted(agent, model, normalizer)
        print(f"{card['name']} seed {seed}: converted policy bitwise equal to the original on {steps} steps",
              file=sys.stderr)
    return pins


def run_hyperparameters(runs: Sequence[Path]) -> dict[str, Any]:
    """What the runs trained with (each run's ``config.json``, written by :func:`agents.trainer.train_run`),
    for the card; runs of one agent must share it (the seed and the step budget aside)."""
    from agents.robust_policy import run_config
    configs = []
    for run in runs:
        config = run_config(run)
        configs.append({k: v for k, v in config.items() if k != "train"}
                       | {"train": {k: v for k, v in config.get("train", {}).items() if k != "total_timesteps"}})
    if any(c != configs[0] for c in configs[1:]):
        raise ValueError(f"runs {[str(r) for r in runs]} were trained with different configurations (config.json)")
    return configs[0]


def bank_of(runs: Sequence[Path]) -> dict[str, Any]:
    """The card's fields of the specimen bank a ``banked`` agent runs, each run's as ``banked:RUN`` drives it:
    ``bank_size`` (:func:`agents.banked_deviation.run_bank_size`) and, for runs trained on the bank's Gauss-Newton
    tracker, ``tracker`` true (the tracker behind the decision, as a bench runs it: its work priced and bounded
    within the period's slack, :mod:`agents.estimate_worker`). The runs must agree on both."""
    from agents.banked_deviation import run_bank_size, run_tracker
    names = [str(r) for r in runs]
    sizes = {run_bank_size(run) for run in runs}
    if len(sizes) != 1:
        raise ValueError(f"runs {names} were trained with different specimen banks: {sorted(sizes)}")
    tracked = {run_tracker(run) for run in runs}
    if len(tracked) != 1:
        raise ValueError(f"runs {names}: some were trained on the bank's Gauss-Newton tracker "
                         "(env.reference_deviation_tracker) and some not: ship them apart")
    return {"bank_size": sizes.pop(), **({"tracker": True} if tracked.pop() else {})}


def _run_seed(run_dir: Path) -> tuple[int, int]:
    """(seed, timesteps) of a finished run of :func:`agents.trainer.train_run`."""
    done = run_dir / "done.json"
    if not done.is_file():
        raise ValueError(f"{run_dir}: not a finished run (no done.json)")
    summary = json.loads(done.read_text())
    return int(summary["seed"]), int(summary["timesteps"])


def figures(run_dirs: Sequence[Path], algo: str, env_kwargs: dict[str, Any], n: int,
            executor: ExecutorLike = None, starter: tuple[str, int] | None = None) -> dict[str, dict[str, Any]]:
    """Held-out and stress statistics of the runs (one seed each), as the card gives them (``starter``: a banked
    agent's, the shipped agent and the decisions it drives)."""
    kind = {"recurrent": "ppo_recurrent", "banked": "banked"}.get(algo, "ppo")
    kwargs = tuple(sorted((k, v) for k, v in env_kwargs.items() if k != "randomize"))
    tip = env_kwargs.get("tip_friction_deg")

    def spec(run: Path) -> Any:
        if algo != "banked":
            return PPOSpec(str(run), kind)
        return BankedSpec(str(run), *starter, _run_seed(run)[0]) if starter else BankedSpec(str(run))
    out = {}
    for bench_set in SHIPPED_SETS:
        batches = [EpisodeBatch.of(spec(run), kind, bench_set, n, tip, kwargs, _run_seed(run)[0]) for run in run_dirs]
        results = run_in_parts(batches, executor, True, f"card: {bench_set}")
        out[bench_set] = row_stats(*outcome_table(batches, results), FAILURE_SCORE_MM)
    return out


def starter_of(agent: str, periods: int, seeds: Sequence[int]) -> dict[str, Any]:
    """The card's ``starter`` of a banked agent whose first ``periods`` decisions the project's shipped ``agent``
    drives (its seed of each of ``seeds``); refused naming what does not fit."""
    if isinstance(periods, bool) or not isinstance(periods, int) or periods < 1:
        raise ValueError(f"starter periods: a positive number of decisions, got {periods!r}")
    card = read_card(agent)
    missing = sorted(set(seeds) - set(card["seeds"]))
    if missing:
        raise ValueError(f"starter {agent!r} has no seed {missing} (its seeds: {card['seeds']}); the runs' seeds "
                         "are matched to the starter's of the same number")
    if card.get("starter") is not None:
        raise ValueError(f"starter {agent!r} has a starter of its own")
    return {"agent": agent, "periods": periods, "card_sha256": zoo_package.SHIPPED[agent][CARD]}


def ship(name: str, run_dirs: Sequence[str | Path], *, algo: str, command: str,
         env_kwargs: dict[str, Any] | None = None, hyperparameters: dict[str, Any] | None = None, n: int = 200,
         zoo_dir: Path | None = None, executor: ExecutorLike = None, overwrite: bool = False,
         starter: tuple[str, int] | None = None) -> Path:
    """Copy the runs into ``zoo_dir/name`` with a model card; returns the agent's directory. ``starter``
    (``algo`` banked only): (a shipped agent, N) drives the first N decisions (:func:`starter_of`)."""
    if not name.isidentifier():
        raise ValueError(f"agent name {name!r}: letters, digits and underscores only")
    runs = [Path(r) for r in run_dirs]
    if not runs:
        raise ValueError("give at least one run directory")
    seeds = [_run_seed(r) for r in runs]
    if len({s for s, _ in seeds}) != len(seeds):
        raise ValueError(f"runs {runs}: two runs have the same seed")
    steps = {t for _, t in seeds}
    if starter is not None and algo != "banked":
        raise ValueError(f"a starter is a banked agent's (algo {algo!r})")
    started = starter_of(*starter, [s for s, _ in seeds]) if starter is not None else None
    env_kwargs = {"observation_mode": "bench", "randomize": True, **(env_kwargs or {})}
    zoo = Path(zoo_dir or ZOO_DIR)
    final = zoo / name
    if final.exists() and not overwrite:
        raise ValueError(f"{final} exists: ship under another name or pass overwrite")
    # A directory, not a file: write_atomic replaces one file, so the agent's folder is filled under a hidden name
    # and renamed here by hand.
    from agents.ppo_controller import load_untrusted_sb3_zip, load_untrusted_vecnormalize
    zoo_tmp = zoo / f".{name}.tmp"
    tmp = zoo_tmp / name
    shutil.rmtree(zoo_tmp, ignore_errors=True)
    try:
        sources = {}
        for run, (seed, _) in zip(runs, seeds):   # the runs the caller named: their pickles are unpickled here
            sources[seed] = (load_untrusted_sb3_zip(run / "final_model.zip", algo),
                             load_untrusted_vecnormalize(run / "vecnormalize.pkl"))
            write_seed(*sources[seed], tmp, seed)
        hyperparameters = hyperparameters or run_hyperparameters(runs)
        frames = hyperparameters.get("env", {}).get("frame_stack")
        card = {"name": name, "env_id": ENV_ID, "env_kwargs": env_kwargs, "algo": algo,
                **(bank_of(runs) if algo == "banked" else {}), **({"starter": started} if started else {}),
                "hyperparameters": hyperparameters,
                "timesteps": max(steps), "timesteps_by_seed": {str(s): t for s, t in seeds},
                "seeds": [s for s, _ in seeds], "observation": observation_layout(env_kwargs, algo, frames),
                "figures": figures(runs, algo, env_kwargs, n, executor, starter),
                "date": datetime.now(timezone.utc).strftime("%Y-%m-%d %H:%M UTC"), "command": command,
                "files": {}}
        pins = _finish_card(card, tmp, sources, zoo_tmp)
        if final.exists():
            shutil.rmtree(final)
        tmp.rename(final)
    finally:
        shutil.rmtree(zoo_tmp, ignore_errors=True)
    print(f"add to agents.zoo.SHIPPED: {name!r}: {json.dumps(pins, indent=4)}", file=sys.stderr)
    return final


OLD_FILES = ("model.zip", "vecnormalize.pkl")


def convert(name: str, zoo_dir: Path | None = None) -> dict[str, str]:
    """Convert the agent ``zoo_dir/name`` from the earlier pickled format (its files checked against its card's
    SHA-256, then unpickled: the repository's own files) into the data format, check each seed bitwise, swap the
    folder and delete the pickles; returns the pins."""
    from agents.ppo_controller import load_untrusted_sb3_zip, load_untrusted_vecnormalize
    zoo = Path(zoo_dir or ZOO_DIR)
    old = zoo / name
    if old.is_symlink() or not old.is_dir():
        raise ValueError(f"{old}: not an agent folder")
    card = parse_card((old / CARD).read_bytes(), str(old / CARD))
    zoo_tmp = zoo / f".{name}.tmp"
    tmp = zoo_tmp / name
    shutil.rmtree(zoo_tmp, ignore_errors=True)
    try:
        sources = {}
        for seed in card["seeds"]:
            rels = [f"seed_{seed}/{f}" for f in OLD_FILES]
            for rel in rels:
                if hashlib.sha256((old / rel).read_bytes()).hexdigest() != card["files"].get(rel):
                    raise ValueError(f"{old / rel}: not the file its model card names (SHA-256)")
            sources[seed] = (load_untrusted_sb3_zip(old / rels[0], card["algo"]),
                             load_untrusted_vecnormalize(old / rels[1]))
            write_seed(*sources[seed], tmp, seed)
        pins = _finish_card(card, tmp, sources, zoo_tmp)
        backup = zoo_tmp / f"{name}.old"
        old.rename(backup)
        tmp.rename(old)
    finally:
        shutil.rmtree(zoo_tmp, ignore_errors=True)
    return pins


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m experiments.shipping", description=__doc__.splitlines()[0])
    parser.add_argument("--name")
    parser.add_argument("--convert", metavar="NAME", help="convert a zoo agent of the earlier pickled format")
    parser.add_argument("--algo", choices=("ppo", "recurrent", "banked"), default="ppo",
                        help="banked: reference_deviation runs, shipped with a specimen bank beside the policy")
    parser.add_argument("--runs", nargs="+", help="finished run directories (OUT/seed_S)")
    parser.add_argument("--command", help="the command that trained the runs (for the card)")
    parser.add_argument("--env-kwargs", default="{}", help="JSON: the TriPlanarShear-v1 arguments of the training")
    parser.add_argument("--n", type=int, default=200, help="held-out and stress benches for the card's figures")
    parser.add_argument("--zoo", help="zoo directory (default: the repository's agents/zoo)")
    parser.add_argument("--starter", metavar="AGENT:N",
                        help="banked: the project's shipped AGENT (its seed of each run's number) drives the first N "
                        "decisions")
    parser.add_argument("--overwrite", action="store_true")
    args = parser.parse_args(None if argv is None else list(argv))
    if args.n <= 0:
        parser.error("--n must be positive")
    if not args.convert and not (args.name and args.runs and args.command):
        parser.error("--name, --runs and --command are needed to ship runs (or --convert NAME)")
    starter = None
    if args.starter:
        agent, _, periods = args.starter.rpartition(":")
        if not agent or not periods.isdigit():
            parser.error(f"--starter: expected AGENT:N (a shipped agent, a number of decisions), got {args.starter!r}")
        starter = (agent, int(periods))
    try:
        if args.convert:
            pins = convert(args.convert, Path(args.zoo) if args.zoo else None)
            print(f"converted; pin in agents.zoo.SHIPPED: {args.convert!r}: {json.dumps(pins, indent=4)}")
            return 0
        path = ship(args.name, args.runs, algo=args.algo, command=args.command,
                    env_kwargs=json.loads(args.env_kwargs), n=args.n, zoo_dir=Path(args.zoo) if args.zoo else None,
                    overwrite=args.overwrite, starter=starter)
    except (ValueError, OSError) as err:    # a named refusal (a bad card, run, file), not a traceback
        print(f"python -m experiments.shipping: error: {err}", file=sys.stderr)
        return 2
    print(f"shipped {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

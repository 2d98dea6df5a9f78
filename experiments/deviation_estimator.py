"""Train a bench estimator of the reference deviation (:mod:`agents.deviation_estimator`) on rollouts of a
reference-deviation PPO (the privileged teacher), and measure it: rapid motor adaptation's second phase.

``python -m experiments.deviation_estimator collect --policy RUN --out DIR [--driver FOLDER] --first 1000 --n 2000``
rolls episodes out on draws ``first``, ``first + 1``, ... of the tuning stream (never those below
:data:`experiments.train_student.JUDGE_DRAWS`, the judge's; the held-out and stress streams never) and writes one
shard per startable draw, ``DIR/shards/<draw>.npz`` (atomically; no pickle): each decision's bench observation
``obs`` (T, 15), as the controller saw it, and the true deviation ``deviation`` (T, 12) the teacher read with it.
The teacher drives (round 0), or with ``--driver FOLDER`` the composed controller of that estimator (DAgger's later
rounds: the states the estimate's own errors lead to; the label is the truth either way). Noise seed: the draw.
Rerun the same command to resume (complete shards are skipped; other settings are refused, naming them).

``python -m experiments.deviation_estimator train --data DIR [DIR ...] --policy RUN --out EST [--epochs 150]``
fits the GRU by MSE on normalised targets (whole episodes, each cut before its first decision beyond
``--outlier-mm``, 10; a seeded fifth of them held out for validation; the best validation epoch is written,
atomically). ``measure --estimator EST --n 100 [--shadow]`` runs the composed controller on the judge's benches
(``--shadow``: the exact-deviation teacher drives, the estimator follows) and prints the estimator's RMS error by
decision span and the CPU time per decision (EST: an estimator folder or a run trained with its estimator in the
loop). ``seed-loop --policy RUN --estimator EST --out DIR/seed_S`` starts a fine-tuning of the exact-deviation run on
the estimate (``triplanar train --out DIR --seed S --env-arg reference_deviation_estimator=EST --timesteps`` more
than RUN's continues it); ``--bank N`` instead of ``--estimator``: on a specimen bank's estimate (``banked:RUN``'s;
with ``--tracker``, on that bank's Gauss-Newton tracker's, :mod:`agents.deviation_tracker`,
``--env-arg reference_deviation_bank=N``). Results: docs/notes/student-experiments.md, findings 12-13c.
"""

from __future__ import annotations

import argparse
import csv
import hashlib
import json
import math
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from agents.controller_base import play
from agents.deviation_estimator import FORMAT, SPEC, WEIGHTS, tensor_shapes
from agents.estimated_policy import EstimatedDeviationPolicy
from agents.heldout import TUNING_SEED
from agents.robust_policy import DeviationPolicy, load_policy
from envs.triplanar_shear_v1 import TriPlanarShearV1Env
from triplanar.atomic import write_atomic

from .distill_labels import bench_of_draw
from .train_student import JUDGE_DRAWS, judge_draws, validation_episodes

SPANS = ((0, 5), (5, 10), (10, 20), (20, 1000))   # decision index spans of the error table
# An episode is trained on up to its first decision whose deviation leaves this bound (mm): a few runaway episodes
# (up to 74 mm in round 0's 4,042, where the 99.9th percentile of an episode's largest is 4.7 mm) would otherwise
# dominate an MSE; the drift's onset, what a DAgger round is for, is kept.
OUTLIER_MM = 10.0


def driver_of(policy_run: str, driver: str | None) -> Any:
    """The rollouts' controller: the teacher (``driver`` None) or the composed controller of estimator ``driver``."""
    teacher = load_policy(policy_run)
    if not isinstance(teacher, DeviationPolicy):
        raise ValueError(f"--policy {policy_run}: not a reference_deviation run (no env.reference_deviation)")
    if driver is None:
        return teacher
    composed = EstimatedDeviationPolicy.load(driver)
    if composed.policy_run != str(policy_run):
        raise ValueError(f"--driver {driver} feeds {composed.policy_run}, not --policy {policy_run}")
    return composed


def rollout(controller: Any, bench: Any, seed: int) -> dict[str, Any]:
    """One episode: each decision's observation and the true deviation at it (read from the env here, the label;
    the controller reads the env only if it is the privileged teacher)."""
    env = TriPlanarShearV1Env()
    obs, _ = env.reset(seed=seed, options={"bench": bench})
    seen, deviation = [], []

    def record(decided_on: np.ndarray, action: np.ndarray) -> None:
        seen.append(np.asarray(decided_on, dtype=np.float32))
        deviation.append(env.unwrapped.reference_deviation())

    _, _, info = play(controller, env, obs, bench.load_N, on_decision=record)
    return {"obs": np.array(seen), "deviation": np.array(deviation), "success": bool(info["is_success"]),
            "mimicry_error_mm": float(info["mimicry_error_mm"])}


def collect(policy_run: str, out: str | Path, first: int, n: int, driver: str | None = None) -> int:
    """Shards for the startable draws among ``first .. first + n - 1`` (module docstring); returns how many exist."""
    if first < JUDGE_DRAWS:
        raise ValueError(f"--first {first}: draws below {JUDGE_DRAWS} are the judge's, never trained on")
    out = Path(out)
    (out / "shards").mkdir(parents=True, exist_ok=True)
    settings = {"format": FORMAT, "stream": TUNING_SEED, "policy_run": str(policy_run), "driver": driver}
    path = out / "settings.json"
    if path.exists() and json.loads(path.read_text()) != settings:
        raise ValueError(f"{path} holds {json.loads(path.read_text())}, this run {settings}: use a new --out")
    write_atomic(path, lambda tmp: tmp.write_text(json.dumps(settings, indent=1) + "\n"))
    controller, done = driver_of(policy_run, driver), 0
    for draw in range(first, first + n):
        shard = out / "shards" / f"{draw:07d}.npz"
        if shard.exists():
            done += 1
            continue
        bench = bench_of_draw(TUNING_SEED, draw, {})
        if bench is None:
            continue
        arrays = rollout(controller, bench, draw)
        write_atomic(shard, lambda tmp: _save(tmp, draw=draw, **arrays))
        done += 1
    return done


def _save(path: Path, **arrays: Any) -> None:
    with path.open("wb") as f:
        np.savez(f, **arrays)


def load_shards(folders: list[str | Path], bound_mm: float = math.inf) -> list[dict[str, np.ndarray]]:
    """The shards' episodes, each cut before its first decision whose deviation leaves ``bound_mm`` (episodes left
    with fewer than 2 decisions dropped)."""
    episodes = []
    for folder in folders:
        for path in sorted((Path(folder) / "shards").glob("*.npz")):
            with np.load(path, allow_pickle=False) as shard:
                outside = np.flatnonzero(np.abs(shard["deviation"][:, :6]).max(axis=1) > bound_mm)
                keep = int(outside[0]) if len(outside) else len(shard["obs"])
                if keep >= 2:
                    episodes.append({"obs": shard["obs"][:keep], "deviation": shard["deviation"][:keep]})
    if not episodes:
        raise ValueError(f"--data {folders}: no shards")
    return episodes


def split_columns(deviation: np.ndarray) -> tuple[list[int], dict[str, float]]:
    """The columns to estimate, and those constant over the data (by construction) with their value."""
    spread = deviation.max(axis=0) - deviation.min(axis=0)
    fixed = {str(c): float(np.round(deviation[0, c], 9)) for c in range(deviation.shape[1]) if spread[c] < 1e-9}
    return [c for c in range(deviation.shape[1]) if str(c) not in fixed], fixed


def padded(episodes: list[dict[str, np.ndarray]], index: np.ndarray, targets: list[int], norm: dict) -> tuple:
    """(x, y, mask) torch tensors of ``episodes[index]``, normalised, padded to the longest."""
    import torch
    length = max(len(episodes[i]["obs"]) for i in index)
    x = np.zeros((len(index), length, episodes[0]["obs"].shape[1]), np.float32)
    y = np.zeros((len(index), length, len(targets)), np.float32)
    mask = np.zeros((len(index), length), np.float32)
    for row, i in enumerate(index):
        n = len(episodes[i]["obs"])
        x[row, :n] = (episodes[i]["obs"] - norm["in_mean"]) / norm["in_std"]
        y[row, :n] = (episodes[i]["deviation"][:, targets] - norm["out_mean"]) / norm["out_std"]
        mask[row, :n] = 1.0
    return torch.from_numpy(x), torch.from_numpy(y), torch.from_numpy(mask)


def build_network(n_out: int, cells: int, hidden: int, seed: int) -> Any:
    import torch
    torch.manual_seed(seed)

    class Estimator(torch.nn.Module):
        def __init__(self) -> None:
            super().__init__()
            self.gru = torch.nn.GRU(15, cells, batch_first=True)
            self.hidden = torch.nn.Linear(cells, hidden)
            self.head = torch.nn.Linear(hidden, n_out)

        def forward(self, x: Any) -> Any:
            return self.head(torch.tanh(self.hidden(self.gru(x)[0])))

    return Estimator()


def _mse(net: Any, batch: tuple) -> Any:
    x, y, mask = batch
    return (((net(x) - y) ** 2).mean(dim=2) * mask).sum() / mask.sum()


def fit(episodes: list, targets: list[int], norm: dict, args: argparse.Namespace, log: Any) -> tuple[dict, list]:
    """The best validation epoch's tensors and the loss history ([epoch, train, validation] rows)."""
    import torch
    torch.set_num_threads(1)
    val = validation_episodes(len(episodes), 0.2, args.seed)
    train = np.setdiff1d(np.arange(len(episodes)), val)
    net = build_network(len(targets), args.gru, args.hidden, args.seed)
    optimizer = torch.optim.Adam(net.parameters(), lr=args.lr)
    val_batch, best, history = padded(episodes, val, targets, norm), (math.inf, None), []
    for epoch in range(1, args.epochs + 1):
        order, total = train[np.random.default_rng([args.seed, epoch]).permutation(len(train))], 0.0
        for start in range(0, len(order), args.batch):
            loss = _mse(net, padded(episodes, order[start:start + args.batch], targets, norm))
            optimizer.zero_grad()
            loss.backward()
            torch.nn.utils.clip_grad_norm_(net.parameters(), 1.0)
            optimizer.step()
            total += loss.item() * len(order[start:start + args.batch])
        with torch.no_grad():
            val_loss = float(_mse(net, val_batch))
        history.append([epoch, total / len(train), val_loss])
        if val_loss < best[0]:
            best = (val_loss, {k.replace("_l0", ""): v.detach().numpy().astype(np.float32).copy()
                               for k, v in net.state_dict().items()})
        if log is not None and epoch % 10 == 0:
            print(f"epoch {epoch}: train {total / len(train):.4f}, validation {val_loss:.4f}", file=log, flush=True)
    return best[1], history


def train(args: argparse.Namespace, log: Any = None) -> dict[str, Any]:
    """Fit an estimator on ``args.data``'s shards and write it to ``args.out`` (module docstring)."""
    from safetensors.numpy import save
    episodes = load_shards(args.data, args.outlier_mm)
    obs = np.concatenate([e["obs"] for e in episodes])
    deviation = np.concatenate([e["deviation"] for e in episodes])
    targets, fixed = split_columns(deviation)
    norm = {"in_mean": obs.mean(0), "in_std": np.where(obs.std(0) > 1e-9, obs.std(0), 1.0),
            "out_mean": deviation[:, targets].mean(0), "out_std": deviation[:, targets].std(0)}
    norm = {k: v.astype(np.float32) for k, v in norm.items()}
    weights, history = fit(episodes, targets, norm, args, log)
    spec = {"format": FORMAT, "gru": args.gru, "hidden": args.hidden, "targets": targets, "fixed": fixed,
            "policy_run": str(args.policy)}
    tensors = {k: np.ascontiguousarray(v, dtype=np.float32) for k, v in {**weights, **norm}.items()}
    assert set(tensors) == set(tensor_shapes(spec)), sorted(set(tensors) ^ set(tensor_shapes(spec)))
    blob = save(tensors)
    spec["weights_sha256"] = hashlib.sha256(blob).hexdigest()
    best = min(history, key=lambda row: row[2])
    spec["training"] = {"data": [str(d) for d in args.data], "episodes": len(episodes), "decisions": len(obs),
                        "seed": args.seed, "lr": args.lr, "outlier_mm": args.outlier_mm, "batch": args.batch, "epochs": args.epochs,
                        "best_epoch": best[0], "best_val_mse_normalised": best[2], "history": history}
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    write_atomic(out / WEIGHTS, lambda tmp: tmp.write_bytes(blob))
    write_atomic(out / SPEC, lambda tmp: tmp.write_text(json.dumps(spec, indent=1) + "\n"))
    return spec


def seed_loop(policy_run: str, estimator: str | None, out: str | Path, bank: int | None = None,
              tracker: bool = False) -> dict[str, Any]:
    """A run folder ``out`` (``DIR/seed_S``) that ``triplanar train --out DIR --seed S`` with ``--env-arg
    reference_deviation_estimator=ESTIMATOR`` and more ``--timesteps`` continues: the finished reference-deviation
    run ``policy_run``'s model and normalisation statistics as its checkpoint, its configuration with ``estimator``
    in the loop (fine-tuning the exact-deviation policy on the estimate, or an in-loop one on a retrained estimator:
    co-training; UNPICKLES ``policy_run``: only yours). ``bank`` instead of ``estimator``: a specimen bank of that
    many hypotheses in the loop (``env.reference_deviation_bank``, ``banked:RUN``'s estimate); ``tracker``: that
    bank's Gauss-Newton tracker (``env.reference_deviation_tracker``)."""
    from agents.checkpoint_files import save_normalizer
    from agents.ppo_controller import load_untrusted_vecnormalize
    from agents.robust_policy import run_config
    from agents.train_config import DEVIATION_BANK, DEVIATION_ESTIMATOR, DEVIATION_TRACKER
    if (estimator is None) == (bank is None):
        raise ValueError(f"seed-loop: give one of --estimator and --bank, got {estimator!r} and {bank!r}")
    if tracker and bank is None:
        raise ValueError("seed-loop: --tracker needs --bank (the tracker runs beside a bank)")
    run, out = Path(policy_run), Path(out)
    config = run_config(run)
    if not config.get("env", {}).get("reference_deviation"):
        raise ValueError(f"--policy {policy_run}: not a reference_deviation run (no env.reference_deviation)")
    if (out / "checkpoint" / "state.json").exists() or (out / "done.json").exists():
        raise ValueError(f"--out {out}: holds a run already (continue it with triplanar train)")
    steps = int(json.loads((run / "done.json").read_text())["timesteps"])
    if bank is None:
        config["env"][DEVIATION_ESTIMATOR] = str(estimator)
    else:
        config["env"][DEVIATION_BANK] = int(bank)
        if tracker:
            config["env"][DEVIATION_TRACKER] = True
    (out / "checkpoint").mkdir(parents=True, exist_ok=True)
    model, stats = f"model_{steps}.zip", f"vecnormalize_{steps}.npz"
    write_atomic(out / "checkpoint" / model, lambda tmp: tmp.write_bytes((run / "final_model.zip").read_bytes()))
    save_normalizer(out / "checkpoint" / stats, load_untrusted_vecnormalize(run / "vecnormalize.pkl"), steps)
    write_atomic(out / "config.json", lambda tmp: tmp.write_text(json.dumps(config, indent=2)))
    # the source's learning curve goes on (an empty one would make the trainer evaluate until it caught up)
    with (run / "learning_curve.csv").open(newline="") as f:
        curve = [{k: int(v) if v.isdigit() else float(v) for k, v in row.items()} for row in csv.DictReader(f)]
    state = {"timesteps": steps, "wall_s": 0.0, "curve": curve, "model": model, "vecnormalize": stats, "token": ""}
    write_atomic(out / "checkpoint" / "state.json", lambda tmp: tmp.write_text(json.dumps(state)))
    return {"run": str(out), "from": str(run), "timesteps": steps, "estimator": estimator, "bank": bank,
            "tracker": tracker}


def measure(folder: str, n: int, shadow: bool = False) -> dict[str, Any]:
    """The composed controller on the first ``n`` judge benches: the estimator's RMS error (mm, the five estimated
    deviation values; slope, m/m) by decision span, and the CPU time of a whole decision (``time.thread_time``).
    ``shadow``: the exact-deviation teacher drives and the estimator follows the same observations (its error on
    the teacher's own states, without the composed controller's drift)."""
    composed = EstimatedDeviationPolicy.load(folder)
    teacher = load_policy(composed.estimator.spec["policy_run"]) if shadow else None
    errors: list[tuple[int, np.ndarray]] = []
    cpu: list[float] = []
    for i, (_, bench) in enumerate(judge_draws(n, {})):
        env = TriPlanarShearV1Env()
        obs, _ = env.reset(seed=i, options={"bench": bench})
        composed.reset(bench.load_N, env.config)
        if teacher is not None:
            teacher.bind(env)
            teacher.reset(bench.load_N, env.config)
        for decision in range(10_000):
            started = time.thread_time()
            action = composed.act(obs)
            cpu.append(time.thread_time() - started)
            errors.append((decision, composed.estimate - env.unwrapped.reference_deviation()))   # the truth: here only
            obs, _, terminated, truncated, _ = env.step(action if teacher is None else teacher.act(obs))
            if terminated or truncated:
                break
    return {"estimator": folder, "n": n, "driver": "teacher (shadow)" if shadow else "composed",
            "rms_by_span": span_table(errors),
            "cpu_ms_per_decision": {"median": 1e3 * float(np.median(cpu)), "p99": 1e3 * float(np.percentile(cpu, 99)),
                                    "decisions": len(cpu), "clock": "time.thread_time, machine loaded"}}


def span_table(errors: list[tuple[int, np.ndarray]]) -> dict[str, Any]:
    table = {}
    for low, high in SPANS:
        rows = np.array([e for k, e in errors if low <= k < high])
        if len(rows):
            table[f"{low}-{min(high, 999)}"] = {
                "decisions": len(rows), "deviation_rms_mm": [float(v) for v in np.sqrt((rows[:, 1:6] ** 2).mean(0))],
                "slope_rms": [float(v) for v in np.sqrt((rows[:, 7:12] ** 2).mean(0))]}
    return table


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="python -m experiments.deviation_estimator", description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    c = sub.add_parser("collect")
    c.add_argument("--policy", required=True)
    c.add_argument("--out", required=True)
    c.add_argument("--driver", help="an estimator folder: its composed controller drives (DAgger)")
    c.add_argument("--first", type=int, default=JUDGE_DRAWS)
    c.add_argument("--n", type=int, default=2000)
    t = sub.add_parser("train")
    t.add_argument("--data", nargs="+", required=True)
    t.add_argument("--policy", required=True)
    t.add_argument("--out", required=True)
    for name, kind, default in (("gru", int, 64), ("hidden", int, 64), ("epochs", int, 150), ("batch", int, 32),
                                ("lr", float, 1e-3), ("seed", int, 0),
                                ("outlier_mm", float, OUTLIER_MM)):
        t.add_argument(f"--{name.replace('_', '-')}", type=kind, default=default)
    m = sub.add_parser("measure")
    m.add_argument("--estimator", required=True)
    m.add_argument("--n", type=int, default=100)
    m.add_argument("--shadow", action="store_true", help="the exact-deviation teacher drives, the estimator follows")
    s = sub.add_parser("seed-loop", help="a run folder fine-tuning --policy with --estimator in the loop")
    s.add_argument("--policy", required=True)
    s.add_argument("--estimator", help="a bench estimator's folder in the loop")
    s.add_argument("--bank", type=int, help="or a specimen bank of this many hypotheses in the loop (banked:RUN's)")
    s.add_argument("--tracker", action="store_true", help="with --bank: the bank's Gauss-Newton tracker's estimate")
    s.add_argument("--out", required=True, help="DIR/seed_S of the triplanar train run to continue")
    for p in (c, t, m, s):
        p.add_argument("--json", help="also write the result here")
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    try:
        if args.command == "collect":
            result: Any = {"shards": collect(args.policy, args.out, args.first, args.n, args.driver)}
        elif args.command == "train":
            spec = train(args, log=sys.stdout)
            result = {k: v for k, v in spec["training"].items() if k != "history"}
        elif args.command == "seed-loop":
            result = seed_loop(args.policy, args.estimator, args.out, args.bank, args.tracker)
        else:
            result = measure(args.estimator, args.n, args.shadow)
    except ValueError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    print(json.dumps(result, indent=1))
    if args.json:
        Path(args.json).write_text(json.dumps(result, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())

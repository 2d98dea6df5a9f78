"""Train a student of ``mpc`` (:mod:`agents.student`) on expert labels (:mod:`experiments.distill_labels`):
behaviour cloning of ``mpc``'s action from the frame-stacked bench observations, optionally with an auxiliary head
that infers the bench's unknowns (``--aux truth``: the shards' privileged ``truth`` row, normalised).

``python -m experiments.train_student --labels DIR [DIR ...] --out OUT [--epochs 300]`` writes ``OUT/student.json``
and ``OUT/student.safetensors`` (the student, no pickle; :func:`agents.student.read_student` loads it) from the
epoch with the lowest validation loss. The validation set is whole episodes (a seeded share ``--val-fraction`` of
them): a decision's neighbours in time never sit on both sides. Rerun the same command to resume: the run's state
(weights, Adam's moments, the best epoch so far, the loss history, the shard list) is checkpointed atomically every
``--checkpoint-every`` epochs to ``OUT/checkpoint.safetensors`` (its settings and the shard list in the file's
metadata, JSON), and a resumed run ends bitwise where an uninterrupted one does. A resume with other settings is
refused naming them; the shards read are the ones listed when the run started, so a label run adding to the folders
meanwhile does not change a resumed run's data (train on the new shards with a new ``--out``).

``--kind gru --gru 64`` trains a recurrent student (:mod:`agents.student`) on whole episodes (``--batch``
episodes a step, each padded to the longest, the padding masked out of the loss). ``--start-periods K`` makes the
student play ``mpc``'s designed excitation for its first ``K`` decisions (written in its ``start`` field) and drops
those decisions' labels from the loss (they are not the student's to take). ``--post-start-weight W`` counts the
``--post-start-span`` decisions after the start ``W`` times in the loss (where the start students failed).
``--given truth`` appends the bench's true unknowns (the shards' ``truth`` row) to the MLP's input: a privileged
student, an upper bound on what inferring them would give (``--judge`` hands it each bench's truth); it did not
drive better (docs/notes/student-experiments.md, finding 8).

``--judge N`` then runs the student on the first ``N`` startable draws of the tuning stream below 1000 (kept from
labelling for this, :mod:`experiments.distill_labels`) and prints success and score with their intervals.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import sys
from dataclasses import asdict, dataclass, fields
from pathlib import Path
from typing import Any

import numpy as np

from agents.heldout import FAILURE_SCORE_MM, TUNING_SEED, run_episode
from agents.student import FORMAT, KINDS, SPEC, WEIGHTS, StudentController, tensor_shapes
from triplanar.atomic import write_atomic

from .distill_labels import TRUTH_NAMES, bench_of_draw, bench_truth, label_shards, load_labels, truth_values
from .stats import row_stats

CHECKPOINT = "checkpoint.safetensors"
GIVEN = ("none", "truth")   # what a student is given beside the observations (agents.student: given_names)
LABELS = ("expert_action", "plain_action")   # the shard array learnt (plain_action: distill_labels --plain-twin)
JUDGE_DRAWS = 1000   # draws below this of the tuning stream are never labelled (distill_labels' --first default)


@dataclass(frozen=True)
class StudentSettings:
    """What decides a training run (stored in its checkpoint; a resume must repeat them)."""

    frames: int = 4
    hidden: tuple = (256, 256)
    aux: str = "none"           # "truth": infer the privileged row as a second head (it did not help: docs)
    aux_weight: float = 0.1
    lr: float = 1e-3
    weight_decay: float = 1e-5
    batch: int = 256
    epochs: int = 300
    val_fraction: float = 0.2
    seed: int = 0
    kind: str = "mlp"           # or "gru": a recurrent student trained on whole episodes (--batch: episodes)
    gru: int = 64               # the GRU's cells
    start_periods: int = 0      # mpc's designed excitation for the first K decisions (no labels learnt there)
    post_start_weight: float = 1.0   # the loss weight of the decisions just after the start (the rest: 1)
    post_start_span: int = 8         # how many decisions after the start carry post_start_weight
    given: str = "none"         # "truth": the bench's true unknowns appended to the input (privileged, an upper bound)
    label: str = "expert_action"  # or "plain_action": the plain limit's action in the same states (a paired control)

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"kind must be one of {KINDS}, got {self.kind!r}")
        if self.kind == "gru" and (self.gru < 1 or self.aux != "none"):
            raise ValueError(f"a gru student needs gru >= 1 and aux 'none', got gru {self.gru!r}, aux {self.aux!r}")
        if self.start_periods < 0:
            raise ValueError(f"start_periods must be >= 0, got {self.start_periods!r}")
        if not self.post_start_weight > 0 or self.post_start_span < 0:
            raise ValueError(f"post_start_weight must be > 0 and post_start_span >= 0, got "
                             f"{self.post_start_weight!r}, {self.post_start_span!r}")
        if self.given not in GIVEN:
            raise ValueError(f"given must be one of {GIVEN}, got {self.given!r}")
        if self.given != "none" and self.kind != "mlp":
            raise ValueError(f"given {self.given!r} needs kind 'mlp', got {self.kind!r}")
        if self.label not in LABELS:
            raise ValueError(f"label must be one of {LABELS}, got {self.label!r}")
        if self.aux not in ("truth", "none"):
            raise ValueError(f"aux must be 'truth' or 'none', got {self.aux!r}")
        if not 0.0 <= self.val_fraction < 1.0:
            raise ValueError(f"val_fraction must be within 0-1 (1 excluded), got {self.val_fraction!r}")
        for name in ("frames", "batch", "epochs"):
            if int(getattr(self, name)) < 1:
                raise ValueError(f"{name} must be >= 1, got {getattr(self, name)!r}")
        if not self.hidden or any(int(h) < 1 for h in self.hidden):
            raise ValueError(f"hidden must be layer sizes >= 1, got {self.hidden!r}")

    def record(self) -> dict[str, Any]:
        return json.loads(json.dumps(asdict(self)))


def validation_episodes(n_episodes: int, fraction: float, seed: int) -> np.ndarray:
    """Indices of the episodes held out for validation: a seeded ``fraction`` of them (at least one when there are
    two or more and ``fraction`` > 0)."""
    k = int(round(fraction * n_episodes))
    if fraction > 0 and n_episodes >= 2:
        k = min(max(k, 1), n_episodes - 1)
    return np.sort(np.random.default_rng([seed, 77]).permutation(n_episodes)[:k])


def env_kwargs_of(folders: list[Path]) -> dict[str, Any]:
    """The env arguments the labels ran with (every folder's ``settings.json`` must agree)."""
    found = {}
    for folder in folders:
        path = folder / "settings.json"
        try:
            found[str(folder)] = json.loads(path.read_text())["env_kwargs"]
        except (OSError, ValueError, KeyError) as err:
            raise ValueError(f"{path}: not a label folder's settings ({type(err).__name__}: {err})") from None
    if len({json.dumps(v, sort_keys=True) for v in found.values()}) > 1:
        raise ValueError(f"the label folders ran different envs: {found}; a student learns one bench")
    return next(iter(found.values()))


@dataclass
class Dataset:
    """The training and validation arrays, normalised, and what normalised them."""

    x: np.ndarray
    y: np.ndarray
    aux: np.ndarray
    train: np.ndarray        # row indices
    val: np.ndarray
    obs_mean: np.ndarray
    obs_std: np.ndarray
    aux_mean: np.ndarray
    aux_std: np.ndarray
    aux_names: list
    n_episodes: int
    val_episodes: list
    bounds: np.ndarray       # (episodes + 1,) the first row of each episode (rows are in episode order)
    weight: np.ndarray       # (rows,) float32: the label's weight in the loss (0 where not learnt)
    given_names: list        # the inputs after the frame stack (StudentSettings.given)

    @property
    def learnt(self) -> np.ndarray:
        """(rows,) bool: the decision's label is learnt (after the start's periods)."""
        return self.weight > 0


def _scale(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    mean, std = a.mean(axis=0), a.std(axis=0)
    std = np.where(std > 1e-6 * np.maximum(1.0, np.abs(mean)), std, 1.0)   # a constant column stays as it is
    return mean.astype(np.float32), std.astype(np.float32)


def dataset(shards: list[str], settings: StudentSettings) -> Dataset:
    """The shards' decisions, split by episode and normalised on the training rows."""
    data = load_labels([], settings.frames, shards=shards, label=settings.label)
    n_episodes = int(data["episode"].max()) + 1
    held = validation_episodes(n_episodes, settings.val_fraction, settings.seed)
    is_val = np.isin(data["episode"], held)
    learnt = data["step"] >= settings.start_periods
    train, val = np.flatnonzero(~is_val & learnt), np.flatnonzero(is_val & learnt)
    given_names = list(TRUTH_NAMES) if settings.given == "truth" else []
    if given_names:   # appended after the frames, normalised with them (agents.student reads them so)
        data["x"] = np.concatenate([data["x"], data["truth"][:, :len(given_names)]], axis=1)
    obs_mean, obs_std = _scale(data["x"][train])
    aux_names = list(TRUTH_NAMES) if settings.aux == "truth" else []
    aux = data["truth"][:, :len(aux_names)].astype(np.float32)
    aux_mean, aux_std = _scale(aux[train]) if aux_names else (np.zeros(0, np.float32), np.ones(0, np.float32))
    x = ((data["x"] - obs_mean) / obs_std).astype(np.float32)
    bounds = np.searchsorted(data["episode"], np.arange(n_episodes + 1))
    return Dataset(x, data["y"].astype(np.float32), ((aux - aux_mean) / aux_std).astype(np.float32), train, val,
                   obs_mean, obs_std, aux_mean, aux_std, aux_names, n_episodes, [int(e) for e in held], bounds,
                   loss_weights(data["step"], settings), given_names)


def loss_weights(step: np.ndarray, settings: StudentSettings) -> np.ndarray:
    """Each decision's weight in the loss: 0 during the start (not learnt), ``post_start_weight`` for the
    ``post_start_span`` decisions after it (where the students failed: docs/notes/student-experiments.md), 1 later."""
    weight = np.where(step >= settings.start_periods, 1.0, 0.0)
    after = (step >= settings.start_periods) & (step < settings.start_periods + settings.post_start_span)
    return np.where(after, settings.post_start_weight, weight).astype(np.float32)


def build_network(settings: StudentSettings, n_aux: int, n_given: int = 0) -> Any:
    """The torch network whose tensors :class:`agents.student.StudentController` evaluates (same names)."""
    import torch
    torch.manual_seed(settings.seed)

    class Student(torch.nn.Module):
        def __init__(self) -> None:
            super().__init__()
            width = settings.frames * 15 + n_given
            self.gru = None
            if settings.kind == "gru":
                self.gru = torch.nn.GRU(width, settings.gru, batch_first=True)
                width = settings.gru
            layers = []
            for size in settings.hidden:
                layers.append(torch.nn.Linear(width, size))
                width = size
            self.hidden = torch.nn.ModuleList(layers)
            self.action = torch.nn.Linear(width, 2)
            self.aux = torch.nn.Linear(width, n_aux) if n_aux else None

        def forward(self, x: Any) -> tuple[Any, Any]:
            if self.gru is not None:   # x: (episodes, steps, inputs), each episode from a zero state
                x = self.gru(x)[0]
            for layer in self.hidden:
                x = torch.tanh(layer(x))
            return torch.tanh(self.action(x)), (self.aux(x) if self.aux is not None else None)

    return Student()


def file_name(torch_name: str) -> str:
    """A network tensor's name in the student's file (``hidden.0.weight`` -> ``hidden0.weight``,
    ``gru.weight_ih_l0`` -> ``gru.weight_ih``); :func:`torch_name` inverts it."""
    return torch_name.replace("hidden.", "hidden").replace("_l0", "")


def torch_name(name: str) -> str:
    if name.startswith("gru."):
        return name + "_l0"
    return name.replace("hidden", "hidden.", 1) if name.startswith("hidden") else name


def _tensors(net: Any) -> dict[str, np.ndarray]:
    return {file_name(k): v.detach().numpy().astype(np.float32).copy() for k, v in net.state_dict().items()}


def episode_batch(data: Dataset, episodes: np.ndarray) -> tuple[Any, Any, Any]:
    """(x, y, mask) of whole ``episodes``, padded to the longest: mask holds each decision's weight in the loss
    (:func:`loss_weights`: 0 for the start's decisions and the padding)."""
    import torch
    lengths = data.bounds[episodes + 1] - data.bounds[episodes]
    x = np.zeros((len(episodes), int(lengths.max()), data.x.shape[1]), np.float32)
    y = np.zeros((len(episodes), x.shape[1], 2), np.float32)
    mask = np.zeros(x.shape[:2], np.float32)
    for i, (e, n) in enumerate(zip(episodes, lengths)):
        span = np.arange(data.bounds[e], data.bounds[e] + n)
        x[i, :n], y[i, :n] = data.x[span], data.y[span]
        mask[i, :n] = data.weight[span]
    return torch.from_numpy(x), torch.from_numpy(y), torch.from_numpy(mask)


def episodes_of_rows(data: Dataset, rows: np.ndarray) -> np.ndarray:
    return np.unique(np.searchsorted(data.bounds, rows, side="right") - 1)


def _sequence_mse(net: Any, data: Dataset, episodes: np.ndarray) -> Any:
    x, y, mask = episode_batch(data, episodes)
    action, _ = net(x)
    return (((action - y) ** 2).sum(dim=2) * mask).sum() / (2.0 * mask.sum())


def _losses(net: Any, data: Dataset, rows: np.ndarray, settings: StudentSettings) -> tuple[float, float, float]:
    """(loss, action RMS error, aux RMS error in normalised units) on ``rows``, without gradients."""
    import torch
    if not len(rows):
        return math.nan, math.nan, math.nan
    if settings.kind == "gru":
        with torch.no_grad():
            mse = float(_sequence_mse(net, data, episodes_of_rows(data, rows)))
        return mse, math.sqrt(mse), math.nan
    with torch.no_grad():
        action, aux = net(torch.from_numpy(data.x[rows]))
        action_mse = float(((action - torch.from_numpy(data.y[rows])) ** 2).mean())
        aux_mse = float(((aux - torch.from_numpy(data.aux[rows])) ** 2).mean()) if aux is not None else math.nan
        fit = action_mse if settings.post_start_weight == 1.0 else float(_weighted_mse(action, data, rows))
    loss = fit + (settings.aux_weight * aux_mse if aux is not None else 0.0)
    return loss, math.sqrt(action_mse), math.sqrt(aux_mse)


def _weighted_mse(action: Any, data: Dataset, rows: np.ndarray) -> Any:
    """The action's squared error on ``rows``, weighted by :func:`loss_weights` (the weights' mean is the unit)."""
    import torch
    weight = torch.from_numpy(data.weight[rows])
    return (((action - torch.from_numpy(data.y[rows])) ** 2).mean(dim=1) * weight).sum() / weight.sum()


def _epoch(net: Any, optimizer: Any, data: Dataset, settings: StudentSettings, epoch: int) -> float:
    """One pass over the training rows in a seeded order; the mean training loss."""
    import torch
    if settings.kind == "gru":
        return _sequence_epoch(net, optimizer, data, settings, epoch)
    order = data.train[np.random.default_rng([settings.seed, epoch]).permutation(len(data.train))]
    total = 0.0
    for start in range(0, len(order), settings.batch):
        rows = order[start:start + settings.batch]
        action, aux = net(torch.from_numpy(data.x[rows]))
        if settings.post_start_weight == 1.0:   # (unweighted as before: earlier runs resume bitwise)
            loss = ((action - torch.from_numpy(data.y[rows])) ** 2).mean()
        else:
            loss = _weighted_mse(action, data, rows)
        if aux is not None:
            loss = loss + settings.aux_weight * ((aux - torch.from_numpy(data.aux[rows])) ** 2).mean()
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
        total += loss.item() * len(rows)
    return total / len(order)


def _sequence_epoch(net: Any, optimizer: Any, data: Dataset, settings: StudentSettings, epoch: int) -> float:
    """One pass over the training episodes in a seeded order, ``batch`` whole episodes a step."""
    train = episodes_of_rows(data, data.train)
    order = train[np.random.default_rng([settings.seed, epoch]).permutation(len(train))]
    total = 0.0
    for start in range(0, len(order), settings.batch):
        loss = _sequence_mse(net, data, order[start:start + settings.batch])
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
        total += loss.item() * len(order[start:start + settings.batch])
    return total / len(order)


def save_checkpoint(path: Path, net: Any, optimizer: Any, best: dict[str, np.ndarray], meta: dict[str, Any]) -> None:
    """The run's state in one file, written whole: weights, Adam's moments and step counts, the best weights so far
    (``best.*``) and ``meta`` (JSON in the file's metadata)."""
    from safetensors.numpy import save
    tensors = {f"net.{k}": v for k, v in _tensors(net).items()}
    tensors.update({f"best.{k}": v for k, v in best.items()})
    state = optimizer.state_dict()
    for index, moments in state["state"].items():
        for key, value in moments.items():
            tensors[f"adam.{index}.{key}"] = np.asarray(value.detach().numpy(), dtype=np.float32).copy()
    blob = save(tensors, metadata={"meta": json.dumps(meta)})
    write_atomic(path, lambda tmp: tmp.write_bytes(blob))


def load_checkpoint(path: Path, net: Any, optimizer: Any) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """Restore ``net`` and ``optimizer`` from :func:`save_checkpoint`'s file; returns (best weights, meta)."""
    import torch
    from safetensors import safe_open
    with safe_open(str(path), framework="numpy") as f:
        meta = json.loads(f.metadata()["meta"])
        tensors = {k: f.get_tensor(k) for k in f.keys()}
    net.load_state_dict({torch_name(k[4:]): torch.from_numpy(v) for k, v in tensors.items() if k.startswith("net.")})
    state = optimizer.state_dict()
    for index in range(len(state["param_groups"][0]["params"])):
        keys = [k for k in tensors if k.startswith(f"adam.{index}.")]
        if keys:
            state["state"][index] = {k.rsplit(".", 1)[1]: torch.from_numpy(tensors[k].copy()) for k in keys}
    optimizer.load_state_dict(state)
    best = {k[5:]: v for k, v in tensors.items() if k.startswith("best.")}
    return best, meta


def _refuse_other_settings(meta: dict[str, Any], settings: StudentSettings, out: Path) -> None:
    defaults = StudentSettings().record()   # a field added since the run started: its default
    stored, now = {**defaults, **meta["settings"]}, settings.record()
    differ = [f"{k} (stored {stored.get(k)!r}, now {now.get(k)!r})" for k in sorted(set(stored) | set(now))
              if stored.get(k) != now.get(k)]
    if differ:
        raise ValueError(f"{out / CHECKPOINT} was trained with other settings: {'; '.join(differ)}. Rerun with the "
                         "stored settings to resume, or use a new --out")


def write_student(out: Path, weights: dict[str, np.ndarray], data: Dataset, settings: StudentSettings,
                  record: dict[str, Any]) -> dict[str, Any]:
    """``OUT/student.safetensors`` and ``OUT/student.json`` (the weights file first: the spec names its hash)."""
    from safetensors.numpy import save
    tensors = {**weights, "obs_mean": data.obs_mean, "obs_std": data.obs_std}
    if data.aux_names:
        tensors.update(aux_mean=data.aux_mean, aux_std=data.aux_std)
    spec = {"format": FORMAT, "frames": settings.frames, "hidden": [int(h) for h in settings.hidden],
            "aux_names": data.aux_names, "env_id": "TriPlanarShear-v1", "env_kwargs": record.pop("env_kwargs")}
    if settings.kind == "gru":
        spec.update(kind="gru", gru=int(settings.gru))
    if data.given_names:
        spec["given_names"] = data.given_names
    if settings.start_periods:
        spec["start"] = mpc_start(settings.start_periods, spec["env_kwargs"])
    expected = tensor_shapes(spec)
    tensors = {k: np.ascontiguousarray(tensors[k], dtype=np.float32) for k in expected}
    blob = save(tensors)
    spec["weights_sha256"] = hashlib.sha256(blob).hexdigest()
    spec["training"] = record
    write_atomic(out / WEIGHTS, lambda tmp: tmp.write_bytes(blob))
    write_atomic(out / SPEC, lambda tmp: tmp.write_text(json.dumps(spec, indent=1) + "\n"))
    return spec


def train(folders: list[str | Path], out: str | Path, settings: StudentSettings, checkpoint_every: int = 10,
          stop_after: int | None = None, log: Any = None) -> dict[str, Any]:
    """Train (or resume) a student on the labels in ``folders`` and write it to ``out`` (module docstring);
    ``stop_after``: stop after that many epochs of this call, checkpointed (what a kill does, for tests).
    Returns ``student.json``'s content (None if stopped early)."""
    import torch
    torch.set_num_threads(1)   # one core: the machine is shared, and the run is bitwise repeatable
    out, folders = Path(out), [Path(f) for f in folders]
    out.mkdir(parents=True, exist_ok=True)
    meta: dict[str, Any] = {"settings": settings.record(), "epoch": 0, "history": [], "best_epoch": 0,
                            "best_val": math.inf, "shards": [str(p) for p in label_shards(folders)],
                            "env_kwargs": env_kwargs_of(folders), "labels": [str(f) for f in folders]}
    if (out / CHECKPOINT).exists():
        stored = load_checkpoint_meta(out / CHECKPOINT)
        _refuse_other_settings(stored, settings, out)
        meta["shards"] = stored["shards"]
    data = dataset(meta["shards"], settings)
    net = build_network(settings, len(data.aux_names), len(data.given_names))
    optimizer = torch.optim.AdamW(net.parameters(), lr=settings.lr, weight_decay=settings.weight_decay)
    best = _tensors(net)
    if (out / CHECKPOINT).exists():
        best, meta = load_checkpoint(out / CHECKPOINT, net, optimizer)
    done_here = 0
    while meta["epoch"] < settings.epochs:
        epoch = meta["epoch"] + 1
        train_loss = _epoch(net, optimizer, data, settings, epoch)
        val_loss, val_action_rms, val_aux_rms = _losses(net, data, data.val, settings)
        meta["history"].append([epoch, train_loss, val_loss, val_action_rms, val_aux_rms])
        score = val_loss if len(data.val) else train_loss
        if score < meta["best_val"]:
            meta["best_val"], meta["best_epoch"], best = score, epoch, _tensors(net)
        meta["epoch"], done_here = epoch, done_here + 1
        if log is not None and (epoch % checkpoint_every == 0 or epoch == settings.epochs):
            print(f"epoch {epoch}: train {train_loss:.4f}, validation {val_loss:.4f} (action RMS "
                  f"{val_action_rms:.4f}, aux RMS {val_aux_rms:.3f}); best epoch {meta['best_epoch']}", file=log,
                  flush=True)
        if epoch % checkpoint_every == 0 or epoch == settings.epochs or done_here == stop_after:
            save_checkpoint(out / CHECKPOINT, net, optimizer, best, meta)
        if done_here == stop_after and epoch < settings.epochs:
            return None
    record = {"env_kwargs": meta["env_kwargs"], "labels": meta["labels"], "settings": meta["settings"],
              "episodes": data.n_episodes, "decisions": int(len(data.y)), "validation_episodes": data.val_episodes,
              "validation_decisions": int(len(data.val)), "best_epoch": meta["best_epoch"],
              "val_action_rms_of_the_mean": _rms_of_the_mean(data),
              "history_columns": ["epoch", "train_loss", "val_loss", "val_action_rms", "val_aux_rms"],
              "history": meta["history"], "shards": [Path(p).name for p in meta["shards"]]}
    return write_student(out, best, data, settings, record)


def mpc_start(periods: int, env_kwargs: dict[str, Any]) -> list[list[float]]:
    """``mpc``'s designed excitation (its default settings) for the first ``periods`` decisions on the env."""
    from agents.mpc import MPCController
    from envs.triplanar_shear_v1 import TriPlanarShearV1Env
    config = TriPlanarShearV1Env(**env_kwargs).config
    expert = MPCController()
    return [[float(v) for v in expert.start_command(p, config)] for p in range(1, periods + 1)]


def _rms_of_the_mean(data: Dataset) -> float:
    """The validation action RMS error of the constant guess (the training rows' mean action): what the student's
    own figure is to be read against."""
    if not len(data.val):
        return math.nan
    return float(np.sqrt(((data.y[data.val] - data.y[data.train].mean(axis=0)) ** 2).mean()))


def load_checkpoint_meta(path: Path) -> dict[str, Any]:
    from safetensors import safe_open
    with safe_open(str(path), framework="numpy") as f:
        return json.loads(f.metadata()["meta"])


def judge_draws(n: int, env_kwargs: dict[str, Any]) -> list[tuple[int, Any]]:
    """The first ``n`` startable draws of the tuning stream below :data:`JUDGE_DRAWS`, as ``(draw, bench)``."""
    found = []
    for draw in range(JUDGE_DRAWS):
        if len(found) == n:
            return found
        bench = bench_of_draw(TUNING_SEED, draw, env_kwargs)
        if bench is not None:
            found.append((draw, bench))
    if len(found) < n:
        raise ValueError(f"--judge {n}: only {len(found)} draws below {JUDGE_DRAWS} start")
    return found


def judge(folder: str | Path, n: int, skip: int = 0) -> dict[str, Any]:
    """The student of ``folder`` on :func:`judge_draws`' benches from the ``skip``-th (:func:`judge_controller`); a
    privileged student (``given_names``) is given each bench's true unknowns."""
    student = StudentController.load(folder)

    def give(bench: Any) -> None:
        if student.given_names:   # a privileged student: the bench's true unknowns (StudentSettings.given)
            student.given = truth_values(bench_truth(bench), student.given_names)
    return judge_controller(student, student.env_kwargs, n, skip, give)


def judge_controller(controller: Any, env_kwargs: dict[str, Any], n: int, skip: int = 0,
                     before: Any = None) -> dict[str, Any]:
    """``controller`` on :func:`judge_draws`' benches from the ``skip``-th (noise seed: the bench's index, as
    ``triplanar evaluate`` seeds a learned controller; ``before(bench)`` called before each episode):
    :func:`experiments.stats.row_stats` and each failure (index, reason, decisions)."""
    return judged_stats([judge_outcomes(controller, env_kwargs, n, skip, before)])


def judge_outcomes(controller: Any, env_kwargs: dict[str, Any], n: int, skip: int = 0,
                   before: Any = None) -> list[Any]:
    """The episodes of :func:`judge_controller` (:class:`agents.heldout.Outcome` each)."""
    outcomes = []
    for i, (_, bench) in enumerate(judge_draws(n, env_kwargs)):
        if i >= skip:
            if before is not None:
                before(bench)
            outcomes.append(run_episode(controller, bench, env_kwargs=env_kwargs, seed=i, bench_set="tuning",
                                        index=i))
    return outcomes


def judged_stats(runs: list[list[Any]]) -> dict[str, Any]:
    """:func:`experiments.stats.row_stats` of one or more controllers' :func:`judge_outcomes` on the same benches
    (pooled as seeds of a row) and each failure (index, reason, decisions)."""
    errors = np.array([[o.mimicry_error_mm for o in outcomes] for outcomes in runs])
    success = np.array([[o.success for o in outcomes] for outcomes in runs])
    stats = row_stats(errors, success, FAILURE_SCORE_MM)
    stats["failures"] = [(o.index, o.reason, o.steps) for outcomes in runs for o in outcomes
                         if not o.success]   # steps: when it ended
    return stats


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog="python -m experiments.train_student", description=__doc__.split("\n\n")[0])
    parser.add_argument("--labels", nargs="+", help="label folders (DAgger's rounds: all of them)")
    parser.add_argument("--out", required=True, help="the student's folder (rerun the command to resume)")
    defaults = StudentSettings()
    for f in fields(StudentSettings):
        if f.name == "hidden":
            parser.add_argument("--hidden", type=int, nargs="+", default=list(defaults.hidden))
        else:
            parser.add_argument(f"--{f.name.replace('_', '-')}", type=type(getattr(defaults, f.name)),
                                default=getattr(defaults, f.name))
    parser.add_argument("--checkpoint-every", type=int, default=10, help="epochs between checkpoints")
    parser.add_argument("--judge", type=int, default=0, metavar="N", help="then run the student on the first N "
                        f"startable tuning draws below {JUDGE_DRAWS} (never labelled) and print its statistics")
    parser.add_argument("--judge-skip", type=int, default=0, metavar="M", help="judge only from the M-th of those "
                        "draws (--judge 200 --judge-skip 100: the second 100, kept for reporting a choice made on "
                        "the first)")
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    try:
        if args.labels:
            settings = StudentSettings(**{f.name: tuple(getattr(args, f.name)) if f.name == "hidden"
                                          else getattr(args, f.name) for f in fields(StudentSettings)})
            spec = train(args.labels, args.out, settings, args.checkpoint_every, log=sys.stdout)
            t = spec["training"]
            best = t["history"][t["best_epoch"] - 1]
            print(f"student in {args.out}: {t['episodes']} episodes, {t['decisions']} decisions, best epoch "
                  f"{t['best_epoch']} (validation action RMS {best[3]:.4f}; the mean action's "
                  f"{t['val_action_rms_of_the_mean']:.4f})")
        if args.judge:
            print(json.dumps(judge(args.out, args.judge, args.judge_skip), indent=1))
    except ValueError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())

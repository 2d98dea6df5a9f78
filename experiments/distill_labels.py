"""Expert labels for distilling ``mpc`` into a policy that runs in real time (DAgger: Ross, Gordon & Bagnell 2011).

``python -m experiments.distill_labels --out DIR [--first 1000] [--n 1000] [--workers 1]`` rolls episodes out on
draws of the tuning stream (``agents.heldout.TUNING_SEED``; the held-out and stress streams are refused) and writes
one shard per episode, ``DIR/shards/<stream>_<draw>.npz`` (atomically, :func:`triplanar.atomic.write_atomic`; no
pickle): every visited state's observation and ``mpc``'s action in it. Rerun the same command to resume: complete
shards are skipped (a run killed at any point loses at most the episodes it was running). The settings (the
expert's, the round's, the stream, the code version of the expert and the env) are stored in
``DIR/settings.json`` on the first run; a resume whose settings differ is refused naming the fields that differ
(labels of two experts or two envs must not be mixed in one folder).

**Rounds.** Round 0 (``--driver expert``) rolls out ``mpc`` itself, so the label is the action that ran. A later
round rolls out another controller, the *driver* (the student of the previous round: any controller
:func:`agents.controller_specs.parse_controller` reads, ``ppo:RUN``, ``ppo_recurrent:RUN``, ``shipped:NAME``,
``student:FOLDER`` or a bench controller such as ``pi_feedback``), with ``mpc`` alongside it: every period ``mpc``
is shown the same observation and told the action that ran (its estimator must follow the bench, not its own wish),
and its action is the label. With ``--beta B`` the expert's own action runs instead in a fraction ``B`` of the
periods (DAgger's mixture, drawn from a generator seeded by the round and the draw). Each round is a folder of its
own; the student is trained on the union of the rounds' shards (DAgger's aggregation): :func:`load_labels` reads
them as one frame-stacked training set. ``--teacher limit`` labels with the privileged ``limit``
(:mod:`agents.limit`, which knows the bench) instead of ``mpc``, at about a fifth of its CPU; the folder records the
teacher.

**A shard** (``numpy.load(path)``; arrays over the episode's ``T`` decisions):

=====================  ==========================================================================================
``obs``                (T, 15) float32: the bench observation before each decision, as the policy sees it
                       (``obs_names``: ``envs.triplanar_shear_v1.BENCH_OBSERVATION``); ``final_obs`` (15,) after
                       the last. A frame stack of ``k`` at decision ``t`` is ``obs[t-k+1 .. t]`` padded with
                       ``obs[0]`` (as ``FrameStackObservation`` pads); a recurrent student reads the sequence.
``expert_action``      (T, 2) float32: ``mpc``'s action (the label); ``action``: what ran; ``expert_ran``: whether
                       it was the expert's.
``reward``,            (T,) the env's reward and the distance to the case-C path after each period (mm), ``travel_m``
``distance_mm``        the travel.
``expert_estimate``    (T, 11): ``mpc``'s estimate of the unknowns after each decision (``estimate_names``), an
                       auxiliary target; ``expert_planned`` (T,) whether it replanned.
``plain_action``       (T, 2) float32, only with ``--plain-twin`` (``--teacher limit``): the action of a plain
                       ``limit`` (as shipped) shown the same states, the control for a teacher set by ``--expert``.
``truth``              (15,): privileged information, the bench's true unknowns (``truth_names``: the estimator's
                       parameters, geometry and dip directions, then the load level), for a privileged teacher.
scalars                ``stream``, ``draw``, ``round``, ``noise_seed``, ``started`` (False: friction holds this draw at
                       rest, nothing ran), ``success``, ``reason``, ``mimicry_error_mm``, ``steps``.
``expert_cpu_s``,      the CPU time of each decision and of the episode: the only arrays that differ between two
``episode_cpu_s``      runs of the same draw.
=====================  ==========================================================================================

Cost: ``mpc``'s episodes take 10-25 CPU s on the tuning benches and far more on a few (``docs/actuator-study.md``,
"Expert labels for a real-time controller", has the measured rate and the CPU-hours per 1,000 episodes).
"""

from __future__ import annotations

import argparse
import ast
import hashlib
import json
import math
import os
import sys
import time
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from agents.controller_specs import ControllerSpecError, parse_controller
from agents.estimator import GEOMETRY, PARAMETERS
from agents.heldout import HELDOUT_SEED, STRESS_SEED, TUNING_SEED, first_startable
from agents.limit import LimitController
from agents.mpc import MPCController
from agents.privileged import TRUTH_NAMES, bench_truth
from envs.core import make_config
from envs.triplanar_shear_v1 import BENCH_FIELDS, BENCH_OBSERVATION, TriPlanarShearV1Env, draw_bench
from triplanar.atomic import remove_stale_temporaries, write_atomic
from triplanar.executor import run_tasks
from triplanar.workbench.report import write_json

from .episodes import noise_seed

FORMAT = 1
TEACHERS = {"mpc": MPCController, "limit": LimitController}   # limit knows the specimen (privileged)
LIMIT_STATE = ("needs_env", "decisions")                    # LimitController fields that are not settings
MIX_SEED = 50_050  # the DAgger mixture's generator: [MIX_SEED, round, draw]
REFUSED_STREAMS = {HELDOUT_SEED: "the held-out stream", STRESS_SEED: "the stress stream"}
NOT_SETTINGS = ("name", "config", "load_N", "info")  # MPCController fields that are state, not settings
# The labels' mpc keeps its estimator unbounded (move_periods 0: a resample-move and refinement in every period), as
# the label folders were made before mpc's default bounded it (docs/performance.md); ``--expert move_periods=N``
# overrides it. Pinned here, not taken from the default, so that a changed default does not change the expert.
# The same for the planner's work budgets (mpc's default since 2026-11-29; none in the labels' expert).
EXPERT_PINNED = {"mpc": {"move_periods": 0, "fev_budget": 0.0, "decision_fev_budget": 0.0}, "limit": {}}
# Expert settings added after label folders were made, at the value that leaves the expert as it was: a folder
# whose settings.json lacks one holds labels of that value (so that a resume is not refused for a new field).
ADDED_SETTINGS = {"fev_budget": 0.0, "decision_fev_budget": 0.0, "change_cost": 0.0}
# The sources whose code decides a label: the expert, its estimator and planner, the env and the physics under it.
CODE = ("agents/mpc.py", "agents/estimator.py", "agents/planner.py", "agents/refine.py", "envs/core.py",
        "envs/base.py", "envs/prediction.py", "envs/triplanar_shear_v1.py", "triplanar/kernel.py",
        "triplanar/stepping.py", "triplanar/driver.py", "triplanar/equilibrium.py", "triplanar/statics.py",
        "triplanar/specimen.py", "triplanar/model.py", "triplanar/effects.py", "triplanar/outcome.py",
        "triplanar/simulate.py")
SHARD_KEYS = ("obs", "final_obs", "expert_action", "action", "expert_ran", "reward", "distance_mm", "travel_m",
              "expert_estimate", "expert_planned", "truth", "started", "success", "steps")


class SettingsMismatch(ValueError):
    """A resume whose settings differ from the folder's ``settings.json``."""


@dataclass(frozen=True)
class LabelSettings:
    """What decides a folder's labels (stored in ``settings.json``): the stream of benches, the round and its driver
    (``"expert"``: ``mpc`` itself), DAgger's mixture ``beta``, the expert's settings that differ from
    ``MPCController``'s defaults and :data:`EXPERT_PINNED` and the env's keyword arguments (sorted ``(name, value)``
    pairs: hashable and picklable, the executor's tasks carry them)."""

    stream: int = TUNING_SEED
    round: int = 0
    driver: str = "expert"
    beta: float = 0.0
    expert: tuple = ()
    env_kwargs: tuple = ()
    teacher: str = "mpc"     # or "limit": the privileged teacher, which knows the bench (TEACHERS)
    plain_twin: bool = False  # limit only: also store a plain limit's action in the same states (plain_action)

    def __post_init__(self) -> None:
        if self.stream in REFUSED_STREAMS:
            raise ValueError(f"stream {self.stream} is {REFUSED_STREAMS[self.stream]}: labels never come from it "
                             f"(use the tuning stream {TUNING_SEED} or another unused one)")
        if not 0.0 <= self.beta <= 1.0:
            raise ValueError(f"beta must be within 0-1, got {self.beta!r}")
        if self.round < 0:
            raise ValueError(f"round must be >= 0, got {self.round!r}")
        if (self.driver == "expert") != (self.round == 0):
            raise ValueError(f"round {self.round} with driver {self.driver!r}: round 0 is driven by the expert "
                             "and a later round by a student (--driver)")
        if self.driver != "expert":
            try:
                parse_controller(self.driver)   # recorded as given: its canonical string (agents.controller_specs)
            except ControllerSpecError as error:
                raise ValueError(f"driver: {error}") from None
        if self.teacher not in TEACHERS:
            raise ValueError(f"teacher must be one of {sorted(TEACHERS)}, got {self.teacher!r}")
        if self.plain_twin and self.teacher != "limit":
            raise ValueError(f"plain_twin needs teacher 'limit' (a twin that reads the true state), got {self.teacher!r}")
        kind = TEACHERS[self.teacher]
        unknown = [k for k, _ in self.expert if k not in kind.__dataclass_fields__ or k in NOT_SETTINGS]
        if unknown:
            raise ValueError(f"expert settings {unknown} are not {kind.__name__} settings")
        bench = [k for k, _ in self.env_kwargs if k in BENCH_FIELDS and k != "randomize"]
        if bench or any(k == "randomize" for k, _ in self.env_kwargs):
            raise ValueError(f"env_kwargs {bench or ['randomize']}: labels run v1's default bench, whose hardware "
                             "mpc knows (its fields), and the stream gives the specimen")


def plain_twin(settings: LabelSettings, env: Any, load_N: float) -> Any:
    """The round's plain twin (None without ``plain_twin``): ``limit`` as shipped, bound to ``env`` and reset, shown
    the states the round visits; its action is the shard's ``plain_action``, the control of a teacher variant."""
    if not settings.plain_twin:
        return None
    twin = TEACHERS[settings.teacher](**EXPERT_PINNED[settings.teacher])
    twin.bind(env)
    twin.reset(load_N, env.config)
    return twin


def make_expert(settings: LabelSettings) -> Any:
    """The expert of ``settings`` (tests replace this with a faster one where the point is the bookkeeping)."""
    return TEACHERS[settings.teacher](**expert_kwargs(settings))


def expert_kwargs(settings: LabelSettings) -> dict[str, Any]:
    """The expert's settings that are not its class's defaults: :data:`EXPERT_PINNED`, then ``settings.expert``."""
    return {**EXPERT_PINNED[settings.teacher], **dict(settings.expert)}


def expert_settings(settings: LabelSettings) -> dict[str, Any]:
    """Every setting of the expert (defaults included: a changed default is a changed expert), JSON-ready."""
    kind = TEACHERS[settings.teacher]
    expert = kind(**expert_kwargs(settings))
    state = NOT_SETTINGS + (LIMIT_STATE if settings.teacher == "limit" else ())
    out = {f.name: getattr(expert, f.name) for f in fields(kind) if f.name not in state and not f.name.startswith("_")}
    return {k: str(v) if isinstance(v, Path) else v for k, v in out.items()}


def source_hash(path: Path) -> str:
    """A hash of a module's code without its docstrings and comments (a reworded docstring is the same code)."""
    tree = ast.parse(path.read_text())
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if isinstance(body, list) and body and isinstance(body[0], ast.Expr) \
                and isinstance(body[0].value, ast.Constant) and isinstance(body[0].value.value, str):
            node.body = body[1:] or [ast.Pass()]
    return hashlib.sha256(ast.dump(tree, include_attributes=False).encode()).hexdigest()[:16]


def code_version() -> dict[str, str]:
    root = Path(__file__).resolve().parent.parent
    import numba
    return {**{name: source_hash(root / name) for name in CODE}, "numpy": np.__version__, "numba": numba.__version__}


def teacher_code(teacher: str) -> dict[str, str]:
    """The teacher's own source where it is not ``mpc``'s (whose sources :data:`CODE` lists)."""
    root = Path(__file__).resolve().parent.parent
    return {"agents/limit.py": source_hash(root / "agents/limit.py")} if teacher == "limit" else {}


def settings_record(settings: LabelSettings) -> dict[str, Any]:
    """``settings.json``'s content."""
    return {"format": FORMAT, "stream": settings.stream, "round": settings.round, "driver": settings.driver,
            "beta": settings.beta, "env_kwargs": dict(settings.env_kwargs), "expert": expert_settings(settings),
            "code_version": {**code_version(), **teacher_code(settings.teacher)},
            # the teacher only where it is not mpc: the folders written before the field resume as they were
            **({"teacher": settings.teacher} if settings.teacher != "mpc" else {}),
            **({"plain_twin": True} if settings.plain_twin else {})}   # (likewise)


def _flat(record: dict, prefix: str = "") -> dict[str, Any]:
    out = {}
    for key, value in record.items():
        if isinstance(value, dict):
            out.update(_flat(value, f"{prefix}{key}."))
        else:
            out[f"{prefix}{key}"] = value
    return out


def check_settings(out: Path, settings: LabelSettings, accept_code_change: bool = False) -> None:
    """Write ``out/settings.json`` on a first run; on a resume, refuse (:class:`SettingsMismatch`) settings that
    differ from the stored ones, naming each field with both values. ``accept_code_change``: a difference in the
    code version alone is accepted (the caller checked that the expert's actions did not change, e.g. with
    ``benchmarks/fingerprint.py --compare`` and a shard redone) and recorded under ``accepted_code_changes``."""
    path = out / "settings.json"
    record = json.loads(json.dumps(settings_record(settings)))  # as it reads back (tuples become lists)
    if not path.exists():
        out.mkdir(parents=True, exist_ok=True)
        write_json(record, path)
        return
    stored_record = json.loads(path.read_text())
    accepted = stored_record.pop("accepted_code_changes", [])
    stored, now = _flat(stored_record), _flat(record)
    for name, value in ADDED_SETTINGS.items():
        if f"expert.{name}" in now:
            stored.setdefault(f"expert.{name}", value)
    keys = [k for k in sorted(set(stored) | set(now)) if stored.get(k, "absent") != now.get(k, "absent")]
    if keys and accept_code_change and all(k.startswith("code_version.") for k in keys):
        accepted.append({"fields": keys, "was": stored_record["code_version"], "at": time.strftime("%Y-%m-%d %H:%M:%S UTC", time.gmtime())})
        write_json({**record, "accepted_code_changes": accepted}, path)
        return
    if keys:
        differ = [f"{k} (stored {stored.get(k, 'absent')!r}, now {now.get(k, 'absent')!r})" for k in keys]
        raise SettingsMismatch(f"{out} holds labels made with other settings: {'; '.join(differ)}. Use a new --out "
                               "folder (or the stored settings) so that one folder holds one expert's labels; a "
                               "code change that leaves the expert's actions as they were: --accept-code-change")


def shard_path(out: Path, stream: int, draw: int) -> Path:
    return out / "shards" / f"{stream}_{draw:07d}.npz"


def complete(path: Path) -> bool:
    """Whether ``path`` is a whole shard (written atomically, so any file there is, unless the disk damaged it)."""
    try:
        with np.load(path, allow_pickle=False) as shard:
            return set(SHARD_KEYS) <= set(shard.files)
    except (OSError, ValueError, EOFError):
        return False


def bench_of_draw(stream: int, draw: int, env_kwargs: dict[str, Any]):
    """Draw ``draw`` of ``stream`` (``draw_bench`` from ``default_rng([stream, draw])``, as
    :func:`agents.heldout.random_benches` draws), or None if friction holds it at rest (never run). ``env_kwargs``:
    the v1 env's arguments (the bench's own, such as ``observation_mode``, do not change the specimen)."""
    shear_kwargs = {k: v for k, v in env_kwargs.items() if k not in BENCH_FIELDS}
    specimen, foundation = make_config(None, **shear_kwargs).base_specimen()
    bench = draw_bench(np.random.default_rng([stream, draw]), specimen, foundation)
    return (first_startable([bench], 1, None, env_kwargs) or [None])[0]


def driver_of(settings: LabelSettings, env_kwargs: dict[str, Any]):
    """The round's driver (None: the expert drives), refused if it needs another env than the labels'."""
    if settings.driver == "expert":
        return None
    built = parse_controller(settings.driver).build("driver", {})
    driver, own_kwargs = built.controller, built.env_kwargs
    if own_kwargs and own_kwargs != env_kwargs:
        raise ValueError(f"driver {settings.driver!r} runs with env_kwargs {own_kwargs}, the labels with "
                         f"{env_kwargs}: a student must see the expert's bench")
    return driver


ESTIMATE_NAMES = PARAMETERS + GEOMETRY


def truth_values(truth: np.ndarray, names: Sequence[str]) -> np.ndarray:
    """The entries ``names`` of a :data:`TRUTH_NAMES` row (a shard's ``truth``, :func:`bench_truth`), in that order:
    what a privileged student is given (``agents.student``'s ``given_names``)."""
    row = dict(zip(TRUTH_NAMES, truth))
    missing = [name for name in names if name not in row]
    if missing:
        raise ValueError(f"given inputs {missing} are not the bench's unknowns {list(TRUTH_NAMES)}")
    return np.array([row[name] for name in names], dtype=np.float32)


def rollout(settings: LabelSettings, bench, draw: int) -> dict[str, Any]:
    """One episode of the round on ``bench``: the arrays of its shard (module docstring)."""
    env_kwargs = dict(settings.env_kwargs)
    env = TriPlanarShearV1Env(**env_kwargs)
    seed = noise_seed(draw, settings.round)
    obs, info = env.reset(seed=seed, options={"bench": bench})
    expert, driver = make_expert(settings), driver_of(settings, env_kwargs)
    if getattr(expert, "needs_env", False):  # limit reads the bench's true state
        expert.bind(env)
    expert.reset(bench.load_N, env.config)
    if driver is not None:
        if getattr(driver, "needs_env", False):
            driver.bind(env)
        driver.reset(bench.load_N, env.config)
    twin = plain_twin(settings, env, bench.load_N)
    mix = np.random.default_rng([MIX_SEED, settings.round, draw])
    rows: dict[str, list] = {k: [] for k in ("obs", "expert_action", "action", "expert_ran", "reward", "distance_mm",
                                             "travel_m", "expert_estimate", "expert_planned", "expert_cpu_s")}
    rows.update({"plain_action": []} if twin is not None else {})
    start = time.process_time()
    while True:
        label = np.asarray(expert.act(obs), dtype=np.float32)
        if twin is not None:
            rows["plain_action"].append(np.asarray(twin.act(obs), dtype=np.float32))
        action, ran = label, True
        if driver is not None:
            own = np.asarray(driver.act(obs), dtype=np.float32)
            ran = bool(mix.random() < settings.beta)
            action = label if ran else own
            # mpc's estimator advances its hypotheses with the action it last sent: tell it what the bench ran
            expert._last = np.clip(np.asarray(action, dtype=float), -1.0, 1.0)
        said = getattr(expert, "info", {})  # (mpc's; a stand-in expert in tests may have none)
        estimate = said.get("estimate", {})
        rows["obs"].append(obs)
        rows["expert_action"].append(label)
        rows["action"].append(action)
        rows["expert_ran"].append(ran)
        rows["expert_estimate"].append([estimate.get(k, math.nan) for k in ESTIMATE_NAMES])
        rows["expert_planned"].append(bool(said.get("planned", False)))
        rows["expert_cpu_s"].append(float(said.get("cpu_s", math.nan)))
        obs, reward, terminated, truncated, info = env.step(action)
        rows["reward"].append(reward)
        rows["distance_mm"].append(info["distance_mm"])
        rows["travel_m"].append(info["travel_m"])
        if terminated or truncated:
            break
    success = bool(info["is_success"])
    return {"obs": np.array(rows["obs"], dtype=np.float32), "final_obs": np.asarray(obs, dtype=np.float32),
            "expert_action": np.array(rows["expert_action"], dtype=np.float32),
            "action": np.array(rows["action"], dtype=np.float32), "expert_ran": np.array(rows["expert_ran"]),
            "reward": np.array(rows["reward"]), "distance_mm": np.array(rows["distance_mm"]),
            "travel_m": np.array(rows["travel_m"]), "expert_estimate": np.array(rows["expert_estimate"]),
            "expert_planned": np.array(rows["expert_planned"]), "expert_cpu_s": np.array(rows["expert_cpu_s"]),
            "episode_cpu_s": np.float64(time.process_time() - start), "noise_seed": np.int64(seed),
            "started": np.bool_(True), "success": np.bool_(success), "reason": np.str_(info["reason"]),
            "mimicry_error_mm": np.float64(info["mimicry_error_mm"] if success else math.nan),
            "steps": np.int64(len(rows["obs"])),
            **({"plain_action": np.array(rows["plain_action"], dtype=np.float32)} if twin is not None else {})}


def not_started() -> dict[str, Any]:
    """The shard of a draw that friction holds at rest: nothing ran (kept, so that a resume skips it)."""
    empty = np.zeros((0, 2), dtype=np.float32)
    return {"obs": np.zeros((0, BENCH_OBSERVATION.size), dtype=np.float32), "final_obs": np.zeros(0, dtype=np.float32),
            "expert_action": empty, "action": empty, "expert_ran": np.zeros(0, dtype=bool), "reward": np.zeros(0),
            "distance_mm": np.zeros(0), "travel_m": np.zeros(0), "expert_estimate": np.zeros((0, len(ESTIMATE_NAMES))),
            "expert_planned": np.zeros(0, dtype=bool), "expert_cpu_s": np.zeros(0), "episode_cpu_s": np.float64(0.0),
            "noise_seed": np.int64(-1), "started": np.bool_(False), "success": np.bool_(False),
            "reason": np.str_("not_started"), "mimicry_error_mm": np.float64(math.nan), "steps": np.int64(0)}


def label_episode(task: tuple[LabelSettings, str, int]) -> dict[str, Any]:
    """The executor's task: draw ``draw`` of the round, rolled out and written as one shard; returns its summary."""
    settings, out, draw = task
    bench = bench_of_draw(settings.stream, draw, dict(settings.env_kwargs))
    arrays = not_started() if bench is None else rollout(settings, bench, draw)
    truth = np.full(len(TRUTH_NAMES), math.nan) if bench is None else bench_truth(bench)
    arrays.update(truth=truth, truth_names=np.array(TRUTH_NAMES), estimate_names=np.array(ESTIMATE_NAMES),
                  obs_names=np.array(obs_names()), stream=np.int64(settings.stream), draw=np.int64(draw),
                  round=np.int64(settings.round))
    path = shard_path(Path(out), settings.stream, draw)

    def write(tmp: Path) -> None:
        with open(tmp, "wb") as f:
            np.savez_compressed(f, **arrays)
    write_atomic(path, write)
    return {"draw": draw, "started": bool(arrays["started"]), "success": bool(arrays["success"]),
            "steps": int(arrays["steps"]), "cpu_s": float(arrays["episode_cpu_s"])}


def obs_names() -> list[str]:
    """The bench observation's 15 entries, named after ``BENCH_OBSERVATION``'s fields (``RANGE0`` ... ``PREV1``)."""
    names = []
    for f in BENCH_OBSERVATION.fields.values():
        names += [f.name] if f.size == 1 else [f"{f.name}{i}" for i in range(f.size)]
    return names


def generate(out: str | Path, settings: LabelSettings, first: int, n: int, executor: Any = "serial",
             progress: bool = False, accept_code_change: bool = False) -> list[dict[str, Any]]:
    """The shards of draws ``first`` .. ``first + n - 1`` in ``out`` (module docstring): the settings checked or
    stored, complete shards skipped, the rest run through ``executor``; returns the summaries of the episodes run."""
    if first < 0 or n < 1:
        raise ValueError(f"first must be >= 0 and n >= 1, got first {first!r}, n {n!r}")
    out = Path(out)
    check_settings(out, settings, accept_code_change)
    shards = out / "shards"
    shards.mkdir(parents=True, exist_ok=True)
    for entry in os.listdir(shards):  # what a hard kill left: ``.<stem>.<pid>.<token>.partial.npz``
        if entry.startswith(".") and entry.endswith(".partial.npz"):
            remove_stale_temporaries(shards / (entry[1:].rsplit(".", 4)[0] + ".npz"))
    present = set(os.listdir(shards))  # (listed once: a run may span 100,000 draws)
    todo = [draw for draw in range(first, first + n) if shard_path(out, settings.stream, draw).name not in present
            or not complete(shard_path(out, settings.stream, draw))]
    return run_tasks(label_episode, [(settings, str(out), draw) for draw in todo], executor, progress=progress,
                     desc=f"labels round {settings.round}")


def status(out: str | Path) -> dict[str, Any]:
    """What a folder holds: shards, episodes run and succeeded, decisions, CPU hours, and the CPU per episode."""
    shards = sorted((Path(out) / "shards").glob("*.npz"))
    started = success = decisions = 0
    cpu = []
    for path in shards:
        with np.load(path, allow_pickle=False) as s:
            if bool(s["started"]):
                started += 1
                success += bool(s["success"])
                decisions += int(s["steps"])
                cpu.append(float(s["episode_cpu_s"]))
    return {"shards": len(shards), "episodes": started, "successes": success, "decisions": decisions,
            "cpu_hours": sum(cpu) / 3600.0, "cpu_s_per_episode": float(np.mean(cpu)) if cpu else math.nan,
            "cpu_s_per_episode_p90": float(np.percentile(cpu, 90)) if cpu else math.nan}


def frame_stacked(obs: np.ndarray, frames: int) -> np.ndarray:
    """(T, frames * 15): at each decision the last ``frames`` observations, oldest first, the episode's first
    observation repeated before it (what :class:`agents.robust_policy.RobustPolicy` feeds its network)."""
    padded = np.concatenate([np.repeat(obs[:1], frames - 1, axis=0), obs])
    return np.concatenate([padded[k:k + len(obs)] for k in range(frames)], axis=1)


def label_shards(folders: list[str | Path]) -> list[Path]:
    """The shard files of ``folders`` in the order :func:`load_labels` reads them (folder by folder, by name)."""
    return [path for folder in folders for path in sorted((Path(folder) / "shards").glob("*.npz"))]


def load_labels(folders: list[str | Path], frames: int = 4, shards: list[str | Path] | None = None,
                label: str = "expert_action") -> dict[str, np.ndarray]:
    """Every started episode's decisions in ``folders`` (DAgger's aggregate of rounds) as one training set: ``x``
    (frame-stacked observations, :func:`frame_stacked`), ``y`` (``mpc``'s actions), ``truth`` (each decision's
    bench's privileged row), ``episode`` (an index per shard, for splitting by episode), ``step`` and ``draw``.
    ``shards``: exactly these shard files instead (a training run that must read the same set again while a label
    run adds to the folders). ``label``: the shard array read as ``y`` (``plain_action``: the plain twin's)."""
    parts: dict[str, list] = {k: [] for k in ("x", "y", "truth", "episode", "step", "draw")}
    episode = 0
    for path in label_shards(folders) if shards is None else [Path(p) for p in shards]:
        with np.load(path, allow_pickle=False) as s:
            if not bool(s["started"]):
                continue
            steps = int(s["steps"])
            parts["x"].append(frame_stacked(s["obs"], frames))
            if label not in s.files:
                raise ValueError(f"{path} has no {label!r} (a folder made without --plain-twin?)")
            parts["y"].append(s[label])
            parts["truth"].append(np.repeat(s["truth"][None, :], steps, axis=0))
            parts["episode"].append(np.full(steps, episode))
            parts["step"].append(np.arange(steps))
            parts["draw"].append(np.full(steps, int(s["draw"]) if "draw" in s.files else -1))
            episode += 1
    if not episode:
        raise ValueError(f"no started episode in {[str(f) for f in folders]}")
    return {k: np.concatenate(v) for k, v in parts.items()}


def expert_pairs(pairs: list[str], teacher: str = "mpc") -> tuple:
    """``--expert FIELD=VALUE`` pairs (values as JSON: numbers, true/false, "strings") as sorted settings."""
    out = {}
    kind = TEACHERS[teacher]
    for pair in pairs:
        name, sep, value = pair.partition("=")
        if not sep or name not in kind.__dataclass_fields__ or name in NOT_SETTINGS:
            raise SystemExit(f"--expert {pair!r}: expected FIELD=VALUE with FIELD one of {kind.__name__}'s settings")
        try:
            out[name] = json.loads(value)
        except json.JSONDecodeError:
            raise SystemExit(f"--expert {pair!r}: VALUE must be JSON (a number, true/false or a \"string\")") from None
    return tuple(sorted(out.items()))


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    from triplanar.commands.options import add_executor_arguments
    parser = argparse.ArgumentParser(prog="python -m experiments.distill_labels", description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", required=True, help="the round's folder (settings.json and shards/); rerun to resume")
    parser.add_argument("--first", type=int, default=1000, help="the first draw of the stream (default 1000: the "
                        "draws before it stay for judging the student on benches it was not trained on)")
    parser.add_argument("--n", type=int, default=1000, help="how many draws from --first (default 1000)")
    parser.add_argument("--stream", type=int, default=TUNING_SEED, help=f"the bench stream (default {TUNING_SEED}, "
                        "the tuning stream; the held-out and stress streams are refused)")
    parser.add_argument("--round", type=int, default=0, help="DAgger round (0: the expert drives)")
    parser.add_argument("--driver", default="expert", help="round >= 1: the controller that drives (ppo:RUN, "
                        "ppo_recurrent:RUN, shipped:NAME, student:FOLDER or a bench controller); mpc labels the states it visits")
    parser.add_argument("--beta", type=float, default=0.0, help="round >= 1: the fraction of periods in which the "
                        "expert's own action runs (DAgger's mixture; default 0)")
    parser.add_argument("--expert", action="append", default=[], metavar="FIELD=VALUE",
                        help="an MPCController setting of the expert (repeatable; default: mpc as shipped)")
    parser.add_argument("--teacher", default="mpc", choices=sorted(TEACHERS), help="the expert whose actions "
                        "label (default mpc; limit: the privileged teacher that knows the bench, about 3 CPU s per "
                        "episode against mpc's 20-30; --expert then sets limit's fields)")
    parser.add_argument("--plain-twin", action="store_true", help="--teacher limit: also store the action of a "
                        "plain limit (as shipped) in the same states, plain_action: the control for a teacher "
                        "variant set with --expert (twice the CPU)")
    parser.add_argument("--workers", type=int, default=1, help="processes (default 1; a local pool for more)")
    parser.add_argument("--accept-code-change", action="store_true", help="resume although the code version of "
                        "the expert or the env differs (only that: checked to leave the expert's actions unchanged)")
    parser.add_argument("--status", action="store_true", help="print what --out holds and stop")
    add_executor_arguments(parser)
    return parser.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    if args.status:
        print(json.dumps(status(args.out), indent=1))
        return 0
    from triplanar.commands.options import executor_from_args
    try:
        settings = LabelSettings(stream=args.stream, round=args.round, driver=args.driver, beta=args.beta,
                                 expert=expert_pairs(args.expert, args.teacher), teacher=args.teacher,
                                 plain_twin=args.plain_twin)
        start = time.time()
        with executor_from_args(args, args.workers) as executor:
            done = generate(args.out, settings, args.first, args.n, executor, progress=True,
                            accept_code_change=args.accept_code_change)
    except ValueError as error:  # bad settings, or a resume with other settings: named, nothing run
        print(f"error: {error}", file=sys.stderr)
        return 2
    print(f"{len(done)} episodes run in {time.time() - start:.0f} s; the folder: {json.dumps(status(args.out))}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

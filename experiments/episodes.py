"""Episode batches of the bench study and of ``triplanar evaluate``: one controller, one seed, a list of benches
under one bench configuration; pure and picklable, the tasks of :func:`triplanar.workbench.executor.run_tasks`.

A batch's ``seed`` is the row's seed: for a learned controller the training seed (which run is loaded), for a
scripted one a sensor-noise replicate. Episode ``i`` seeds the sensor noise with :func:`noise_seed` (``i`` for
seed 0 and for every learned controller, as the held-out tables always did).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from agents.bench_controllers import make_controller
from agents.controller_base import Controller
from agents.heldout import TUNING_SEED, Outcome, bench_set, random_benches, run_episode

NOISE_SEED = 40_040


def noise_seed(index: int, replicate: int) -> int:
    """The sensor-noise seed of episode ``index`` of a scripted controller's replicate ``replicate``."""
    if replicate == 0:
        return index
    return int(np.random.SeedSequence([NOISE_SEED, replicate, index]).generate_state(1)[0])


@dataclass(frozen=True)
class EpisodeBatch:
    """One controller on a list of benches under one bench configuration."""

    label: str                       # the name written to the tables
    controller: str                  # agents.bench_controllers name, "ppo:<run_dir>" (frame stack),
    #                                  "ppo_recurrent:<run_dir>" (LSTM), "ppo_state:<run_dir>" (v0, exact state) or
    #                                  "shipped:<name>" (agents.zoo; ``zoo_dir`` names the zoo) or
    #                                  "student:<folder>" (agents.student, experiments.train_student)
    params: tuple = ()
    bench_set: str = "heldout"       # heldout, stress, nominal or tuning
    n: int = 50
    tip_friction_deg: float | None = None
    env_kwargs: tuple = ()
    seed: int = 0
    zoo_dir: str | None = None


def benches_of(batch: EpisodeBatch) -> list[Any]:
    """The batch's benches, with its design's tip where it has one."""
    if batch.bench_set == "tuning":
        return random_benches(batch.n, TUNING_SEED, tip_friction_deg=batch.tip_friction_deg)
    return bench_set(batch.bench_set, batch.n, batch.tip_friction_deg)


class _Named(Controller):
    """A policy's ``act`` under the batch's label."""

    def __init__(self, name: str, policy_act: Any):
        self.name, self.policy_act = name, policy_act

    def act(self, obs: np.ndarray) -> np.ndarray:
        return self.policy_act(obs)


def controller_of(batch: EpisodeBatch) -> tuple[Any, dict[str, Any], bool]:
    """(controller, env kwargs, learned) of a batch."""
    env_kwargs = dict(batch.env_kwargs)
    kind, _, rest = batch.controller.partition(":")
    if kind in ("ppo", "ppo_recurrent"):
        from agents.train_robust import load_policy
        return load_policy(rest, "ppo" if kind == "ppo" else "recurrent", name=batch.label), env_kwargs, True
    if kind == "ppo_state":
        from agents.ppo_controller import PPOController
        run = Path(rest)
        ppo = PPOController.load(run / "final_model.zip", run / "vecnormalize.pkl", name=batch.label)
        return _Named(batch.label, ppo.act), {**env_kwargs, "observation_mode": "state"}, True
    if kind == "student":
        from agents.student import StudentController
        student = StudentController.load(rest, name=batch.label)
        return student, {**student.env_kwargs, **env_kwargs}, True
    if kind == "shipped":
        from agents.zoo import bench_arguments, check_bench, check_layout, load_shipped, read_card
        zoo = Path(batch.zoo_dir) if batch.zoo_dir else None
        card = read_card(rest, zoo)
        env_kwargs = {**card["env_kwargs"], **env_kwargs}
        env_kwargs.pop("randomize", None)   # the bench set gives the specimen
        check_layout(card, env_kwargs)
        tip = {} if batch.tip_friction_deg is None else {"tip_friction_deg": batch.tip_friction_deg}
        check_bench(card, bench_arguments({**env_kwargs, **tip}), "the batch's bench")
        policy = load_shipped(rest, batch.seed, zoo)
        policy.name = batch.label
        return policy, env_kwargs, True
    controller = make_controller(batch.controller, **dict(batch.params))
    controller.name = batch.label
    return controller, env_kwargs, False


def run_batch(batch: EpisodeBatch) -> list[Outcome]:
    controller, env_kwargs, learned = controller_of(batch)
    return [run_episode(controller, b, env_kwargs=env_kwargs, seed=i if learned else noise_seed(i, batch.seed),
                        bench_set=batch.bench_set, index=i) for i, b in enumerate(benches_of(batch))]


def outcome_table(batches: list[EpisodeBatch], results: list[list[Outcome]]) -> tuple[np.ndarray, np.ndarray]:
    """``(errors, success)``, each (seeds, benches), of one row's batches (one batch per seed, the same benches)."""
    lengths = {len(r) for r in results}
    if len(lengths) != 1:
        raise ValueError(f"a row's batches must run the same benches, got {sorted(lengths)} episodes")
    errors = np.array([[o.mimicry_error_mm for o in r] for r in results], dtype=float)
    success = np.array([[o.success for o in r] for r in results], dtype=bool)
    return errors, success

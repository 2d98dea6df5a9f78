"""Episode batches of the bench study and of ``triplanar evaluate``: one controller, one seed, a list of benches
under one bench configuration; pure and picklable, the tasks of :func:`triplanar.workbench.executor.run_tasks`.

A batch's ``seed`` is the row's seed: for a learned controller the training seed (which run is loaded), for a
scripted one a sensor-noise replicate. Episode ``i`` seeds the sensor noise with :func:`noise_seed` (``i`` for
seed 0 and for every learned controller, as the held-out tables always did).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from agents.controller_specs import ControllerSpec, ScriptedSpec, ShippedSpec, parse_controller
from agents.information_bound import InformationBound
from agents.heldout import TUNING_SEED, Outcome, bench_set, random_benches, run_episode

NOISE_SEED = 40_040


def noise_seed(index: int, replicate: int) -> int:
    """The sensor-noise seed of episode ``index`` of a scripted controller's replicate ``replicate``."""
    if replicate == 0:
        return index
    return int(np.random.SeedSequence([NOISE_SEED, replicate, index]).generate_state(1)[0])


@dataclass(frozen=True)
class EpisodeBatch:
    """One controller on a list of benches under one bench configuration. Build it from a spec with
    :meth:`of`; its fields are the spec's canonical string and numbers (:mod:`agents.controller_specs`), so that
    a batch pickles as it always did and the bench study's task checkpoints keep their keys."""

    label: str                       # the name written to the tables
    controller: str                  # the spec's canonical string (agents.controller_specs): a bench controller
    #                                  name, "ppo:<run_dir>", "ppo_recurrent:<run_dir>", "ppo_state:<run_dir>",
    #                                  "shipped:<name>" or "student:<folder>"
    params: tuple = ()               # a scripted controller's numbers
    bench_set: str = "heldout"       # heldout, stress, nominal or tuning
    n: int = 50
    tip_friction_deg: float | None = None
    env_kwargs: tuple = ()
    seed: int = 0                    # the row's seed; a shipped agent's training seed
    zoo_dir: str | None = None       # a shipped agent's zoo

    @classmethod
    def of(cls, spec: ControllerSpec, label: str, bench_set: str = "heldout", n: int = 50,
           tip_friction_deg: float | None = None, env_kwargs: tuple = (), seed: int = 0) -> EpisodeBatch:
        """The batch of ``spec`` (a shipped agent's ``seed`` is its spec's)."""
        if isinstance(spec, ShippedSpec):
            return cls(label, spec.text, (), bench_set, n, tip_friction_deg, env_kwargs, spec.seed, spec.zoo_dir)
        params = spec.params if isinstance(spec, ScriptedSpec) else ()
        return cls(label, spec.text, params, bench_set, n, tip_friction_deg, env_kwargs, seed)

    @property
    def spec(self) -> ControllerSpec:
        return parse_controller(self.controller, params=self.params, seed=self.seed, zoo_dir=self.zoo_dir)


def benches_of(batch: EpisodeBatch) -> list[Any]:
    """The batch's benches, with its design's tip where it has one."""
    if batch.bench_set == "tuning":
        return random_benches(batch.n, TUNING_SEED, tip_friction_deg=batch.tip_friction_deg)
    return bench_set(batch.bench_set, batch.n, batch.tip_friction_deg)


def controller_of(batch: EpisodeBatch) -> tuple[Any, dict[str, Any], bool]:
    """(controller, env kwargs, learned) of a batch."""
    built = batch.spec.build(batch.label, dict(batch.env_kwargs), batch.tip_friction_deg)
    return built.controller, built.env_kwargs, built.learned


@dataclass(frozen=True)
class BatchPart:
    """Episodes ``start`` to ``stop - 1`` of ``batch`` (numbered as in the whole batch, so their sensor noise is the
    whole batch's): a model-based batch costs seconds of planning per episode, and the bench study checkpoints it
    part by part so that an interrupted run loses at most one part."""

    batch: EpisodeBatch
    start: int
    stop: int


def parts_of(batch: EpisodeBatch, size: int) -> list[BatchPart]:
    """``batch`` as consecutive parts of ``size`` benches (the last one shorter)."""
    count = len(benches_of(batch))
    return [BatchPart(batch, start, min(start + size, count)) for start in range(0, count, size)]


def run_part(part: BatchPart) -> list[Outcome]:
    """The part's episodes; ``information_bound``'s outcome carries the bound, not its episode's error."""
    batch = part.batch
    controller, env_kwargs, learned = controller_of(batch)
    out = []
    for i, b in enumerate(benches_of(batch)[part.start:part.stop], start=part.start):
        played = run_episode(controller, b, env_kwargs=env_kwargs, seed=i if learned else noise_seed(i, batch.seed),
                             bench_set=batch.bench_set, index=i)
        if isinstance(controller, InformationBound):   # (the tip the design knows is not an unknown)
            played = controller.outcome(played, b, env_kwargs, batch.tip_friction_deg)
        out.append(played)
    return out


def run_batch(batch: EpisodeBatch) -> list[Outcome]:
    """The batch's episodes (:func:`run_part` of all of them)."""
    return run_part(BatchPart(batch, 0, len(benches_of(batch))))


def outcome_table(batches: list[EpisodeBatch], results: list[list[Outcome]]) -> tuple[np.ndarray, np.ndarray]:
    """``(errors, success)``, each (seeds, benches), of one row's batches (one batch per seed, the same benches)."""
    lengths = {len(r) for r in results}
    if len(lengths) != 1:
        raise ValueError(f"a row's batches must run the same benches, got {sorted(lengths)} episodes")
    errors = np.array([[o.mimicry_error_mm for o in r] for r in results], dtype=float)
    success = np.array([[o.success for o in r] for r in results], dtype=bool)
    return errors, success

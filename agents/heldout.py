"""Held-out evaluation on ``TriPlanarShear-v1``: a fixed, seeded set of unknown specimens that no training or
tuning uses, plus the nominal bench; failures are counted, never averaged into a mimicry error.

* :func:`heldout_benches`: bench ``i`` is drawn from ``np.random.default_rng([HELDOUT_SEED, i])`` (training draws
  from the env's own seeded generator, tuning from ``TUNING_SEED``: different streams);
* :func:`stress_benches`: benches outside the training ranges (:data:`STRESS_RANGES`), drawn from their own
  stream ``STRESS_SEED``; every stress bench has at least one parameter outside v1's randomisation ranges;
* :func:`bench_set`: any of the sets above by name (:data:`BENCH_SETS`), optionally with a design's known tip
  (a bench that tip cannot start is skipped too: :func:`first_startable`);
* :func:`run_episode`: one controller on one bench -> :class:`Outcome` (``success``, ``mimicry_error_mm`` only when
  successful, else NaN);
* :func:`summarise`: success rate, mimicry error over successful episodes, and the score (below).

**Score** (mm, lower is better): the mean over all episodes of the mimicry error, a failed episode counting
``FAILURE_SCORE_MM`` (10 mm, ten times the 1 mm target): a controller that fails 1 test in 20 cannot score under
0.5 mm however well it mimics in the others.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, replace
from typing import Any, Callable, Iterable, Sequence

import numpy as np

from envs.core import make_config
from envs.triplanar_shear_v1 import (BENCH_FIELDS, TRAINING_RANGES, Bench, TriPlanarShearV1Env, can_start,
                                     draw_bench)
from triplanar import PAPER_LOADS_N

from .controller_base import Controller, play
from triplanar.specimen import Foundation, Specimen

HELDOUT_SEED = 10_010
TUNING_SEED = 20_020
STRESS_SEED = 30_030
FAILURE_SCORE_MM = 10.0
BENCH_SETS = ("heldout", "stress", "nominal")

# The stress set's ranges: wider than v1's training ranges (envs.triplanar_shear_v1.TRAINING_RANGES) in the tip
# friction, the load and the plane tilts (a worn tip, loads beyond the paper's, a foundation levelled less well);
# contact friction, mass and mass centre vary as in training.
STRESS_RANGES = replace(TRAINING_RANGES, tip_friction_deg=(2.0, 15.0), load_N=(25.0, 60.0), tilt_deg=1.0)


def _shear_kwargs(env_kwargs: dict[str, Any] | None) -> dict[str, Any]:
    """The ``ShearConfig`` part of v1's keyword arguments (the bench's own are not needed to draw specimens)."""
    return {k: v for k, v in (env_kwargs or {}).items() if k not in BENCH_FIELDS}


def _startable(bench: Bench, env_kwargs: dict[str, Any]) -> bool:
    return can_start(make_config(None, **_shear_kwargs(env_kwargs)), bench)


def random_benches(n: int, seed: int, env_kwargs: dict[str, Any] | None = None,
                   tip_friction_deg: float | None = None) -> list[Bench]:
    """The first ``n`` startable draws of the stream ``seed`` (a draw that friction holds at rest is skipped, as a
    laboratory would not run it), with the tip ``tip_friction_deg`` where given (:func:`first_startable`)."""
    config = make_config(None, **_shear_kwargs(env_kwargs))
    specimen, foundation = config.base_specimen()
    draws = (draw_bench(np.random.default_rng([seed, i]), specimen, foundation) for i in itertools.count())
    return first_startable(draws, n, tip_friction_deg, env_kwargs)


def first_startable(draws: Iterable[Bench], n: int, tip_friction_deg: float | None = None,
                    env_kwargs: dict[str, Any] | None = None) -> list[Bench]:
    """The first ``n`` of ``draws`` that start as drawn and, with a design's known tip ``tip_friction_deg``, also
    with that tip; returned with the tip. Both conditions, not the second alone, so that every design runs a subset
    of one stream of specimens (designs compare on common benches) and a set without a tip is unchanged."""
    out: list[Bench] = []
    for bench in draws:
        if len(out) == n:
            break
        if not _startable(bench, env_kwargs or {}):
            continue
        tipped = with_tip(bench, tip_friction_deg)
        if tip_friction_deg is None or _startable(tipped, env_kwargs or {}):
            out.append(tipped)
    return out


def heldout_benches(n: int = 50, tip_friction_deg: float | None = None) -> list[Bench]:
    return random_benches(n, HELDOUT_SEED, tip_friction_deg=tip_friction_deg)


def draw_stress_bench(rng: np.random.Generator, specimen: Specimen, foundation: Foundation) -> Bench:
    """An unknown specimen from :data:`STRESS_RANGES` (:func:`envs.triplanar_shear_v1.draw_bench` with them)."""
    return draw_bench(rng, specimen, foundation, STRESS_RANGES, "stress")


def outside_training_ranges(bench: Bench, foundation: Foundation) -> list[str]:
    """The parameters of ``bench`` outside v1's randomisation ranges around the nominal ``foundation``."""
    out, r = [], TRAINING_RANGES
    low, high = r.tip_friction_deg
    if not low <= bench.specimen.tip_friction_deg <= high:
        out.append("tip_friction_deg")
    low, high = r.load_N
    if not low <= bench.load_N <= high:
        out.append("load_N")
    for nominal, plane in zip(foundation.planes, bench.foundation.planes):
        reference = 0.0 if nominal.dip_deg < r.tilt_deg else nominal.dip_deg
        if abs(plane.dip_deg - reference) > r.tilt_deg:
            out.append("plane_tilt")
            break
    return out


def stress_benches(n: int = 50, tip_friction_deg: float | None = None) -> list[Bench]:
    """The first ``n`` startable draws of :func:`draw_stress_bench` from the stream ``STRESS_SEED`` that lie
    outside the training ranges in at least one parameter (a draw inside all of them is skipped), with the tip
    ``tip_friction_deg`` where given (:func:`first_startable`)."""
    specimen, foundation = make_config(None).base_specimen()
    draws = (draw_stress_bench(np.random.default_rng([STRESS_SEED, i]), specimen, foundation)
             for i in itertools.count())
    return first_startable((b for b in draws if outside_training_ranges(b, foundation)), n, tip_friction_deg)


def bench_set(name: str, n: int, tip_friction_deg: float | None = None) -> list[Bench]:
    """The bench set ``name`` (:data:`BENCH_SETS`): ``n`` held-out or stress benches, or the nominal bench at the
    paper's loads (``n`` is then ignored: there are 12); with a design's known tip ``tip_friction_deg`` where given."""
    if name == "heldout":
        return heldout_benches(n, tip_friction_deg)
    if name == "stress":
        return stress_benches(n, tip_friction_deg)
    if name == "nominal":
        return [with_tip(b, tip_friction_deg) for b in nominal_benches()]
    raise ValueError(f"unknown bench set {name!r}; choose from {list(BENCH_SETS)}")


def nominal_benches(loads: Sequence[float] = PAPER_LOADS_N) -> list[Bench]:
    """The nominal specimen (steel tip, 8 deg) at the paper's load levels."""
    specimen, foundation = make_config(None).base_specimen()
    return [Bench(specimen, foundation, float(f)) for f in loads]


def with_tip(bench: Bench, tip_friction_deg: float | None) -> Bench:
    """``bench`` with a given tip (a design's hardware) instead of its drawn tip friction."""
    if tip_friction_deg is None:
        return bench
    return replace(bench, specimen=replace(bench.specimen, tip_friction_deg=float(tip_friction_deg)))


@dataclass(frozen=True)
class Outcome:
    controller: str
    bench_set: str
    index: int
    load_N: float
    success: bool
    reason: str
    mimicry_error_mm: float   # NaN unless success
    travel_m: float
    episode_return: float
    steps: int


def run_episode(controller: Any, bench: Bench, *, env_kwargs: dict[str, Any] | None = None, seed: int = 0,
                bench_set: str = "heldout", index: int = 0, policy: Any = None,
                on_step: Callable[[dict], None] | None = None) -> Outcome:
    """One episode of ``controller`` (a :class:`agents.controller_base.Controller`, or ``policy(obs) -> action``
    with ``controller`` its name) on ``bench`` through the one episode loop (:func:`agents.controller_base.play`);
    ``seed`` seeds the sensor noise; ``on_step`` is called with every step's ``info``."""
    env = TriPlanarShearV1Env(**(env_kwargs or {}))
    obs, info = env.reset(seed=seed, options={"bench": bench})
    name = controller if isinstance(controller, str) else controller.name
    if policy is not None:   # a bare policy: nothing to reset
        controller = _Policy(name, policy)
    total, steps, info = play(controller, env, obs, bench.load_N, prepared=policy is not None,
                              on_step=None if on_step is None else lambda action, step_info: on_step(step_info))
    success = bool(info["is_success"])
    return Outcome(name, bench_set, index, bench.load_N, success, info["reason"],
                   float(info["mimicry_error_mm"]) if success else math.nan, float(info["travel_m"]), total, steps)


class _Policy(Controller):
    """``policy(obs) -> action`` as a controller."""

    def __init__(self, name: str, policy: Callable[[np.ndarray], np.ndarray]):
        self.name, self.policy = name, policy

    def act(self, obs: np.ndarray) -> np.ndarray:
        return self.policy(obs)


def summarise(outcomes: Sequence[Outcome]) -> dict[str, float]:
    """``n_episodes``, ``success_rate``, ``mimicry_error_mm`` (mean over successful episodes; NaN if none) and
    ``score`` (failures count ``FAILURE_SCORE_MM``)."""
    n = len(outcomes)
    ok = [o.mimicry_error_mm for o in outcomes if o.success]
    score = (sum(ok) + FAILURE_SCORE_MM * (n - len(ok))) / n if n else math.nan
    return {"n_episodes": n, "success_rate": len(ok) / n if n else math.nan,
            "mimicry_error_mm": float(np.mean(ok)) if ok else math.nan, "score": score}

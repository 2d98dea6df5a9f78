"""A stable-baselines3 ``VecEnv`` over the batched TriPlanarShear arrays: v0's (:class:`envs.vector.ShearBatch`) or
v1's (:class:`envs.vector_v1.BenchBatch`, with its frame stack and start bank).

It lives with the agents, not in :mod:`envs`, because stable-baselines3 (and torch with it) is an agent's
dependency: ``import envs`` and ``gym.make_vec`` work without them.
"""

from __future__ import annotations

from typing import Any, Sequence

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from stable_baselines3.common.vec_env import VecEnv

from envs import core as S
from envs.core import REFERENCE_DEVIATION_DIM
from envs.triplanar_shear_v1 import BENCH_FIELDS, BenchConfig
from envs.vector import ShearBatch
from envs.vector_v1 import BANK_REUSE, BenchBatch

from .privileged import TRUTH_NAMES, privileged_row, truth_scale

__all__ = ["DeviationSB3VecEnv", "PrivilegedSB3VecEnv", "ShearSB3VecEnv", "bench_vec_env"]


class ShearSB3VecEnv(VecEnv):
    """stable-baselines3 ``VecEnv`` over a batch (same-step autoreset, as SB3's ``DummyVecEnv``).

    ``ShearSB3VecEnv(n, config, seed=s, **v0_kwargs)`` batches ``TriPlanarShear-v0``; :func:`bench_vec_env` batches
    ``TriPlanarShear-v1``. ``row_options`` (v0) fixes reset options per environment, e.g. one load level each for
    evaluation: ``ShearSB3VecEnv(12, row_options=[{"load_N": f} for f in PAPER_LOADS_N])``.

    Observations are flat (a frame stack of ``k`` frames of ``dim`` values is ``k * dim`` values, oldest first, as
    ``FlattenObservation(FrameStackObservation(env, k))``). At an episode's end ``infos[i]`` has
    ``terminal_observation``, ``TimeLimit.truncated``, ``is_success``, ``reason``, ``mimicry_error_mm``,
    ``travel_m`` and ``load_N``; otherwise it is empty (nothing is copied per step but the arrays SB3 keeps).
    """

    def __init__(self, num_envs: int, config: S.ShearConfig | None = None, seed: int | None = None,
                 row_options: Sequence[dict[str, Any] | None] | None = None, *,
                 batch: ShearBatch | BenchBatch | None = None, **kwargs: Any):
        if batch is None:
            config = S.make_config(config, **kwargs)
            batch = ShearBatch(num_envs, config)
            space = S.observation_space()
        else:
            if config is not None or kwargs:
                raise ValueError("give either a batch or the env's configuration, not both")
            space = batch.single_observation_space()
        if row_options is not None:
            if not isinstance(batch, ShearBatch):
                raise ValueError("row_options is for v0's batch; v1's rows draw their own benches")
            if len(row_options) != num_envs:
                raise ValueError(f"row_options needs {num_envs} entries, got {len(row_options)}")
            batch.row_options = list(row_options)
        if batch.num_envs != num_envs:
            raise ValueError(f"num_envs {num_envs} differs from the batch's {batch.num_envs}")
        self.batch, self.config = batch, batch.config
        self.render_mode = None
        flat = spaces.Box(space.low.reshape(-1), space.high.reshape(-1), dtype=np.float32)
        super().__init__(num_envs, flat, S.action_space())
        if seed is not None:
            self.seed(seed)
        self._actions = np.zeros((num_envs, 2))
        self._all = np.ones(num_envs, dtype=np.bool_)

    def _flat_observations(self) -> np.ndarray:
        return self.batch.observations().reshape(self.num_envs, -1)

    def reset(self):
        seeds = self._seeds
        if any(s is not None for s in seeds):
            self.batch.seed(seeds)
        options = self._options[0] if self._options and self._options[0] else None
        self.batch.reset_rows(np.arange(self.num_envs), options)
        self._reset_seeds()
        self._reset_options()
        self.reset_infos = [self.batch.reset_info(i) for i in range(self.num_envs)]
        return self._flat_observations()

    def step_async(self, actions: np.ndarray) -> None:
        self._actions[:] = np.asarray(actions, dtype=np.float64).reshape(self.num_envs, 2)

    def step_wait(self):
        batch = self.batch
        codes = batch.step(self._actions, self._all)
        obs = self._flat_observations()
        rewards = batch.rewards().astype(np.float32)
        truncated = batch.truncated()
        dones = (codes > 0) | truncated
        infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        ended = np.flatnonzero(dones)
        for i in ended:
            infos[i] = {"terminal_observation": obs[i].copy(), "TimeLimit.truncated": bool(truncated[i]),
                        **batch.episode_info(i)}
        if len(ended):
            batch.reset_rows(ended)
            obs[ended] = self._flat_observations()[ended]
        return obs, rewards, dones, infos

    def close(self) -> None:
        pass

    def get_attr(self, attr_name: str, indices=None) -> list[Any]:
        return [getattr(self, attr_name) for _ in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices=None) -> None:
        setattr(self, attr_name, value)

    def env_method(self, method_name: str, *method_args, indices=None, **method_kwargs) -> list[Any]:
        return [getattr(self, method_name)(*method_args, **method_kwargs) for _ in self._get_indices(indices)]

    def env_is_wrapped(self, wrapper_class: type[gym.Wrapper], indices=None) -> list[bool]:
        return [False for _ in self._get_indices(indices)]

    def get_images(self) -> Sequence[np.ndarray | None]:
        return [None for _ in range(self.num_envs)]


class PrivilegedSB3VecEnv(ShearSB3VecEnv):
    """v1's batch with each row's privileged row (:func:`agents.privileged.privileged_row` of the bench it runs)
    appended to its flat observation: a teacher's training env (``env: privileged: true``). The terminal observation
    carries the ended episode's row, the next observation the new episode's."""

    def __init__(self, num_envs: int, seed: int | None = None, *, batch: BenchBatch):
        self._scale = truth_scale(batch.specimen, batch.foundation)
        self._truth = np.zeros((num_envs, len(TRUTH_NAMES)), dtype=np.float32)
        self._truth_of: list[Any] = [None] * num_envs   # the bench each row of _truth was computed for
        super().__init__(num_envs, seed=seed, batch=batch)
        self.observation_space = _widened(self.observation_space, len(TRUTH_NAMES))

    def _flat_observations(self) -> np.ndarray:
        for i, bench in enumerate(self.batch.benches):
            if bench is not self._truth_of[i]:   # a new episode (the bank hands out the same bench again: no cost)
                self._truth[i], self._truth_of[i] = privileged_row(bench, self._scale), bench
        return np.concatenate([super()._flat_observations(), self._truth], axis=1)


# The deviation values an estimator must supply: CP1 z, CP2 x, CP2 z, CP3 x, CP3 z. CP1's x deviation is zero by
# construction (the travel is CP1's x displacement and the reference is indexed by it); the slope follows them.
ESTIMATED_DEVIATION = slice(1, 6)
BIAS_STREAM = 40_040   # the first entry of the training bias's seed sequence (envs.vector_v1.BANK_STREAM's kin)


class DeviationSB3VecEnv(ShearSB3VecEnv):
    """v1's batch with each row's deviation from its true hydrostatic reference and the reference's slope
    (:meth:`envs.vector_v1.BenchBatch.reference_deviations`, 12 values, now) appended to its flat observation:
    ``env: reference_deviation: true``, a privileged feature that a bench controller would have to estimate.

    ``bias_mm`` (``env: reference_deviation_bias_mm``; default 0: exact) trains with an estimate's error: each
    episode's :data:`ESTIMATED_DEVIATION` values are off by a Gaussian bias of that standard deviation, drawn at its
    start from the env's own stream (``[BIAS_STREAM, seed]``) and constant through it.

    ``estimator`` (``env: reference_deviation_estimator: FOLDER``) trains with the estimate in the loop: the 12
    values are, instead of the truth, what the bench estimator in FOLDER (:class:`agents.deviation_estimator.
    DeviationEstimator`, one per row, reset at each episode's start) makes of the row's observations so far, the
    same arithmetic the composed controller (``estimated:``) runs at the bench; ``with_state`` (``env:
    reference_deviation_estimator_state: true``) appends each row's GRU state after them.

    ``bank_size`` (``env: reference_deviation_bank: N``) trains on a specimen bank's estimate instead: one
    :class:`agents.deviation_bank.DeviationBank` of N hypotheses per row, reset at each episode's start with the
    row's load and the batch's config, weighed by each observation and advanced by the command the batch ran: what
    ``banked:RUN`` feeds its policy at the bench; with ``tracker`` (``env: reference_deviation_tracker: true``), that
    bank's Gauss-Newton tracker's estimate (:mod:`agents.deviation_tracker`), as ``banked:RUN`` then runs."""

    def __init__(self, num_envs: int, seed: int | None = None, *, batch: BenchBatch, bias_mm: float = 0.0,
                 estimator: str | None = None, with_state: bool = False, bank_size: int | None = None,
                 tracker: bool = False):
        self.bias_mm = float(bias_mm)
        self._rng = np.random.default_rng(None if seed is None else [BIAS_STREAM, seed])
        self._bias = np.zeros((num_envs, REFERENCE_DEVIATION_DIM))
        self._last_step = np.full(num_envs, np.inf)   # each row's control periods at the last observation
        self._estimators = _row_estimators(estimator, num_envs) or _row_banks(bank_size, num_envs, batch, tracker)
        self._estimate = np.zeros((num_envs, REFERENCE_DEVIATION_DIM))
        self.with_state = bool(with_state and self._estimators)
        self._state = np.zeros((num_envs, len(self._estimators[0].state) if self.with_state else 0), np.float32)
        self._estimated_step = np.full(num_envs, np.inf)   # each row's control periods at its last estimate
        super().__init__(num_envs, seed=seed, batch=batch)
        self.observation_space = _widened(self.observation_space, REFERENCE_DEVIATION_DIM + self._state.shape[1])

    def reset(self):
        self._estimated_step[:] = np.inf   # every row starts an episode, even one reset at step 0 before
        return super().reset()

    def _estimates(self) -> np.ndarray:
        """Each row's estimate after its current observation. Each observation is read once: ``step_wait`` asks
        twice when rows end (the terminal observation, then the reset rows'), so a row whose period count has not
        changed keeps its estimate, and one whose count fell (a new episode) restarts its estimator."""
        steps = self.batch.ST[:, S.ST_STEP].copy()
        frames = self.batch.observations()
        current = frames[:, -1] if frames.ndim == 3 else frames
        for i in np.flatnonzero(steps != self._estimated_step):
            if steps[i] < self._estimated_step[i]:
                self._estimators[i].reset()
            elif steps[i] > 0 and hasattr(self._estimators[i], "advance"):
                self._estimators[i].advance(self._actions[i])   # a bank's: the command the row ran since
            self._estimate[i] = self._estimators[i].update(current[i])
            if self.with_state:
                self._state[i] = self._estimators[i].state
        self._estimated_step = steps
        return self._estimate.copy()

    def _flat_observations(self) -> np.ndarray:
        deviations = self._estimates() if self._estimators else self.batch.reference_deviations()
        if self.bias_mm:
            steps = self.batch.ST[:, S.ST_STEP].copy()
            new = steps < self._last_step   # fewer periods than at the last look: a new episode
            width = ESTIMATED_DEVIATION.stop - ESTIMATED_DEVIATION.start
            self._bias[new, ESTIMATED_DEVIATION] = self._rng.normal(0.0, self.bias_mm, (int(new.sum()), width))
            self._last_step = steps
            deviations = deviations + self._bias
        return np.concatenate([super()._flat_observations(), deviations.astype(np.float32), self._state], axis=1)


def _row_estimators(folder: str | None, n: int) -> list[Any]:
    """``n`` run-time estimators of ``folder`` (one read of its files; each row keeps its own GRU state)."""
    if folder is None:
        return []
    from .deviation_estimator import DeviationEstimator, read_estimator   # numpy only: no policy module
    spec, tensors = read_estimator(folder)
    return [DeviationEstimator(spec, tensors) for _ in range(n)]


class _RowBank:
    """A training row's :class:`agents.deviation_bank.DeviationBank` with the GRU estimator's interface (``reset``,
    ``update``) plus ``advance``: reset with the row's episode load and the batch's config."""

    def __init__(self, bank: Any, batch: BenchBatch, row: int):
        self.bank, self.batch, self.row = bank, batch, row

    def reset(self) -> None:
        self.bank.reset(self.batch.benches[self.row].load_N, self.batch.config)

    def update(self, obs: np.ndarray) -> np.ndarray:
        return self.bank.estimate(obs)

    def advance(self, action: np.ndarray) -> None:
        self.bank.advance(action)


def _row_banks(bank_size: int | None, n: int, batch: BenchBatch, tracker: bool = False) -> list[Any]:
    """``n`` specimen-bank estimators of ``bank_size`` hypotheses, one per row (``banked:RUN``'s settings), each
    with its Gauss-Newton tracker if ``tracker``."""
    if bank_size is None:
        return []
    from .deviation_tracker import deviation_estimator   # imports mpc: only for a bank-trained run
    return [_RowBank(deviation_estimator(int(bank_size), tracker), batch, i) for i in range(n)]


def _widened(space: spaces.Box, extra: int) -> spaces.Box:
    """``space`` with ``extra`` unbounded values appended."""
    more = np.full(extra, np.inf, dtype=np.float32)
    return spaces.Box(np.concatenate([space.low, -more]), np.concatenate([space.high, more]), dtype=np.float32)


def bench_vec_env(num_envs: int, seed: int | None = None, *, frame_stack: int = 1, start_bank: int = 0,
                  bank_reuse: int = BANK_REUSE, **v1_kwargs: Any) -> ShearSB3VecEnv:
    """``TriPlanarShear-v1`` x ``num_envs`` as an SB3 ``VecEnv`` (every v1 argument, plus the batch's frame stack
    and start bank: :mod:`envs.vector_v1`); env ``i`` is seeded ``seed + i``. (A privileged input, a training run's
    ``env: privileged`` or ``reference_deviation``: :func:`agents.train_config.make_vec_env`.)"""
    bench_kwargs = {k: v for k, v in v1_kwargs.items() if k in BENCH_FIELDS}
    shear_kwargs = {k: v for k, v in v1_kwargs.items() if k not in BENCH_FIELDS}
    bench = BenchConfig(**bench_kwargs)
    batch = BenchBatch(num_envs, S.make_config(None, **shear_kwargs), bench, frame_stack, start_bank, bank_reuse)
    return ShearSB3VecEnv(num_envs, seed=seed, batch=batch)

"""N ``TriPlanarShear-v1`` environments in state arrays, stepped by one compiled loop (as :mod:`envs.vector` for v0).

Each row runs exactly the single v1 env's bench (:func:`envs.triplanar_shear_v1.bench_command`) and the core's
control step (:func:`envs.core.control_step`), draws its episodes and sensor noise from its own generator with the
single env's functions (:func:`~envs.triplanar_shear_v1.draw_start`), so env ``i`` of a batch seeded ``s`` is bitwise
a single v1 env seeded ``s + i`` given the same actions (and, with ``frame_stack=k``, that env wrapped in
``FrameStackObservation(env, k)``).

* :class:`BenchBatch`: the arrays, resets of chosen rows, one batched step (no autoreset), observations, rewards;
* :class:`TriPlanarShearV1VectorEnv`: Gymnasium ``VectorEnv`` (next-step autoreset), ``gym.make_vec``'s vector entry
  point for ``TriPlanarShear-v1``.

The stable-baselines3 ``VecEnv`` over either version's batch is :class:`agents.sb3_vec_env.ShearSB3VecEnv`.

**Start bank** (``start_bank=C``, with ``randomize=True`` only; default 0: off). An unknown specimen's start costs a
start-mode search and a hydrostatic reference run (about 1.7 ms a reset, draws that cannot start included). With a
bank, a reset takes the next of ``C`` precomputed unknown specimens in turn (the first reset computes all ``C``), and
an entry is replaced by a fresh draw after ``bank_reuse`` episodes (default 8): a reset then costs about
``1 / bank_reuse`` of a fresh start. What it does to the training distribution: the specimens are drawn from the
same ranges (the same :func:`draw_bench`, the same rejection of specimens that cannot start), but each specimen
serves ``bank_reuse`` episodes (each with its own sensor noise, and in whatever state the policy leaves it): the
number of distinct specimens seen in training is the number of episodes divided by ``bank_reuse``, and episodes
that share a specimen are correlated. The bank draws from its own streams,
``np.random.default_rng([BANK_STREAM, seed, k])`` for its ``k``-th specimen, which no held-out or tuning set uses
(theirs are ``[seed, i]`` pairs of other seeds: :mod:`agents.heldout`). Rows of a banked batch are not the single
env's episodes (the bitwise equality above holds without a bank).
"""

from __future__ import annotations

from typing import Any, Sequence

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space
from numba import njit

from triplanar import kernel as K
from triplanar.outcome import RUNNING, TIME_LIMIT, TRAVEL

from . import core as S
from .triplanar_shear_v1 import (BENCH_HIGH, BENCH_OBS_DIM, BS_PREV, BS_THRUST, DEFAULT_BENCH, N_BS, Bench, BenchConfig,
                                 action_rate_reward, bench_command, bench_constants, bench_observation, bench_option,
                                 bench_start, draw_start, observation_space_of, reset_bench_state)
from .vector import seed_list

BANK_STREAM = 30_030   # the first entry of the start bank's seed sequences (agents.heldout uses 10_010, 20_020)
BANK_REUSE = 8


@njit(cache=True, error_model="numpy")
def _bench_batch_step(ACT, bc, BS, QUEUE, Y, P, MODES, ARMED, ST, REF, cfg, OBS, INF, APPLIED, DA, CODES, active,
                      ws) -> None:
    """The bench and the control step of every active row (``ws``: one kernel workspace, shared in turn)."""
    for i in range(Y.shape[0]):
        if active[i]:
            d0, d1 = bench_command(ACT[i], bc, BS[i], QUEUE[i], Y[i], ST[i], APPLIED[i])
            DA[i, 0] = d0
            DA[i, 1] = d1
            CODES[i] = S.control_step(Y[i], P[i], MODES[i], ARMED[i], ST[i], REF[i], APPLIED[i], cfg, OBS[i],
                                      INF[i], ws)


@njit(cache=True, error_model="numpy")
def _bench_observations(rows, OBS, NOISE, BS, Y, ST, high, out) -> None:
    """The bench observation of each row in ``rows`` into ``out`` (float32; ``NOISE`` has 0 columns without noise)."""
    for j in range(rows.shape[0]):
        i = rows[j]
        out[i, :] = bench_observation(OBS[i], NOISE[i], BS[i], Y[i], ST[i], high)


class BenchBatch:
    """State arrays of ``num_envs`` v1 environments sharing one configuration and bench (see the module docstring).

    ``frame_stack=k`` (k >= 1) keeps the last ``k`` observations of each row, as ``FrameStackObservation`` does
    (padded at an episode's start with its first observation): :meth:`observations` is then ``(n, k, dim)``.
    """

    def __init__(self, num_envs: int, config: S.ShearConfig, bench: BenchConfig, frame_stack: int = 1,
                 start_bank: int = 0, bank_reuse: int = BANK_REUSE):
        if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)) or num_envs < 1:
            raise ValueError(f"num_envs must be an integer >= 1, got {num_envs!r}")
        for name, value, low in (("frame_stack", frame_stack, 1), ("start_bank", start_bank, 0),
                                 ("bank_reuse", bank_reuse, 1)):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < low:
                raise ValueError(f"{name} must be an integer >= {low}, got {value!r}")
        bench.validate(config.dt, config.time_limit_s)
        self.num_envs, self.config, self.bench = int(num_envs), config, bench
        self.frame_stack = int(frame_stack)
        self.cfg, self.bc = config.packed(), bench_constants(bench, config)
        self.specimen, self.foundation = config.base_specimen()
        self._start_cache = S.StartCache()   # the batch's starts, as a single env's
        n, dim = self.num_envs, self.obs_dim
        self.Y, self.P, self.MODES = np.zeros((n, K.N_STATE)), np.zeros((n, K.N_PARAM)), np.zeros((n, K.N_MODE))
        self.ARMED = np.zeros((n, 5), dtype=np.bool_)
        self.ST, self.OBS, self.INF = np.zeros((n, S.N_ST)), np.zeros((n, S.OBS_DIM)), np.zeros((n, S.N_INFO))
        self.REF = np.zeros((n, S.REFERENCE_POINTS, 9))
        self.BS = np.zeros((n, N_BS))
        self.QUEUE = np.zeros((n, bench.latency_periods(config.dt), 2))
        self.ACT, self.APPLIED, self.DA = np.zeros((n, 2)), np.zeros((n, 2)), np.zeros((n, 2))
        self.CODES = np.zeros(n, dtype=np.int64)
        self.R_RATE = np.zeros(n)
        self.NOISE = np.zeros((n, 9 if bench.sensor_noise_m > 0 else 0))
        self.FRAMES = np.zeros((n, self.frame_stack, dim), dtype=np.float32)
        self._single = np.zeros((n, dim), dtype=np.float32)
        self.ws = S.new_workspace()
        self.rngs: list[np.random.Generator] = [seeding.np_random(None)[0] for _ in range(n)]
        self.benches: list[Bench | None] = [None] * n
        self._bank_size = int(start_bank) if bench.randomize else 0
        self._bank_reuse = int(bank_reuse)
        self._bank: list[list[Any]] = []   # [bench, start, episodes left]
        self._bank_next = 0
        self._bank_drawn = 0
        self._bank_seed = int(np.random.SeedSequence().entropy)   # until seed() gives one

    @property
    def obs_dim(self) -> int:
        return S.OBS_DIM if self.bench.observation_mode == "state" else BENCH_OBS_DIM

    def single_observation_space(self) -> spaces.Box:
        """One env's observation space (``(k, dim)`` with a frame stack, as ``FrameStackObservation``'s)."""
        space = observation_space_of(self.bench.observation_mode)
        if self.frame_stack == 1:
            return space
        return spaces.Box(np.repeat(space.low[None], self.frame_stack, 0),
                          np.repeat(space.high[None], self.frame_stack, 0), dtype=np.float32)

    # -- resets ----------------------------------------------------------------------------------
    def seed(self, seeds: Sequence[int | None], rows: Sequence[int] | None = None) -> None:
        rows = range(self.num_envs) if rows is None else rows
        seeds = list(seeds)
        for i, seed in zip(rows, seeds):
            self.rngs[i] = seeding.np_random(seed)[0]
        if seeds and seeds[0] is not None:   # the bank's streams follow the batch's first seed
            self._bank_seed = int(seeds[0])

    def _bank_draw(self) -> list[Any]:
        bench, start = draw_start(np.random.default_rng([BANK_STREAM, self._bank_seed, self._bank_drawn]),
                                  self.config, True, self.specimen, self.foundation, self._start_cache)
        self._bank_drawn += 1
        return [bench, start, self._bank_reuse]

    def _bank_take(self) -> tuple[Bench, S.EpisodeStart]:
        """The next banked specimen and its start (a fresh draw where the entry has served its episodes). The first
        reset fills the whole bank, so that every episode comes from a full bank."""
        if not self._bank:
            self._bank = [self._bank_draw() for _ in range(self._bank_size)]
        if self._bank[self._bank_next][2] == 0:
            self._bank[self._bank_next] = self._bank_draw()
        entry = self._bank[self._bank_next]
        entry[2] -= 1
        self._bank_next = (self._bank_next + 1) % self._bank_size
        return entry[0], entry[1]

    def reset_rows(self, rows: np.ndarray, options: dict[str, Any] | None = None) -> None:
        """Start a new episode in each row of ``rows`` (drawn from that row's generator, or from the start bank, or
        ``options["bench"]``, a :class:`Bench`, as the single env's reset option), and make its first observation."""
        bench = bench_option(options)
        rows = np.asarray(rows, dtype=np.int64)
        for i in rows.tolist():
            if bench is not None:
                episode, start = bench, bench_start(self.config, bench, self._start_cache)
            elif self._bank_size:
                episode, start = self._bank_take()
            else:
                episode, start = draw_start(self.rngs[i], self.config, self.bench.randomize, self.specimen,
                                            self.foundation, self._start_cache)
            self.benches[i] = episode
            reset_bench_state(self.config, start, self.BS[i], self.QUEUE[i])
            self.Y[i], self.P[i], self.MODES[i], self.ARMED[i] = start.y, start.p, start.modes, start.armed
            self.ST[i], self.REF[i], self.OBS[i], self.INF[i] = start.st, start.reference, start.obs, start.inf
        self.CODES[rows] = RUNNING
        self.R_RATE[rows] = 0.0
        self._observe(rows)
        self.FRAMES[rows] = self._single[rows][:, None, :]

    # -- steps -----------------------------------------------------------------------------------
    def step(self, actions: np.ndarray, active: np.ndarray) -> np.ndarray:
        """One control period for the active rows (actions clipped as the single env does); returns the outcome
        codes (``> 0``: terminated). Observations, action-rate rewards and frames follow."""
        self.ACT[:] = actions
        _bench_batch_step(self.ACT, self.bc, self.BS, self.QUEUE, self.Y, self.P, self.MODES, self.ARMED, self.ST,
                          self.REF, self.cfg, self.OBS, self.INF, self.APPLIED, self.DA, self.CODES, active, self.ws)
        rows = np.flatnonzero(active)
        coef = self.config.action_rate_coef
        da = self.DA.tolist()
        for i in rows.tolist():
            self.R_RATE[i] = action_rate_reward(coef, da[i][0], da[i][1])
        self._observe(rows)
        if self.frame_stack > 1:
            self.FRAMES[rows, :-1] = self.FRAMES[rows, 1:]
        self.FRAMES[rows, -1] = self._single[rows]
        return self.CODES

    def _observe(self, rows: np.ndarray) -> None:
        """The current observation of ``rows`` into ``_single`` (noise drawn from each row's generator, in the
        single env's order)."""
        if self.bench.observation_mode == "state":
            obs = self.OBS[rows].copy()
            obs[:, S.OBS_PREV:S.OBS_PREV + 2] = self.BS[rows, BS_PREV:BS_PREV + 2]
            self._single[rows] = obs.astype(np.float32)
            return
        if self.NOISE.shape[1]:
            sigma = self.bench.sensor_noise_m
            for i in rows.tolist():
                self.NOISE[i] = self.rngs[i].normal(0.0, sigma, 9)
        _bench_observations(rows, self.OBS, self.NOISE, self.BS, self.Y, self.ST, BENCH_HIGH, self._single)

    def observations(self) -> np.ndarray:
        """Every row's observation, float32 (``(n, dim)``, or ``(n, k, dim)`` with a frame stack), a new array."""
        return self.FRAMES.copy() if self.frame_stack > 1 else self._single.copy()

    def reference_deviations(self) -> np.ndarray:
        """Every row's deviation from its true hydrostatic reference now and the reference's slope
        (:func:`envs.core.reference_deviation`, ``(n, 12)``, float64): the truth, for a privileged policy."""
        return S.reference_deviation(self.OBS, self.REF, self.config.travel_m)

    def rewards(self) -> np.ndarray:
        """The last step's rewards (float64): the core's distance and termination terms and the bench's action rate."""
        return (self.INF[:, S.IN_R_DIST] + self.INF[:, S.IN_R_TERM]) + self.R_RATE

    def truncated(self) -> np.ndarray:
        return self.INF[:, S.IN_TRUNC] != 0

    def infos(self) -> dict[str, np.ndarray]:
        """Info terms as arrays (keys as the single env's step info, plus ``reason_code``)."""
        info = {key: self.INF[:, slot].copy() for key, slot in zip(S.INFO_KEYS, S.INFO_SLOTS)}
        info["reward_action_rate"] = self.R_RATE.copy()
        info["load_cell_N"] = self.BS[:, BS_THRUST].copy()
        codes = self.CODES
        info["reason_code"] = np.where(codes != RUNNING, codes, np.where(self.truncated(), TIME_LIMIT, RUNNING))
        info["reason"] = S.REASON_LABELS[info["reason_code"]]
        info["is_success"] = codes == TRAVEL
        return info

    def reason(self, i: int) -> str:
        return S.reason(int(self.CODES[i]), bool(self.INF[i, S.IN_TRUNC]))

    def episode_info(self, i: int) -> dict[str, Any]:
        """Row ``i``'s episode end, as the SB3 adapter reports it."""
        return {"is_success": bool(self.CODES[i] == TRAVEL), "reason": self.reason(i),
                "mimicry_error_mm": float(self.INF[i, S.IN_ERR]), "travel_m": float(self.INF[i, S.IN_TRAVEL]),
                "load_N": float(self.INF[i, S.IN_LOAD])}

    def reset_info(self, i: int) -> dict[str, Any]:
        bench = self.benches[i]
        return {"load_N": bench.load_N} if bench is not None else {}


def check_max_episode_steps(max_episode_steps: Any, config: S.ShearConfig) -> None:
    """``gym.make_vec`` passes the registered ``max_episode_steps`` (399); the batch truncates at ``time_limit_s``
    itself and cannot end episodes earlier, so a limit below that is refused by name (one at or above it changes
    nothing: the batch truncates first, as a single env under Gymnasium's ``TimeLimit`` does)."""
    if max_episode_steps is None:
        return
    if isinstance(max_episode_steps, bool) or not isinstance(max_episode_steps, (int, np.integer)) \
            or max_episode_steps < config.agent_steps:
        raise ValueError(f"max_episode_steps must be None or an integer >= {config.agent_steps} (the steps of "
                         f"time_limit_s = {config.time_limit_s:g} s, where the batched env truncates); got "
                         f"{max_episode_steps!r} (with a longer time_limit_s, pass gym.make_vec(..., max_episode_steps=None))")


class TriPlanarShearV1VectorEnv(VectorEnv):
    """``TriPlanarShear-v1`` x ``num_envs`` in state arrays: every v1 argument (see
    :class:`envs.triplanar_shear_v1.TriPlanarShearV1Env`), plus ``frame_stack`` (k >= 1: observations ``(k, dim)``
    per env, as ``FrameStackObservation``), ``start_bank`` and ``bank_reuse`` (the module docstring).

    Next-step autoreset (``metadata["autoreset_mode"]``): the step after an episode ends returns the new episode's
    first observation, reward 0 and ``terminated = truncated = False``. ``reset(seed=s)`` seeds env ``i`` with
    ``s + i`` (or pass a list); ``reset(options={"bench": Bench})`` runs that bench in every env. ``info`` holds the
    single env's step terms as arrays, with ``reason_code`` (:class:`triplanar.outcome.Outcome` value) and
    ``is_success``.
    """

    metadata = {"render_modes": [], "autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(self, num_envs: int = 1, render_mode: str | None = None, *,
                 observation_mode: str = DEFAULT_BENCH.observation_mode, randomize: bool = DEFAULT_BENCH.randomize,
                 stage_bandwidth_hz: float = DEFAULT_BENCH.stage_bandwidth_hz,
                 thrust_bandwidth_hz: float = DEFAULT_BENCH.thrust_bandwidth_hz,
                 latency_s: float = DEFAULT_BENCH.latency_s, sensor_noise_m: float = DEFAULT_BENCH.sensor_noise_m,
                 frame_stack: int = 1, start_bank: int = 0,
                 bank_reuse: int = BANK_REUSE, max_episode_steps: int | None = None, **kwargs: Any):
        if render_mode is not None:
            raise ValueError("the batched v1 does not render; render a single TriPlanarShear-v1 to watch a test")
        config = S.make_config(None, **kwargs)
        check_max_episode_steps(max_episode_steps, config)
        bench = BenchConfig(stage_bandwidth_hz, thrust_bandwidth_hz, latency_s, sensor_noise_m, observation_mode,
                            randomize)
        self.batch = BenchBatch(num_envs, config, bench, frame_stack, start_bank, bank_reuse)
        self.config, self.num_envs, self.render_mode = config, int(num_envs), None
        self.single_observation_space = self.batch.single_observation_space()
        self.single_action_space = S.action_space()
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self._prev_done = np.zeros(self.num_envs, dtype=np.bool_)
        self._started = False

    def reset(self, *, seed: int | Sequence[int | None] | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed if isinstance(seed, (int, np.integer)) else None)
        bench_option(options)  # a named error before any state changes
        if seed is not None or not self._started:
            self.batch.seed(seed_list(seed, self.num_envs))
        self.batch.reset_rows(np.arange(self.num_envs), options)
        self._prev_done[:] = False
        self._started = True
        return self.batch.observations(), self.batch.infos()

    def step(self, actions: np.ndarray):
        if not self._started:
            raise gym.error.ResetNeeded("call reset() before step()")
        S.check_actions(actions, self.num_envs)  # a named error before any state changes
        batch = self.batch
        resetting = np.flatnonzero(self._prev_done)
        if len(resetting):
            batch.reset_rows(resetting)
        codes = batch.step(np.asarray(actions, dtype=np.float64).reshape(self.num_envs, 2), ~self._prev_done)
        rewards = batch.rewards()
        terminated = codes > 0
        truncated = batch.truncated()
        rewards[resetting] = 0.0
        terminated[resetting] = False
        truncated[resetting] = False
        self._prev_done = terminated | truncated
        return batch.observations(), rewards, terminated, truncated, batch.infos()

    def render(self):
        raise NotImplementedError("the batched v1 does not render; render a single TriPlanarShear-v1 to watch a test")

    def close_extras(self, **kwargs: Any) -> None:
        pass


__all__ = ["BANK_STREAM", "BenchBatch", "TriPlanarShearV1VectorEnv"]

"""N TriPlanarShear environments in state arrays, stepped by one compiled loop (as Gymnasium's CartPoleVectorEnv).

Each environment runs exactly the single env's compiled control step (:func:`envs.core.control_step`)
on its row of the state arrays, so env ``i`` of a batch seeded ``s`` is bitwise identical to a single env seeded
``s + i`` given the same actions. Three layers:

* :class:`ShearBatch`: the arrays, resets of chosen rows, one batched step (no autoreset);
* :class:`TriPlanarShearVectorEnv`: Gymnasium ``VectorEnv`` (next-step autoreset), ``gym.make_vec``'s vector entry
  point for ``TriPlanarShear-v0``.

(:mod:`envs.vector_v1` is v1's: its ``BenchBatch`` has the same reading methods, ``observations``, ``rewards``,
``truncated``, ``episode_info``, ``reset_info``, so one SB3 adapter serves both.)

The stable-baselines3 ``VecEnv`` over the same arrays is :class:`agents.sb3_vec_env.ShearSB3VecEnv` (SB3 is an
agent's dependency; ``import envs`` and ``gym.make_vec`` need neither it nor torch).
"""

from __future__ import annotations

from typing import Any, Iterable, Sequence

import gymnasium as gym
import numpy as np
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space
from numba import njit

from triplanar.outcome import RUNNING, TIME_LIMIT, TRAVEL

from . import core as S


@njit(cache=True, error_model="numpy")
def _batch_step(Y, P, MODES, ARMED, ST, BANK_REF, KIDX, ACT, cfg, OBS, INF, CODES, active, ws) -> None:
    """Step every active row (``ws``: one kernel workspace, scratch shared by the rows in turn)."""
    for i in range(Y.shape[0]):
        if active[i]:
            CODES[i] = S.control_step(Y[i], P[i], MODES[i], ARMED[i], ST[i], BANK_REF[KIDX[i]], ACT[i], cfg, OBS[i],
                                      INF[i], ws)


@njit(cache=True, error_model="numpy")
def _load_starts(rows, kidx, KIDX, Y, P, MODES, ARMED, ST, OBS, INF, BY, BP, BMODES, BARMED, BST, BOBS,
                 BINF) -> None:
    """Copy bank entry ``kidx[j]`` into environment row ``rows[j]``."""
    for j in range(rows.shape[0]):
        i, k = rows[j], kidx[j]
        KIDX[i] = k
        Y[i, :] = BY[k]
        P[i, :] = BP[k]
        MODES[i, :] = BMODES[k]
        ARMED[i, :] = BARMED[k]
        ST[i, :] = BST[k]
        OBS[i, :] = BOBS[k]
        INF[i, :] = BINF[k]


class ShearBatch:
    """State arrays of ``num_envs`` environments sharing one :class:`~envs.core.ShearConfig`.

    Distinct starting states (load level x friction draw) live in a bank; each row points at its entry (for the
    hydrostatic reference) through ``kidx``.
    """

    def __init__(self, num_envs: int, config: S.ShearConfig):
        if num_envs < 1:
            raise ValueError(f"num_envs must be >= 1, got {num_envs}")
        self.num_envs, self.config = num_envs, config
        self.cfg = config.packed()
        self.specimen, self.foundation = config.base_specimen()
        self._base_key = S.specimen_key(self.specimen, self.foundation)
        n = num_envs
        self.Y = np.zeros((n, S.K.N_STATE))
        self.P = np.zeros((n, S.K.N_PARAM))
        self.MODES = np.zeros((n, S.K.N_MODE))
        self.ARMED = np.zeros((n, 5), dtype=np.bool_)
        self.ST = np.zeros((n, S.N_ST))
        self.OBS = np.zeros((n, S.OBS_DIM))
        self.INF = np.zeros((n, S.N_INFO))
        self.ACT = np.zeros((n, 2))
        self.CODES = np.zeros(n, dtype=np.int64)
        self.ws = S.new_workspace()  # scratch, shared by the rows in turn
        self.KIDX = np.zeros(n, dtype=np.int64)
        self.rngs: list[np.random.Generator] = [seeding.np_random(None)[0] for _ in range(n)]
        self.draws: list[S.EpisodeDraw | None] = [None] * n
        self.row_options: list[dict[str, Any] | None] | None = None
        self._entries: list[S.EpisodeStart] = []
        self._index: dict[S.EpisodeDraw, int] = {}
        self._bank_capacity = 0
        self._grow(4)

    # -- the bank of starting states -------------------------------------------------------------
    def _grow(self, capacity: int) -> None:
        old = self._bank_capacity
        g = S.REFERENCE_POINTS
        shapes = {"BY": (S.K.N_STATE,), "BP": (S.K.N_PARAM,), "BMODES": (S.K.N_MODE,), "BARMED": (5,),
                  "BST": (S.N_ST,),
                  "BOBS": (S.OBS_DIM,), "BINF": (S.N_INFO,), "BREF": (g, 9)}
        for name, shape in shapes.items():
            arr = np.zeros((capacity,) + shape, dtype=np.bool_ if name == "BARMED" else np.float64)
            if old:
                arr[:old] = getattr(self, name)
            setattr(self, name, arr)
        self._bank_capacity = capacity

    def _bank_index(self, draw: S.EpisodeDraw) -> int:
        k = self._index.get(draw)
        if k is not None:
            return k
        entry = S.episode_start(self.config, draw, self.specimen, self.foundation, self._base_key)
        k = len(self._entries)
        if k >= self._bank_capacity:
            self._grow(2 * self._bank_capacity)
        self.BY[k], self.BP[k], self.BMODES[k] = entry.y, entry.p, entry.modes
        self.BARMED[k], self.BST[k] = entry.armed, entry.st
        self.BOBS[k], self.BINF[k], self.BREF[k] = entry.obs, entry.inf, entry.reference
        self._entries.append(entry)
        self._index[draw] = k
        return k

    def entry(self, i: int) -> S.EpisodeStart:
        """The starting-state entry (model, reference) of row ``i``'s current episode."""
        return self._entries[int(self.KIDX[i])]

    # -- resets and steps --------------------------------------------------------------------------
    def seed(self, seeds: Sequence[int | None], rows: Iterable[int] | None = None) -> None:
        rows = range(self.num_envs) if rows is None else rows
        for i, seed in zip(rows, seeds):
            self.rngs[i] = seeding.np_random(seed)[0]

    def reset_rows(self, rows: np.ndarray, options: dict[str, Any] | None = None) -> None:
        """Start a new episode in each row of ``rows`` (drawing from that row's own generator). Without
        ``options``, a row uses its entry of ``row_options`` (if set: fixed per-row reset options)."""
        rows = np.asarray(rows, dtype=np.int64)
        kidx = np.empty(len(rows), dtype=np.int64)
        for j, i in enumerate(rows):
            opts = options if options is not None or self.row_options is None else self.row_options[i]
            draw = S.draw_episode(self.rngs[i], self.config, self.specimen, opts)
            self.draws[i] = draw
            kidx[j] = self._bank_index(draw)
        _load_starts(rows, kidx, self.KIDX, self.Y, self.P, self.MODES, self.ARMED, self.ST, self.OBS, self.INF,
                     self.BY, self.BP, self.BMODES, self.BARMED, self.BST, self.BOBS, self.BINF)

    def step(self, actions: np.ndarray, active: np.ndarray) -> np.ndarray:
        """One control period for the active rows; returns the outcome codes (``> 0``: terminated)."""
        self.ACT[:] = actions
        _batch_step(self.Y, self.P, self.MODES, self.ARMED, self.ST, self.BREF, self.KIDX, self.ACT, self.cfg, self.OBS,
                    self.INF, self.CODES, active, self.ws)
        return self.CODES

    def infos(self, rows: np.ndarray | slice = slice(None)) -> dict[str, np.ndarray]:
        """Info terms of ``rows`` as arrays (keys as the single env's info)."""
        info = {key: self.INF[rows, slot].copy() for key, slot in zip(S.INFO_KEYS, S.INFO_SLOTS)}
        codes = self.CODES[rows]
        info["reason_code"] = np.where(codes != RUNNING, codes, np.where(self.INF[rows, S.IN_TRUNC] != 0, TIME_LIMIT,
                                                                          RUNNING))
        info["reason"] = S.REASON_LABELS[info["reason_code"]]
        info["is_success"] = codes == TRAVEL
        return info

    def reason(self, i: int) -> str:
        return S.reason(int(self.CODES[i]), bool(self.INF[i, S.IN_TRUNC]))

    # -- what an adapter reads (the same methods as envs.vector_v1.BenchBatch) --------------------------------
    def observations(self) -> np.ndarray:
        """Every row's observation, float32, a new array."""
        return self.OBS.astype(np.float32)

    def rewards(self) -> np.ndarray:
        """The last step's rewards (float64), a new array."""
        return self.INF[:, S.IN_REWARD].copy()

    def truncated(self) -> np.ndarray:
        return self.INF[:, S.IN_TRUNC] != 0

    def episode_info(self, i: int) -> dict[str, Any]:
        """Row ``i``'s episode end, as the SB3 adapter reports it."""
        return {"is_success": bool(self.CODES[i] == TRAVEL), "reason": self.reason(i),
                "mimicry_error_mm": float(self.INF[i, S.IN_ERR]), "travel_m": float(self.INF[i, S.IN_TRAVEL]),
                "load_N": float(self.INF[i, S.IN_LOAD])}

    def reset_info(self, i: int) -> dict[str, Any]:
        draw = self.draws[i]
        return {"load_N": draw.load_N} if draw is not None else {}


def seed_list(seed: int | Sequence[int | None] | None, n: int) -> list[int | None]:
    """Per-env seeds of a batch: ``seed + i`` for an int, as given for a list, all None for None."""
    if seed is None or isinstance(seed, (int, np.integer)):
        return [None if seed is None else int(seed) + i for i in range(n)]
    if len(seed) != n:
        raise ValueError(f"need {n} seeds, got {len(seed)}")
    return list(seed)


class TriPlanarShearVectorEnv(VectorEnv):
    """``TriPlanarShear-v0`` x ``num_envs`` in state arrays; the same dynamics as
    :class:`envs.triplanar_shear.TriPlanarShearEnv` (see its docstring for spaces, reward and episode end).

    Next-step autoreset: the step after an episode ends returns the new episode's first observation, reward 0 and
    ``terminated = truncated = False``. ``reset(seed=s)`` seeds env ``i`` with ``s + i`` (or pass a list);
    ``info`` holds the single env's terms as arrays, with ``reason_code`` (the :class:`triplanar.outcome.Outcome`
    value: ``RUNNING`` while the episode goes on, ``TIME_LIMIT`` when truncated) and ``is_success``.
    """

    metadata = {"render_modes": [], "autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(self, num_envs: int = 1, render_mode: str | None = None, config: S.ShearConfig | None = None,
                 **kwargs: Any):
        self.config = S.make_config(config, **kwargs)
        self.batch = ShearBatch(num_envs, self.config)
        self.num_envs = num_envs
        self.render_mode = render_mode
        self.single_observation_space = S.observation_space()
        self.single_action_space = S.action_space()
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self._prev_done = np.zeros(num_envs, dtype=np.bool_)
        self._started = False

    def reset(self, *, seed: int | Sequence[int | None] | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed if isinstance(seed, (int, np.integer)) else None)
        if seed is not None or not self._started:
            self.batch.seed(seed_list(seed, self.num_envs))
        self.batch.reset_rows(np.arange(self.num_envs), options)
        self.batch.CODES[:] = 0
        self._prev_done[:] = False
        self._started = True
        return self.batch.OBS.astype(np.float32), self.batch.infos()

    def step(self, actions: np.ndarray):
        if not self._started:
            raise gym.error.ResetNeeded("call reset() before step()")
        S.check_actions(actions, self.num_envs)  # a named error before any state changes
        batch = self.batch
        resetting = np.flatnonzero(self._prev_done)
        if len(resetting):
            batch.reset_rows(resetting)
        batch.CODES[resetting] = 0
        codes = batch.step(np.asarray(actions, dtype=np.float64).reshape(self.num_envs, 2), ~self._prev_done)
        rewards = batch.INF[:, S.IN_REWARD].copy()
        terminated = codes > 0
        truncated = batch.INF[:, S.IN_TRUNC] != 0
        rewards[resetting] = 0.0
        truncated[resetting] = False
        self._prev_done = terminated | truncated
        return batch.OBS.astype(np.float32), rewards, terminated, truncated, batch.infos()

    def render(self):
        raise NotImplementedError("the vector env does not render; render a single TriPlanarShearEnv to watch a test")

    def close_extras(self, **kwargs: Any) -> None:
        pass

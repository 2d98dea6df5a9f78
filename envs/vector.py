"""N TriPlanarShear environments in state arrays, stepped by one compiled loop (as Gymnasium's CartPoleVectorEnv).

Each environment runs exactly the single env's compiled control step (:func:`envs.triplanar_shear.control_step`)
on its row of the state arrays, so env ``i`` of a batch seeded ``s`` is bitwise identical to a single env seeded
``s + i`` given the same actions. Three layers:

* :class:`ShearBatch`: the arrays, resets of chosen rows, one batched step (no autoreset);
* :class:`TriPlanarShearVectorEnv`: Gymnasium ``VectorEnv`` (next-step autoreset), ``gym.make_vec``'s vector entry
  point for ``TriPlanarShear-v0``;
* :class:`ShearSB3VecEnv`: a stable-baselines3 ``VecEnv`` (same-step autoreset, ``terminal_observation`` in infos).
"""

from __future__ import annotations

from typing import Any, Iterable, Sequence

import gymnasium as gym
import numpy as np
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space
from numba import njit
from stable_baselines3.common.vec_env import VecEnv

from triplanar import kernel as K

from . import triplanar_shear as S


@njit(cache=True, error_model="numpy")
def _batch_step(Y, P, ARMED, ST, BANK_REF, KIDX, ACT, cfg, OBS, INF, CODES, active, ws) -> None:
    """Step every active row (``ws``: one kernel workspace, scratch shared by the rows in turn)."""
    for i in range(Y.shape[0]):
        if active[i]:
            CODES[i] = S.control_step(Y[i], P[i], ARMED[i], ST[i], BANK_REF[KIDX[i]], ACT[i], cfg, OBS[i], INF[i],
                                      ws)


@njit(cache=True, error_model="numpy")
def _load_starts(rows, kidx, KIDX, Y, P, ARMED, ST, OBS, INF, BY, BP, BARMED, BST, BOBS, BINF) -> None:
    """Copy bank entry ``kidx[j]`` into environment row ``rows[j]``."""
    for j in range(rows.shape[0]):
        i, k = rows[j], kidx[j]
        KIDX[i] = k
        Y[i, :] = BY[k]
        P[i, :] = BP[k]
        ARMED[i, :] = BARMED[k]
        ST[i, :] = BST[k]
        OBS[i, :] = BOBS[k]
        INF[i, :] = BINF[k]


class ShearBatch:
    """State arrays of ``num_envs`` environments sharing one :class:`~envs.triplanar_shear.ShearConfig`.

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
        self.ARMED = np.zeros((n, 5), dtype=np.bool_)
        self.ST = np.zeros((n, S.N_ST))
        self.OBS = np.zeros((n, S.OBS_DIM))
        self.INF = np.zeros((n, S.N_INFO))
        self.ACT = np.zeros((n, 2))
        self.CODES = np.zeros(n, dtype=np.int64)
        self.ws = K.new_workspace()  # kernel scratch, shared by the rows in turn
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
        shapes = {"BY": (S.K.N_STATE,), "BP": (S.K.N_PARAM,), "BARMED": (5,), "BST": (S.N_ST,),
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
        self.BY[k], self.BP[k], self.BARMED[k], self.BST[k] = entry.y, entry.p, entry.armed, entry.st
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
        _load_starts(rows, kidx, self.KIDX, self.Y, self.P, self.ARMED, self.ST, self.OBS, self.INF, self.BY,
                     self.BP, self.BARMED, self.BST, self.BOBS, self.BINF)

    def step(self, actions: np.ndarray, active: np.ndarray) -> np.ndarray:
        """One control period for the active rows; returns the outcome codes (``> 0``: terminated)."""
        self.ACT[:] = actions
        _batch_step(self.Y, self.P, self.ARMED, self.ST, self.BREF, self.KIDX, self.ACT, self.cfg, self.OBS,
                    self.INF, self.CODES, active, self.ws)
        return self.CODES

    def infos(self, rows: np.ndarray | slice = slice(None)) -> dict[str, np.ndarray]:
        """Info terms of ``rows`` as arrays (keys as the single env's info)."""
        info = {key: self.INF[rows, slot].copy() for key, slot in zip(S.INFO_KEYS, S.INFO_SLOTS)}
        codes = self.CODES[rows]
        info["reason_code"] = np.where(codes > 0, codes, np.where(self.INF[rows, S.IN_TRUNC] != 0, -2, 0))
        info["is_success"] = codes == S.SUCCESS
        return info

    def reason(self, i: int) -> str:
        code = int(self.CODES[i])
        return S.REASONS[code] if code > 0 else (S.TIME_LIMIT if self.INF[i, S.IN_TRUNC] else "")


def _seed_list(seed: int | Sequence[int | None] | None, n: int) -> list[int | None]:
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
    ``info`` holds the single env's terms as arrays, with ``reason_code`` (index into
    ``envs.triplanar_shear.REASONS``; -2: time limit) and ``is_success``.
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
            self.batch.seed(_seed_list(seed, self.num_envs))
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


class ShearSB3VecEnv(VecEnv):
    """stable-baselines3 ``VecEnv`` over a :class:`ShearBatch` (same-step autoreset, as SB3's ``DummyVecEnv``).

    ``row_options`` fixes reset options per environment, e.g. one load level each for evaluation:
    ``ShearSB3VecEnv(12, row_options=[{"load_N": f} for f in PAPER_LOADS_N])``.

    At an episode's end ``infos[i]`` has ``terminal_observation``, ``TimeLimit.truncated``, ``is_success``,
    ``reason`` and ``mimicry_error_mm``; otherwise it is empty.
    """

    def __init__(self, num_envs: int, config: S.ShearConfig | None = None, seed: int | None = None,
                 row_options: Sequence[dict[str, Any] | None] | None = None, **kwargs: Any):
        config = S.make_config(config, **kwargs)
        self.batch = ShearBatch(num_envs, config)
        if row_options is not None:
            if len(row_options) != num_envs:
                raise ValueError(f"row_options needs {num_envs} entries, got {len(row_options)}")
            self.batch.row_options = list(row_options)
        self.config = config
        self.render_mode = None
        super().__init__(num_envs, S.observation_space(), S.action_space())
        if seed is not None:
            self.seed(seed)
        self._actions = np.zeros((num_envs, 2))
        self._all = np.ones(num_envs, dtype=np.bool_)

    def reset(self):
        seeds = self._seeds
        if any(s is not None for s in seeds):
            self.batch.seed(seeds)
        options = self._options[0] if self._options and self._options[0] else None
        self.batch.reset_rows(np.arange(self.num_envs), options)
        self._reset_seeds()
        self._reset_options()
        self.reset_infos = [{"load_N": d.load_N} for d in self.batch.draws]
        return self.batch.OBS.astype(np.float32)

    def step_async(self, actions: np.ndarray) -> None:
        self._actions[:] = np.asarray(actions, dtype=np.float64).reshape(self.num_envs, 2)

    def step_wait(self):
        batch = self.batch
        codes = batch.step(self._actions, self._all)
        obs = batch.OBS.astype(np.float32)
        rewards = batch.INF[:, S.IN_REWARD].astype(np.float32)
        terminated = codes > 0
        truncated = batch.INF[:, S.IN_TRUNC] != 0
        dones = terminated | truncated
        infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        ended = np.flatnonzero(dones)
        for i in ended:
            infos[i] = {"terminal_observation": obs[i].copy(), "TimeLimit.truncated": bool(truncated[i]),
                        "is_success": bool(codes[i] == S.SUCCESS), "reason": batch.reason(i),
                        "mimicry_error_mm": float(batch.INF[i, S.IN_ERR]), "travel_m": float(batch.INF[i, S.IN_TRAVEL]),
                        "load_N": float(batch.INF[i, S.IN_LOAD])}
        if len(ended):
            batch.reset_rows(ended)
            obs[ended] = batch.OBS[ended]
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

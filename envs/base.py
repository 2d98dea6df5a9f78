"""What ``TriPlanarShear-v0`` and ``-v1`` share as Gymnasium envs: one episode's arrays loaded from a cached start,
the compiled control step over them (:func:`envs.core.control_step`: physics, observation, reward terms
and the one truncation, ``time_limit_s``), one renderer (:mod:`envs.render`) and its ``render``/``close``.

The versioned classes (:class:`envs.triplanar_shear.TriPlanarShearEnv`,
:class:`envs.triplanar_shear_v1.TriPlanarShearV1Env`) add only what differs: how a reset draws its episode, what
lies between the agent's action and the step (v1's bench), and what the agent observes.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, fields
from typing import Any

import gymnasium as gym
import numpy as np

from .core import (IN_TRUNC, N_INFO, OBS_DIM, ST_CP_REST, ST_LOAD, ST_T, EpisodeStart, ShearConfig,
                   contact_points_of, control_step, load_point_of, new_workspace, reference_deviation)


@dataclass
class ShearState:
    """An episode's whole state, as the compiled step reads and writes it (copies: an env's arrays are never shared):
    the kernel state ``y`` (``triplanar.kernel.S_*``) and parameters ``p``, the stick/slip ``modes``, the armed
    events, the bookkeeping ``st`` (``envs.core.ST_*``), the episode's reference ``ref`` and the packed configuration
    ``cfg`` (``envs.core.CF_*``). :meth:`ShearEnvBase.get_state` makes one, :meth:`ShearEnvBase.set_state` loads one
    (MuJoCo envs' ``state_vector``/``set_state``)."""

    y: np.ndarray
    p: np.ndarray
    modes: np.ndarray
    armed: np.ndarray
    st: np.ndarray
    ref: np.ndarray
    cfg: np.ndarray

    def copy(self):
        return type(self)(*(np.array(getattr(self, f.name)) for f in fields(self)))


class ShearEnvBase(gym.Env):
    """One environment's state arrays and the compiled control step over them (subclasses set ``config``, the
    spaces, and call :meth:`_load_start` in ``reset`` and :meth:`_control_step` in ``step``).

    ``render_fps`` is the control rate (``control_hz``): a renderer draws one frame per control period, so a
    recorded video (``gymnasium.wrappers.RecordVideo``) lasts exactly as long as the episode did.
    """

    metadata = {"render_modes": ["human", "rgb_array"], "render_fps": 200}
    config: ShearConfig

    def _init_core(self, render_mode: str | None) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be one of {self.metadata['render_modes']}, got {render_mode!r}")
        self.render_mode = render_mode
        self.metadata = {**self.metadata, "render_fps": self.config.control_hz}
        self._specimen, self._foundation = self.config.base_specimen()
        self._cfg = self.config.packed()
        self._ws = new_workspace()
        self._obs = np.zeros(OBS_DIM)
        self._inf = np.zeros(N_INFO)
        self._start: EpisodeStart | None = None
        self._trace: list[np.ndarray] = []
        self._renderer = None
        self._warned_display = False
        self._reset_failed = False   # a reset raised: no episode until one succeeds
        self._ended = False          # the episode has returned terminated or truncated
        self._warned_ended = False

    def _begin_reset(self) -> None:
        """First thing in ``reset``: the previous episode is over whether or not this reset succeeds (a reset that
        raises must not leave it running for the next ``step``)."""
        self._start = None
        self._reset_failed = True

    def _check_step_allowed(self) -> None:
        """Refuse ``step`` without an episode; warn once, as Gymnasium's CartPole does, on a step after the end."""
        if self._start is None:
            if self._reset_failed:
                raise gym.error.ResetNeeded("the last reset() raised an error, so there is no episode to step: call "
                                            "reset() again (successfully) before step()")
            raise gym.error.ResetNeeded("call reset() before step()")
        if self._ended and not self._warned_ended:
            self._warned_ended = True
            gym.logger.warn("You are calling 'step()' even though this environment has already returned terminated "
                            "= True or truncated = True. You should always call 'reset()' once you receive "
                            "'terminated = True' or 'truncated = True' -- any further steps are undefined behavior.")

    def reference_deviation(self) -> np.ndarray:
        """The episode's deviation from its true hydrostatic reference now, and the reference's slope
        (:func:`envs.core.reference_deviation`, 12 values): the truth, for a privileged policy (after ``reset``)."""
        if self._start is None:
            raise gym.error.ResetNeeded("call reset() before reference_deviation()")
        return reference_deviation(self._obs, self._ref, self.config.travel_m)

    @property
    def dt(self) -> float:
        """The control period, s (Gymnasium's convention, as MuJoCo environments' ``dt``)."""
        return self.config.dt

    def _load_start(self, start: EpisodeStart) -> None:
        """Begin an episode from a cached start (the state after the first control period)."""
        self._start = start
        self._y, self._p, self._modes = start.y.copy(), start.p.copy(), start.modes.copy()
        self._armed, self._st = start.armed.copy(), start.st.copy()
        self._ref = start.reference
        self._obs[:] = start.obs
        self._inf[:] = start.inf
        self._reset_failed = self._ended = self._warned_ended = False
        if self.render_mode is not None:
            self._trace = [self.contact_points()]
            if self.render_mode == "human":
                self.render()

    def _control_step(self, applied: np.ndarray) -> int:
        """One control period with ``applied`` (the (thrust, tip) action the physics gets); the outcome code (the
        caller's ``step`` has called :meth:`_check_step_allowed`)."""
        code = control_step(self._y, self._p, self._modes, self._armed, self._st, self._ref, applied, self._cfg,
                            self._obs, self._inf, self._ws)
        self._ended = code > 0 or self._inf[IN_TRUNC] != 0
        if self.render_mode is not None:
            self._trace.append(self.contact_points())
            if self.render_mode == "human":
                self.render()
        return code

    def render(self):
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; pass render_mode='rgb_array' or 'human'")
            return None
        if self.render_mode == "human" and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
            if not self._warned_display:
                gym.logger.warn("render_mode='human' needs a display (DISPLAY or WAYLAND_DISPLAY); none is set, so "
                                "nothing is shown. Use render_mode='rgb_array' (e.g. with RecordVideo).")
                self._warned_display = True
            return None
        if self._start is None:
            raise gym.error.ResetNeeded("call reset() before render()")
        if self._renderer is None:
            from .render import Renderer  # Pillow only when rendering
            self._renderer = Renderer(self._foundation, human=self.render_mode == "human")
        return self._renderer.draw(np.array(self._trace), self.reference_path, self._load_point(),
                                   self._st[ST_LOAD], self._st[ST_T])

    def close(self) -> None:
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None

    def contact_points(self) -> np.ndarray:
        """The three contact points (world, 3x3) now: what a rendered trace records."""
        return contact_points_of(self._y, self._p)

    def _load_point(self) -> np.ndarray:
        """Overhead (x1, x3) of the load point: where the rendering draws the tip."""
        return load_point_of(self._st[ST_T], self._y, self._p, self._modes)

    def get_state(self) -> ShearState:
        """The episode's state now (copies; after ``reset``): what a prediction starts from."""
        self._require_episode("get_state")
        return ShearState(self._y.copy(), self._p.copy(), self._modes.copy(), self._armed.copy(), self._st.copy(),
                          np.array(self._ref), self._cfg.copy())

    def set_state(self, state: ShearState) -> None:
        """Continue the episode from ``state`` (copied in; one of :meth:`get_state`'s, of an env with the same
        configuration, else a ValueError naming the field). The next ``step`` runs from it; the observation held
        until then is the last one's."""
        self._require_episode("set_state")
        if not np.array_equal(state.cfg, self._cfg):
            raise ValueError("set_state: state.cfg differs from this env's configuration (a state of another env)")
        for name in ("y", "p", "modes", "armed", "st"):
            mine, theirs = getattr(self, "_" + name), np.asarray(getattr(state, name))
            if theirs.shape != mine.shape:
                raise ValueError(f"set_state: state.{name} has shape {theirs.shape}, expected {mine.shape}")
            mine[:] = theirs
        if np.shape(state.ref) != np.shape(self._ref):
            raise ValueError(f"set_state: state.ref has shape {np.shape(state.ref)}, expected {np.shape(self._ref)}")
        self._ref = np.array(state.ref)
        self._ended = self._warned_ended = False

    def _require_episode(self, what: str) -> None:
        if self._start is None:
            raise gym.error.ResetNeeded(f"call reset() before {what}()")

    @property
    def state(self) -> np.ndarray:
        """The kernel state (layout ``triplanar.kernel.S_*``), a copy."""
        return self._y.copy()

    @property
    def reference_path(self) -> np.ndarray:
        """The episode's hydrostatic reference: (REFERENCE_POINTS, 3, 3) contact points, sampled by travel."""
        return self._st[ST_CP_REST:ST_CP_REST + 9].reshape(3, 3) + self._ref.reshape(-1, 3, 3)

    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        state["_renderer"] = None
        return state

"""``limit``: what a bench design allows, with perfect knowledge. The controller reads the env's exact state, true
specimen, bench dynamics and the true specimen's case-C reference (:func:`envs.prediction.snapshot`), and each
period replans the action sequence by the cross-entropy method over rollouts of the env's own compiled step
(:class:`agents.planner.CEMPlanner`), sending the first action. Its plans keep ``mpc``'s margin from lift-off (0.1 of
the normal load) and ``mpc``'s pace (0.3 s): with the truth neither should be needed, but the cross-entropy search
over a 120 ms horizon does not see what lies beyond it. With pace 0.5 s and no margin (the study run's ``limit``) it
failed on 1 of the 200 held-out benches of the default bench (an arrest) and on 1-2 of 50 on 9 of the 14 designs; with
the margin still on 5 designs, every failure an arrest (the block let slow until friction held it). Margin then pace
lowered its score on the default bench from 0.54 to 0.47 to 0.42 mm (``docs/actuator-study.md``): the limit is the
best plan this search finds, an upper bound on the optimum. No laboratory can build it (it sees the truth); it is the
reference a design's real controllers are judged against (``docs/actuator-study.md``).

It needs the env: :func:`agents.heldout.run_episode` hands it over through :meth:`bind` (a controller with
``needs_env = True``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from envs.core import ShearConfig
from envs.prediction import snapshot
from envs.triplanar_shear_v1 import BS_PREV

from .planner import CEMPlanner

@dataclass
class LimitController:
    """Perfect-knowledge receding-horizon control (module docstring); the planner's settings are its fields
    (``normal_margin``: :func:`envs.prediction.predict`'s lift-off margin, 0.1 of the normal load as ``mpc``'s;
    ``plane_margin_m``: its margin from leaving a plane, none: the limit knows where the planes meet)."""

    name: str = "limit"
    config: ShearConfig = field(default_factory=ShearConfig)
    load_N: float = 0.0
    horizon: int = 24
    block: int = 4
    samples: int = 32
    iterations: int = 3
    elites: int = 6
    sigma0: float = 0.3
    seed: int = 0
    pace_s: float = 0.3
    normal_margin: float = 0.1
    plane_margin_m: float = 0.0
    needs_env: bool = True
    _env: Any = None
    _planner: CEMPlanner | None = None
    decisions: list = field(default_factory=list)

    def bind(self, env: Any) -> None:
        self._env = env.unwrapped

    def reset(self, load_N: float, config: ShearConfig) -> None:
        self.config, self.load_N = config, float(load_N)
        self._planner = CEMPlanner.with_settings_of(self)
        self.decisions = []

    def act(self, obs: np.ndarray) -> np.ndarray:
        if self._env is None:
            raise RuntimeError("limit needs the env's true state: call bind(env) after env.reset (run_episode does)")
        state = snapshot(self._env)
        plan = self._planner.plan([state], [1.0], state.bs[BS_PREV:BS_PREV + 2])
        self._planner.advance(plan)
        self.decisions.append(self._planner.last_cost)
        return plan[0].astype(np.float32)

"""``limit``: what a bench design allows, with perfect knowledge. The controller reads the env's exact state, true
specimen, bench dynamics and the true specimen's case-C reference (the env's public state, ``get_state``), and each
period replans the action sequence by the cross-entropy method over rollouts of the env's own compiled step
(:class:`agents.planner.CEMPlanner`), sending the first action: horizon 48 periods (240 ms), 64 candidates x 4
iterations, thrusts within ``1 +- thrust_envelope`` (0.4) times the load level. Its plans keep ``mpc``'s margin from
lift-off (0.1 of the normal load) and ``mpc``'s pace (0.3 s): with the truth neither should be needed, but the
search does not see past its horizon. Each of these was found by a controller doing better than the ``limit`` of
its time: the margin and pace by ``mpc`` (they lowered ``limit``'s held-out score from 0.54 to 0.42 mm), the
envelope by ``mpc``'s planner given the true state (``mpc_true``, 0.33 against ``limit``'s 0.37 mm on 60 tuning
benches). With the envelope a larger search pays (0.44 to 0.24 mm on the 200 tuning benches); doubling the horizon
or the candidates beyond it moves the figure by about 0.01 mm, within the benches' noise
(``docs/notes/mpc-tuning-rounds.md``, fifth round). So the limit is the best plan this search finds: an upper bound on the
optimum, no longer falling with more search. No laboratory can build it (it sees the truth); it is the reference a
design's real controllers are judged against.

It needs the env: the episode loop (:func:`agents.controller_base.play`) hands it over through :meth:`bind` (a
controller with ``needs_env = True``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from envs.core import ShearConfig
from envs.triplanar_shear_v1 import BS_PREV

from .controller_base import Controller
from .planner import CEMPlanner


@dataclass
class LimitController(Controller):
    """Perfect-knowledge receding-horizon control (module docstring); the planner's settings are its fields
    (``normal_margin``: :func:`envs.prediction.predict`'s lift-off margin, 0.1 of the normal load as ``mpc``'s;
    ``plane_margin_m``: its margin from leaving a plane, none: the limit knows where the planes meet;
    ``thrust_envelope``: the thrusts searched, ``1 +-`` this times the load level, as ``mpc``'s; ``change_cost``: the
    planner's tie-breaking cost on changes of action, none by default; ``fev_budget``, ``decision_fev_budget``: the
    planner's work budgets, :mod:`agents.planner`, none)."""

    name: str = "limit"
    config: ShearConfig = field(default_factory=ShearConfig)
    load_N: float = 0.0
    horizon: int = 48
    block: int = 4
    samples: int = 64
    iterations: int = 4
    elites: int = 6
    sigma0: float = 0.3
    seed: int = 0
    pace_s: float = 0.3
    normal_margin: float = 0.1
    plane_margin_m: float = 0.0
    fev_budget: float = 0.0
    decision_fev_budget: float = 0.0
    change_cost: float = 0.0
    thrust_envelope: float = 0.4
    needs_env: bool = True
    _env: Any = None
    _planner: CEMPlanner | None = None
    decisions: list = field(default_factory=list)

    def bind(self, env: Any) -> None:
        self._env = env.unwrapped

    def reset(self, load_N: float, config: ShearConfig) -> None:
        self.config, self.load_N = config, float(load_N)
        self._planner = CEMPlanner.with_settings_of(self)
        self._planner.low = (-float(self.thrust_envelope), -1.0)
        self._planner.high = (float(self.thrust_envelope), 1.0)
        self.decisions = []

    def act(self, obs: np.ndarray) -> np.ndarray:
        if self._env is None:
            raise RuntimeError("limit needs the env's true state: call bind(env) after env.reset (run_episode does)")
        state = self._env.get_state()
        plan = self._planner.plan([state], [1.0], state.bs[BS_PREV:BS_PREV + 2])
        self._planner.advance(plan)
        self.decisions.append(self._planner.last_cost)
        return plan[0].astype(np.float32)

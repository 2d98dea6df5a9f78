"""The composed controller of :mod:`agents.deviation_estimator`: a reference-deviation PPO
(:class:`agents.robust_policy.DeviationPolicy`) driven on a bench estimator's deviation instead of the truth, the
controller ``estimated:FOLDER`` runs. FOLDER is an estimator folder (it names the run it feeds) or a run trained with
its estimator in the loop (``env: reference_deviation_estimator``; it names the estimator)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from envs.core import REFERENCE_DEVIATION_DIM

from .deviation_estimator import DeviationEstimator
from .robust_policy import DeviationPolicy, RobustPolicy, load_policy
from .train_config import deviation_estimator_of, estimator_state_of


class EstimatedDeviationPolicy(RobustPolicy):
    """A reference-deviation PPO driven on its estimator's deviation (module docstring): reads only the bench's
    observations (``needs_env`` False). ``estimate`` holds the last decision's estimate."""

    needs_env = False

    def __init__(self, policy: DeviationPolicy, estimator: DeviationEstimator, name: str = "ppo_deviation_estimated",
                 with_state: bool = False):
        if not isinstance(policy, DeviationPolicy):
            raise ValueError(f"policy {policy.name!r}: not a reference_deviation run (its config.json has no "
                             "env.reference_deviation), so it has no deviation input to estimate")
        super().__init__(policy.model, policy.normalizer, name, policy.n_frames)
        self.estimator = estimator
        self.estimate = np.zeros(REFERENCE_DEVIATION_DIM)
        self.policy_run = str(estimator.spec["policy_run"])   # the run it drives (load: the folder's)
        self.with_state = with_state   # the GRU's state appended after the estimate, as the run was trained

    @classmethod
    def load(cls, folder: str | Path, name: str = "ppo_deviation_estimated") -> EstimatedDeviationPolicy:
        """The estimator in ``folder`` and the policy run its spec names, or, ``folder`` being a run trained with its
        estimator in the loop (``env.reference_deviation_estimator``), that run and that estimator (UNPICKLES the
        run: load only yours). ``policy_run`` is the run's folder."""
        path = Path(folder) / "config.json"
        config = json.loads(path.read_text()) if path.exists() else {}
        loop = deviation_estimator_of(config)
        estimator = DeviationEstimator.load(loop or folder)
        run = str(folder) if loop else estimator.spec["policy_run"]
        with_state = bool(loop) and estimator_state_of(config)
        composed = cls(load_policy(run), estimator, name, with_state)
        composed.policy_run = run
        return composed

    def reset(self, load_N: float, config: Any) -> None:
        super().reset(load_N, config)
        self.estimator.reset()

    def act(self, obs: np.ndarray) -> np.ndarray:
        self.estimate = self.estimator.update(obs)
        state = [self.estimator.state] if self.with_state else []
        return self._decide(np.concatenate([self._stack(obs), self.estimate.astype(np.float32), *state]))

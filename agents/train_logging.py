"""What a training run reports, as stable-baselines3 users expect: SB3's own logger (``--verbose 1``: its table on
stdout; ``--tensorboard-log DIR``: TensorBoard), fed with the episodes' figures beside SB3's losses.

SB3 logs ``rollout/ep_rew_mean`` and ``rollout/ep_len_mean`` (from ``VecMonitor``) and ``rollout/success_rate`` (from
the episodes' ``info["is_success"]``) by itself; :func:`episode_error_callback` adds ``rollout/error_mm_mean``, the
mimicry error (mm) over the successful episodes among the last ``window`` that ended (the task's figure: the target is
1 mm), and ``rollout/success_episodes``, how many that mean pools. The evaluation curve's points go to ``eval/*``
(:func:`record_evaluation`).
"""

from __future__ import annotations

import math
from collections import deque
from typing import Any

WINDOW = 100   # episodes, as SB3's ``stats_window_size``


def episode_error_callback(window: int = WINDOW) -> Any:
    """A callback recording ``rollout/error_mm_mean`` and ``rollout/success_episodes`` at the end of each rollout."""
    from stable_baselines3.common.callbacks import BaseCallback

    class EpisodeError(BaseCallback):
        def __init__(self) -> None:
            super().__init__()
            self.errors: deque = deque(maxlen=window)   # NaN for a failed episode: the window counts episodes

        def _on_step(self) -> bool:
            for info, done in zip(self.locals["infos"], self.locals["dones"]):
                if done and "is_success" in info:
                    self.errors.append(info["mimicry_error_mm"] if info["is_success"] else math.nan)
            return True

        def _on_rollout_end(self) -> None:
            ok = [e for e in self.errors if not math.isnan(e)]
            if ok:
                self.logger.record("rollout/error_mm_mean", sum(ok) / len(ok))
            self.logger.record("rollout/success_episodes", len(ok))

    return EpisodeError()


def record_evaluation(model: Any, stats: dict[str, float]) -> None:
    """One point of the evaluation curve (``agents.heldout.summarise``'s figures) as ``eval/*``, written at once (as
    SB3's ``EvalCallback`` does); nothing for a model that has not trained in this process (no logger yet)."""
    logger = getattr(model, "_logger", None)
    if logger is None:
        return
    for key in ("success_rate", "mimicry_error_mm", "score"):
        value = stats.get(key, math.nan)
        if not math.isnan(value):
            logger.record(f"eval/{key}", value)
    logger.dump(step=model.num_timesteps)

"""A tqdm progress bar over a stable-baselines3 run's env steps (SB3's own ``progress_bar=True`` needs ``rich``, which
the project does not pin)."""

from __future__ import annotations

from typing import Any


def progress_callback(total: int, desc: str) -> Any:
    """A callback that shows a tqdm bar of ``total`` env steps named ``desc`` (a resumed run starts where it was)."""
    from stable_baselines3.common.callbacks import BaseCallback
    from tqdm import tqdm

    class Progress(BaseCallback):
        def _on_training_start(self) -> None:
            self.bar = tqdm(total=total, initial=self.model.num_timesteps, desc=desc, unit="step", unit_scale=True)

        def _on_step(self) -> bool:
            self.bar.update(self.model.num_timesteps - self.bar.n)
            return True

        def _on_training_end(self) -> None:
            self.bar.close()

    return Progress()

"""What the ideal-bench study (:mod:`experiments.study`) produces: its episodes, PPO runs, learning curves and
timings. Apart from the study's code so that the report and the plots read it without importing the study back."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from agents import EpisodeResult
from agents.trainer import TrainResult


@dataclass
class StudyResult:
    out_dir: Path
    loads: tuple[float, ...]
    episodes: list[EpisodeResult]
    ppo_runs: list[TrainResult]
    curves: dict[int, dict[str, np.ndarray]] = field(default_factory=dict)
    timings: dict[str, float] = field(default_factory=dict)

    def errors(self, controller: str) -> np.ndarray:
        """(seeds, loads) mimicry errors of ``controller``."""
        rows = [r for r in self.episodes if r.controller == controller]
        seeds = sorted({r.seed for r in rows})
        table = np.full((len(seeds), len(self.loads)), np.nan)
        for r in rows:
            table[seeds.index(r.seed), self.loads.index(r.load_N)] = r.mimicry_error_mm
        return table

    @property
    def controllers(self) -> list[str]:
        return list(dict.fromkeys(r.controller for r in self.episodes))

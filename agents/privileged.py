"""The privileged row: a bench's true unknowns, for a teacher that is given them (learning by cheating, Chen et al.
2019; rapid motor adaptation's first phase, Kumar et al. 2021) and for the labels' ``truth`` (:mod:`experiments
.distill_labels`).

:func:`bench_truth` is the row in SI-like units (degrees, metres, kilograms, newtons: :data:`TRUTH_NAMES`, the
estimator's unknowns, then the load level); :func:`privileged_row` the same row scaled to about [-1, 1] over the
ranges the training benches are drawn from (:data:`envs.triplanar_shear_v1.TRAINING_RANGES` around the env's nominal
specimen; 0 at a range's centre, +-1 at its ends; a stress bench may lie beyond). A policy trained with ``env:
privileged: true`` (:mod:`agents.train_config`) sees its frame stack followed by this row; no laboratory can run it.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from envs.triplanar_shear_v1 import TRAINING_RANGES, Bench

from .estimator import DIRECTIONS, GEOMETRY, PARAMETERS, geometry_ranges, hypothesis_of, prior_ranges

TRUTH_NAMES = PARAMETERS + GEOMETRY + DIRECTIONS + ("load_N",)


def bench_truth(bench: Bench) -> np.ndarray:
    """A bench's privileged row (:data:`TRUTH_NAMES`: its unknowns, then the load level), unscaled."""
    return np.append(hypothesis_of(bench), bench.load_N)


def truth_scale(specimen: Any, foundation: Any) -> tuple[np.ndarray, np.ndarray]:
    """(centre, half width) of each :data:`TRUTH_NAMES` entry's training range around the nominal ``specimen`` on
    ``foundation`` (``ShearConfig.base_specimen()``): the specimen's, the geometry's and the load's ranges."""
    low_p, high_p = prior_ranges(specimen)
    low_g, high_g, _ = geometry_ranges(specimen, foundation)
    low = np.concatenate([low_p, low_g, [TRAINING_RANGES.load_N[0]]])
    high = np.concatenate([high_p, high_g, [TRAINING_RANGES.load_N[1]]])
    return (low + high) / 2, (high - low) / 2


def privileged_row(bench: Bench, scale: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """``bench``'s :func:`bench_truth` scaled by ``scale`` (:func:`truth_scale`), float32."""
    centre, half = scale
    return ((bench_truth(bench) - centre) / half).astype(np.float32)

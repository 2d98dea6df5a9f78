"""The margins :mod:`experiments.post_start_diagnosis` reads from the bench's true state: the smallest normal
reaction as a share of the load, and the smallest distance of a contact point from crossing onto another plane."""

from __future__ import annotations

import numpy as np

from envs.triplanar_shear_v1 import TriPlanarShearV1Env
from experiments.post_start_diagnosis import margins


def test_the_margins_of_a_resting_block_are_a_share_of_the_load_and_a_small_plane_gap():
    env = TriPlanarShearV1Env()
    env.reset(seed=0)
    normal, plane_mm = margins(env)
    assert 0.0 < normal < 1.0                      # three contacts share the load: none carries all of it
    assert 0.0 <= plane_mm < 1.0                   # CP3 starts where the three planes meet
    for _ in range(5):
        env.step(np.array([0.3, 0.0], dtype=np.float32))
    later = margins(env)
    assert later != (normal, plane_mm) and np.isfinite(later).all()

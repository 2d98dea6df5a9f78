"""A result's rotations, contact points and contact velocities come from one compiled pass
(:func:`triplanar.result.block_paths`) that computes what the numpy expressions did, bit for bit: the quaternion's
norm, the rotation matrix, ``einsum("nij,cj->nci")`` for the turned body points, omega x arm."""

from __future__ import annotations

import numpy as np
import pytest

from triplanar import kernel as K
from triplanar.result import block_paths


def _numpy_paths(y: np.ndarray, body: np.ndarray):
    q = y[:, K.S_Q:K.S_Q + 4]
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    w, x, yy, z = (q[:, i] for i in range(4))
    rot = np.empty((len(y), 3, 3))
    rot[:, 0, 0], rot[:, 0, 1], rot[:, 0, 2] = 1 - 2 * (yy * yy + z * z), 2 * (x * yy - w * z), 2 * (x * z + w * yy)
    rot[:, 1, 0], rot[:, 1, 1], rot[:, 1, 2] = 2 * (x * yy + w * z), 1 - 2 * (x * x + z * z), 2 * (yy * z - w * x)
    rot[:, 2, 0], rot[:, 2, 1], rot[:, 2, 2] = 2 * (x * z - w * yy), 2 * (yy * z + w * x), 1 - 2 * (x * x + yy * yy)
    centre = y[:, K.S_R:K.S_R + 3]
    cps = centre[:, None, :] + np.einsum("nij,cj->nci", rot, body)
    arms = cps - centre[:, None, :]
    omega = y[:, None, K.S_W:K.S_W + 3]
    vel = y[:, None, K.S_V:K.S_V + 3] + np.cross(omega, arms)
    return rot, cps, vel


@pytest.mark.parametrize("n", [1, 2, 9, 57, 400])
def test_block_paths_are_the_numpy_expressions_bit_for_bit(n: int) -> None:
    rng = np.random.default_rng(n)
    y = rng.normal(size=(n, K.N_STATE))
    y[:, K.S_R:K.S_R + 3] *= 0.05
    body = rng.normal(size=(3, 3)) * 0.05
    for got, want, name in zip(block_paths(y, body), _numpy_paths(y, body), ("rotation", "points", "velocities")):
        assert got.shape == want.shape and got.tobytes() == want.tobytes(), name

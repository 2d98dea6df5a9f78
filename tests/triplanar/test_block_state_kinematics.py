"""What a user effect's ``wrench`` sees: ``Model.block_state`` decodes the kernel state (in one compiled call) into the
same numbers the kinematics give one by one, and ``BlockState.moment_of`` is ``np.cross`` to the bit."""

from __future__ import annotations

import numpy as np

from triplanar import kernel as K, paper_model, simulate


def test_block_state_matches_the_kinematics_one_by_one() -> None:
    for case in ("A", "C"):
        model = paper_model(case, 40.0)
        run = simulate(model)
        for i in (0, len(run.t) // 2, len(run.t) - 1):
            y = np.array(run.y[i])
            state = model.block_state(float(run.t[i]), y)
            p = model.kernel_params_cached.copy()
            rot, cps, arm = np.empty((3, 3)), np.empty((3, 3)), np.empty(3)
            K.quat_to_matrix(y[K.S_Q:K.S_Q + 4], rot)
            K.contact_points(y, p, cps)
            K.load_arm(y, p, rot, arm)
            r, v, w = y[K.S_R:K.S_R + 3], y[K.S_V:K.S_V + 3], y[K.S_W:K.S_W + 3]
            assert np.array_equal(state.rotation, rot) and np.array_equal(state.contact_points, cps)
            assert np.array_equal(state.load_point, r + arm)
            assert np.array_equal(state.contact_velocities, v + np.cross(w, cps - r))
            assert np.array_equal(state.velocity, v) and np.array_equal(state.position, r)


def test_moment_of_is_np_cross_bitwise() -> None:
    state = paper_model("A", 40.0).block_state(0.0, paper_model("A", 40.0).initial_state())
    rng = np.random.default_rng(7)
    for _ in range(200):
        force, at = rng.normal(size=3) * 50.0, rng.normal(size=3) * 0.05
        assert state.moment_of(force, at=at).tobytes() == np.cross(at - state.position, force).tobytes()

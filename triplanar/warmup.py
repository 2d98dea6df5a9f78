"""Compile every numba kernel into numba's cache ahead of use: ``python -m triplanar.warmup`` (``make install``).

Runs what a user's first commands run, small: traces (the static-equilibrium LP, the sliding threshold of a rising
actuator force, the start modes, DOPRI5; RK4 and Euler share its compiled code), a trace resampled by travel (the
cubic Hermite interpolant), a block at rest, the decoded
block state, the contact and load points a rendering draws, and, when Gymnasium is installed, one episode start
and step of each env (v0, v1, and both batched versions, v1's in both observation modes) and the model-based
controllers' prediction from a copy of v1's state (:mod:`envs.prediction`). The environments are imported only
here, in :func:`warm_envs`, the one place below the commands where the core reaches the env layer, and only
through its public API. Each compiled function lands in numba's cache
(:func:`triplanar.compiled_cache.numba_cache_dir`); with a warm cache this only loads them (a few seconds, most of
it importing torch for the vector env). Idempotent.
"""

from __future__ import annotations

import argparse
import sys
import time

from .outcome import Outcome


def warm_physics() -> None:
    """Everything ``simulate``, the statics and the workbench compile."""
    import numpy as np

    from . import kernel as K, make_effect, paper_model, simulate

    result = simulate(paper_model("A", 30.0))  # holds, start_motion, integrate_ws, the kernel
    assert result.status is Outcome.TRAVEL, result.message
    result.resample_by_travel(np.array([0.01]))  # the interpolant (triplanar.interpolate) the workbench resamples with
    from .workbench.discrepancy import discrepancy  # its compiled per-test terms (triplanar.workbench.discrepancy_kernel)
    discrepancy(result.to_measured("warm-up"), result)
    simulate(paper_model("A", 35.0, effects=[make_effect("actuator_rise:tau_s=0.05")]))  # the sliding threshold
    model = paper_model("A", 1.0)
    simulate(model)  # held: the right-hand side at rest
    model.block_state(0.0, model.initial_state()).rotation  # a user effect's state, decoded (kernel.block_kinematics)
    assert np.isfinite(result.y).all()
    # What draws a state (the envs' rendered traces): the contact points, and the load point from the right-hand side.
    y, p = model.initial_state(), model.kernel_params()
    K.contact_points(y, p, np.empty((3, 3)))
    K.rhs(0.0, y, p, K.sliding_modes(), np.empty(K.N_STATE), np.empty(K.N_AUX))


def warm_envs() -> bool:
    """The single and batched envs' compiled steps. False if Gymnasium is missing."""
    try:
        import gymnasium as gym
        import numpy as np

        from envs import v0_on_purpose  # (importing envs registers TriPlanarShear-v0 and -v1)
    except ImportError:
        return False
    with v0_on_purpose():  # its kernels are the ones to compile
        env = gym.make("TriPlanarShear-v0")
        env.reset(seed=0)
        env.step(np.zeros(2, np.float32))
        env.close()
        # v1's bench layer (envs.triplanar_shear_v1.bench_command, bench_observation), and the model-based
        # controllers' prediction from a copy of its state (envs.prediction.step_state, rollout_costs)
        from envs.prediction import warm_up as warm_prediction
        env = gym.make("TriPlanarShear-v1")
        env.reset(seed=0)
        warm_prediction(env)
        env.step(np.zeros(2, np.float32))
        env.close()
        for env_id, kwargs in (("TriPlanarShear-v0", {}), ("TriPlanarShear-v1", {}),
                               ("TriPlanarShear-v1", {"observation_mode": "state"})):
            # the batched loops (envs.vector._batch_step, envs.vector_v1._bench_batch_step, _bench_observations)
            vec = gym.make_vec(env_id, num_envs=2, vectorization_mode="vector_entry_point", **kwargs)
            vec.reset(seed=0)
            vec.step(np.zeros((2, 2), np.float32))
            vec.close()
        return True


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m triplanar.warmup", description=__doc__.splitlines()[0])
    parser.add_argument("--physics-only", action="store_true", help="skip the Gymnasium environments")
    args = parser.parse_args(argv)
    t0 = time.perf_counter()
    warm_physics()
    envs_done = False if args.physics_only else warm_envs()
    what = "physics and environment kernels" if envs_done else "physics kernels"
    print(f"triplanar: {what} ready in numba's cache ({time.perf_counter() - t0:.1f} s)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())

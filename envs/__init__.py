"""Gymnasium environments of the project. ``import envs`` registers ``TriPlanarShear-v0`` and ``-v1``:

    import gymnasium as gym
    import envs  # noqa: F401  (or gym.make("envs:TriPlanarShear-v0") without the import)

    env = gym.make("TriPlanarShear-v0", load_N=27.8)
    vec = gym.make_vec("TriPlanarShear-v0", num_envs=1024)  # the batched vector env (envs.vector)
    vec1 = gym.make_vec("TriPlanarShear-v1", num_envs=64, vectorization_mode="vector_entry_point",
                        randomize=True, frame_stack=4)      # v1 batched (envs.vector_v1)
"""

from __future__ import annotations

import warnings
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

from gymnasium.envs.registration import register, registry

from triplanar.compiled_cache import drop_if_stale, numba_cache_dir


def _drop_stale_compiled_code(cache: Path | None = None, sources: list[Path] | None = None) -> bool:
    """The env's compiled step has the kernel, its stepping, the driver and the equilibrium LP built in, and the
    vector env's loop has the single env's step built in: drop this package's numba cache whenever any of them changes
    (:func:`triplanar.compiled_cache.drop_if_stale`; returns True if it did)."""
    if sources is None:
        from triplanar import driver, equilibrium, kernel, layout, outcome, stepping  # importing compiles nothing
        sources = [Path(module.__file__) for module in (kernel, stepping, equilibrium, driver, outcome, layout)]
        sources += [Path(__file__).parent / name for name in ("core.py", "triplanar_shear_v1.py")]
    cache = cache if cache is not None else numba_cache_dir(Path(__file__).parent / "core.py")
    return drop_if_stale(cache, "*.nb[ic]", sources, "kernel.sha256")


_drop_stale_compiled_code()

from .triplanar_shear import ShearConfig, TriPlanarShearEnv  # after the stale cache is dropped

ENV_ID = "TriPlanarShear-v0"

if ENV_ID not in registry:
    register(id=ENV_ID, entry_point="envs.triplanar_shear:TriPlanarShearEnv",
             vector_entry_point="envs.vector:TriPlanarShearVectorEnv")

__all__ = ["ENV_ID", "ShearConfig", "TriPlanarShearEnv", "V0_OUT_OF_DATE", "v0_on_purpose"]

# Gymnasium's notice on making TriPlanarShear-v0 now that v1 exists (its convention for an older version).
V0_OUT_OF_DATE = r".*TriPlanarShear-v0 is out of date"


@contextmanager
def v0_on_purpose() -> Iterator[None]:
    """Make ``TriPlanarShear-v0`` inside this without Gymnasium's out-of-date notice: the project's own commands,
    warm-up and benchmarks make v0 on purpose (its kernels, its fingerprint), so the notice would only be noise there.
    A user's own ``gym.make("TriPlanarShear-v0")`` still shows it."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=V0_OUT_OF_DATE, category=DeprecationWarning)
        yield

V1_ID = "TriPlanarShear-v1"
if V1_ID not in registry:  # truncated by the env itself at time_limit_s (no max_episode_steps: one mechanism)
    register(id=V1_ID, entry_point="envs.triplanar_shear_v1:TriPlanarShearV1Env",
             vector_entry_point="envs.vector_v1:TriPlanarShearV1VectorEnv")

"""Gymnasium environments of the project: two tasks, the ideal bench (``TriPlanarShearIdeal-v0``, first published
as ``TriPlanarShear-v0``) and the realistic bench (``TriPlanarShearRealistic-v0``, first published as
``TriPlanarShear-v1``). ``import triplanar`` (which ``import envs`` does too) registers every id
(:mod:`triplanar.gym_registration`):

    import gymnasium as gym
    env = gym.make("triplanar:TriPlanarShearIdeal-v0", load_N=27.8)
    vec = gym.make_vec("triplanar:TriPlanarShearIdeal-v0", num_envs=1024)  # the batched vector env (envs.vector)
    vec1 = gym.make_vec("triplanar:TriPlanarShearRealistic-v0", num_envs=64, vectorization_mode="vector_entry_point",
                        randomize=True, frame_stack=4)                      # the realistic bench batched (envs.vector_v1)
"""

from __future__ import annotations

import warnings
from contextlib import contextmanager
from pathlib import Path
from typing import Iterator

from triplanar.compiled_cache import drop_if_stale, numba_cache_dir
from triplanar.gym_registration import IDEAL_ID, REALISTIC_ID, register_envs


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
V1_ID = "TriPlanarShear-v1"
register_envs()  # (``triplanar`` registers them when Gymnasium loads; here Gymnasium is loaded, so now)

__all__ = ["ENV_ID", "V1_ID", "IDEAL_ID", "REALISTIC_ID", "ShearConfig", "TriPlanarShearEnv", "V0_OUT_OF_DATE",
           "v0_on_purpose"]

# Gymnasium's notice on making TriPlanarShear-v0 now that TriPlanarShear-v1 exists (two versions of one name, to
# Gymnasium; two tasks in truth: TriPlanarShearIdeal-v0, the same env, gets no notice).
V0_OUT_OF_DATE = r".*TriPlanarShear-v0 is out of date"


@contextmanager
def v0_on_purpose() -> Iterator[None]:
    """Make ``TriPlanarShear-v0`` inside this without Gymnasium's out-of-date notice: the project's own commands,
    warm-up and benchmarks make v0 on purpose (its kernels, its fingerprint), so the notice would only be noise there.
    A user's own ``gym.make("TriPlanarShear-v0")`` still shows it."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=V0_OUT_OF_DATE, category=DeprecationWarning)
        yield

"""Gymnasium environments of the project. ``import envs`` registers ``TriPlanarShear-v0``:

    import gymnasium as gym
    import envs  # noqa: F401  (or gym.make("envs:TriPlanarShear-v0") without the import)

    env = gym.make("TriPlanarShear-v0", load_N=27.8)
    vec = gym.make_vec("TriPlanarShear-v0", num_envs=1024)  # the batched vector env (envs.vector)
"""

from __future__ import annotations

import hashlib
from pathlib import Path

from gymnasium.envs.registration import register, registry


def _drop_stale_compiled_code(cache: Path | None = None, kernel_file: Path | None = None) -> bool:
    """numba keys its on-disk cache on each function's own source file only, so the env's compiled step would keep
    an old kernel built in after ``triplanar/kernel.py`` changes. Drop that cache whenever the kernel differs
    (returns True if it did)."""
    if kernel_file is None:
        from triplanar import kernel  # importing compiles nothing
        kernel_file = Path(kernel.__file__)
    digest = hashlib.sha256(Path(kernel_file).read_bytes()).hexdigest()
    cache = cache if cache is not None else Path(__file__).parent / "__pycache__"
    stamp = cache / "kernel.sha256"
    try:
        if stamp.exists() and stamp.read_text() == digest:
            return False
        for path in cache.glob("*.nb[ic]"):
            path.unlink(missing_ok=True)
        cache.mkdir(exist_ok=True)
        stamp.write_text(digest)
    except OSError:  # read-only install: numba then does not cache here either
        pass
    return True


_drop_stale_compiled_code()

from .triplanar_shear import ShearConfig, TriPlanarShearEnv  # noqa: E402

ENV_ID = "TriPlanarShear-v0"

if ENV_ID not in registry:
    register(id=ENV_ID, entry_point="envs.triplanar_shear:TriPlanarShearEnv",
             vector_entry_point="envs.vector:TriPlanarShearVectorEnv")

__all__ = ["ENV_ID", "ShearConfig", "TriPlanarShearEnv"]

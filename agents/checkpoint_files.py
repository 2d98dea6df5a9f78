"""A training checkpoint's side files, in data formats that cannot run code: the normalisation statistics
(``VecNormalize``'s running means and variances and its settings) as ``.npz`` read with ``allow_pickle=False``,
stamped with the step count and the token of the invocation that wrote them.

The token is how a run knows a checkpoint is its own: ``triplanar train`` without ``--out`` or ``--resume`` resumes
(after a worker died and was retried) only from checkpoints carrying the token this invocation drew, never from
what an earlier run, or someone else, left at the default path. The SB3 model zip beside the statistics is still
read by SB3 (which unpickles parts of it): it is loaded only from a run the user named or that this invocation wrote.
"""

from __future__ import annotations

import secrets
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from triplanar.atomic import write_atomic

_SETTINGS = ("clip_obs", "clip_reward", "gamma", "epsilon")
_FLAGS = ("norm_obs", "norm_reward")


class CheckpointError(ValueError):
    """A checkpoint that does not load or does not belong with the rest of its set (the message names the file)."""


def new_token() -> str:
    """A token for one invocation's checkpoints."""
    return secrets.token_hex(8)


def save_normalizer(path: str | Path, venv: Any, timesteps: int, token: str = "") -> None:
    """``venv``'s (a ``VecNormalize``) statistics and settings at ``path`` (``.npz``), written whole."""
    arrays = {"obs_mean": np.asarray(venv.obs_rms.mean, dtype=np.float64),
              "obs_var": np.asarray(venv.obs_rms.var, dtype=np.float64),
              "obs_count": np.float64(venv.obs_rms.count),
              "ret_mean": np.asarray(venv.ret_rms.mean, dtype=np.float64),
              "ret_var": np.asarray(venv.ret_rms.var, dtype=np.float64),
              "ret_count": np.float64(venv.ret_rms.count),
              "timesteps": np.int64(timesteps), "token": np.str_(token),
              **{k: np.float64(getattr(venv, k)) for k in _SETTINGS},
              **{k: np.bool_(getattr(venv, k)) for k in _FLAGS}}

    def write(tmp: Path) -> None:
        with open(tmp, "wb") as f:
            np.savez(f, **arrays)

    write_atomic(path, write)


def read_normalizer(path: str | Path) -> dict[str, Any]:
    """The statistics :func:`save_normalizer` wrote (:class:`CheckpointError` naming the file if it is not one)."""
    keys = ("obs_mean", "obs_var", "obs_count", "ret_mean", "ret_var", "ret_count", "timesteps", "token",
            *_SETTINGS, *_FLAGS)
    try:
        with np.load(path, allow_pickle=False) as npz:
            data = {k: npz[k] for k in keys}
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as err:
        raise CheckpointError(f"{path}: not a normalisation-statistics file ({type(err).__name__}: {err})") from None
    if data["obs_mean"].shape != data["obs_var"].shape or not all(
            np.all(np.isfinite(data[k])) for k in ("obs_mean", "obs_var", "ret_mean", "ret_var", *_SETTINGS)):
        raise CheckpointError(f"{path}: statistics of mismatched shapes or not finite")
    return data


def load_normalizer(path: str | Path, venv: Any, timesteps: int | None = None) -> Any:
    """A training ``VecNormalize`` over ``venv`` with the statistics at ``path``; with ``timesteps``, refused unless
    they were saved at that step count (the model and its statistics are one set)."""
    from stable_baselines3.common.vec_env import VecNormalize
    data = read_normalizer(path)
    if timesteps is not None and int(data["timesteps"]) != int(timesteps):
        raise CheckpointError(f"{path}: statistics of step {int(data['timesteps'])}, the model is at step {timesteps}")
    normalizer = VecNormalize(venv, **{k: float(data[k]) for k in _SETTINGS}, **{k: bool(data[k]) for k in _FLAGS})
    if normalizer.obs_rms.mean.shape != data["obs_mean"].shape:
        raise CheckpointError(f"{path}: statistics of {data['obs_mean'].shape} observations, the env has "
                              f"{normalizer.obs_rms.mean.shape}")
    normalizer.obs_rms.mean, normalizer.obs_rms.var = data["obs_mean"].copy(), data["obs_var"].copy()
    normalizer.obs_rms.count = float(data["obs_count"])
    normalizer.ret_rms.mean, normalizer.ret_rms.var = data["ret_mean"].copy(), data["ret_var"].copy()
    normalizer.ret_rms.count = float(data["ret_count"])
    return normalizer


def token_of(path: str | Path) -> str:
    """The token in a statistics file ("" if it does not read)."""
    try:
        return str(read_normalizer(path)["token"])
    except CheckpointError:
        return ""


def leftovers(run_dir: str | Path) -> list[Path]:
    """What a run directory holds that a resume would load: its checkpoints (v0 ``checkpoints/``, v1 ``checkpoint/``)."""
    run_dir = Path(run_dir)
    return sorted(p for folder in ("checkpoint", "checkpoints") if (run_dir / folder).is_dir()
                  for p in (run_dir / folder).iterdir())

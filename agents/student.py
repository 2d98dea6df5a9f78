"""A student of ``mpc``: a small network that maps the last few bench observations to ``mpc``'s action
(behaviour cloning and DAgger on the labels of :mod:`experiments.distill_labels`; trained by
:mod:`experiments.train_student`), run as a bench controller (``reset(load_N, config)``, ``act(obs)``).

A student is two files in one folder, neither of which can hold code: ``student.safetensors`` (the weights and the
observation normalisation, float32 tensors) and ``student.json`` (its layout: frames, layer sizes, the names of the
auxiliary head's outputs, the env it was trained on, the SHA-256 of the weights file, and the training record). The
network is evaluated here with numpy (no torch at run time: a decision is a few small matrix products):

    x = (frames of obs, oldest first, padded with the episode's first) ; z = (x - obs_mean) / obs_std
    h = tanh(W_k h + b_k) for each hidden layer ; action = tanh(W_action h + b_action)
    aux = W_aux h + b_aux, then * aux_std + aux_mean  (the student's guess of the unknowns: :attr:`estimate`)
"""

from __future__ import annotations

import hashlib
import json
from collections import deque
from pathlib import Path
from typing import Any

import numpy as np

from envs.triplanar_shear_v1 import BENCH_OBSERVATION

from .controller_base import Controller

WEIGHTS = "student.safetensors"
SPEC = "student.json"
FORMAT = 1
OBS_SIZE = BENCH_OBSERVATION.size   # the 15 bench observations
ACTION_SIZE = 2


class StudentFileError(ValueError):
    """A student folder that does not load (the message names the file and the field)."""


def tensor_shapes(spec: dict[str, Any]) -> dict[str, tuple[int, ...]]:
    """Every tensor a student of layout ``spec`` holds, with its shape (the loader accepts exactly these)."""
    n_in = int(spec["frames"]) * OBS_SIZE
    shapes: dict[str, tuple[int, ...]] = {"obs_mean": (n_in,), "obs_std": (n_in,)}
    width = n_in
    for k, size in enumerate(spec["hidden"]):
        shapes[f"hidden{k}.weight"], shapes[f"hidden{k}.bias"] = (size, width), (size,)
        width = size
    shapes["action.weight"], shapes["action.bias"] = (ACTION_SIZE, width), (ACTION_SIZE,)
    n_aux = len(spec["aux_names"])
    if n_aux:
        shapes["aux.weight"], shapes["aux.bias"] = (n_aux, width), (n_aux,)
        shapes["aux_mean"], shapes["aux_std"] = (n_aux,), (n_aux,)
    return shapes


def _positive_int(value: Any, limit: int) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and 0 < value <= limit


def check_spec(spec: Any, source: str) -> dict[str, Any]:
    """``student.json``'s content, checked (refused naming the field)."""
    if not isinstance(spec, dict):
        raise StudentFileError(f"{source}: not a JSON object")
    if spec.get("format") != FORMAT:
        raise StudentFileError(f"{source}: field 'format' must be {FORMAT}, got {spec.get('format')!r}")
    if not _positive_int(spec.get("frames"), 64):
        raise StudentFileError(f"{source}: field 'frames' must be an integer 1-64, got {spec.get('frames')!r}")
    hidden = spec.get("hidden")
    if not (isinstance(hidden, list) and 0 < len(hidden) <= 8 and all(_positive_int(h, 4096) for h in hidden)):
        raise StudentFileError(f"{source}: field 'hidden' must be 1-8 layer sizes of 1-4096, got {hidden!r}")
    aux = spec.get("aux_names")
    if not (isinstance(aux, list) and all(isinstance(a, str) for a in aux)):
        raise StudentFileError(f"{source}: field 'aux_names' must be a list of names, got {aux!r}")
    if not isinstance(spec.get("env_kwargs"), dict):
        raise StudentFileError(f"{source}: field 'env_kwargs' must be an object, got {spec.get('env_kwargs')!r}")
    digest = spec.get("weights_sha256")
    if not (isinstance(digest, str) and len(digest) == 64):
        raise StudentFileError(f"{source}: field 'weights_sha256' must be a SHA-256 (64 hex digits)")
    return spec


def read_student(folder: str | Path) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """(spec, tensors) of the student in ``folder``: the spec checked, the weights file's SHA-256 the spec's, and
    exactly the tensors of the spec's layout, finite, float32 (refused naming the file and field otherwise)."""
    from safetensors import SafetensorError
    from safetensors.numpy import load as load_tensors
    folder = Path(folder)
    spec_path, weights_path = folder / SPEC, folder / WEIGHTS
    try:
        spec = check_spec(json.loads(spec_path.read_text()), str(spec_path))
        data = weights_path.read_bytes()
    except OSError as err:
        raise StudentFileError(f"{err.filename}: cannot read ({err.strerror})") from None
    except ValueError as err:
        if isinstance(err, StudentFileError):
            raise
        raise StudentFileError(f"{spec_path}: not JSON ({err})") from None
    if hashlib.sha256(data).hexdigest() != spec["weights_sha256"]:
        raise StudentFileError(f"{weights_path}: SHA-256 differs from {SPEC}'s 'weights_sha256' (not this "
                               "student's weights)")
    try:
        tensors = load_tensors(data)
    except (SafetensorError, ValueError) as err:
        raise StudentFileError(f"{weights_path}: not a safetensors file ({err})") from None
    expected = tensor_shapes(spec)
    if set(tensors) != set(expected):
        raise StudentFileError(f"{weights_path}: tensors {sorted(set(tensors) ^ set(expected))} missing or "
                               f"unexpected for the layout of {SPEC}")
    for key, shape in expected.items():
        t = tensors[key]
        if t.shape != shape or t.dtype != np.float32 or not np.all(np.isfinite(t)):
            raise StudentFileError(f"{weights_path}: tensor {key!r} must be finite float32 of shape {shape}, got "
                                   f"{t.dtype} {t.shape}")
    if np.any(tensors["obs_std"] <= 0) or ("aux_std" in tensors and np.any(tensors["aux_std"] <= 0)):
        raise StudentFileError(f"{weights_path}: tensors 'obs_std' and 'aux_std' must be > 0")
    return spec, tensors


class StudentController(Controller):
    """A student as a bench controller (module docstring). ``estimate`` holds the auxiliary head's last output
    (the unknowns it was trained to infer, ``aux_names``), empty without one."""

    needs_env = False

    def __init__(self, spec: dict[str, Any], tensors: dict[str, np.ndarray], name: str = "student"):
        self.spec, self.name = spec, name
        self.n_frames = int(spec["frames"])
        self.env_kwargs: dict[str, Any] = dict(spec["env_kwargs"])
        self.aux_names: list[str] = list(spec["aux_names"])
        self._mean, self._scale = tensors["obs_mean"], (1.0 / tensors["obs_std"]).astype(np.float32)
        self._hidden = [(tensors[f"hidden{k}.weight"], tensors[f"hidden{k}.bias"]) for k in range(len(spec["hidden"]))]
        self._action = (tensors["action.weight"], tensors["action.bias"])
        self._aux = (tensors["aux.weight"], tensors["aux.bias"], tensors["aux_mean"], tensors["aux_std"]) \
            if self.aux_names else None
        self.frames: deque = deque(maxlen=self.n_frames)
        self.estimate = np.zeros(0)

    @classmethod
    def load(cls, folder: str | Path, name: str = "student") -> StudentController:
        spec, tensors = read_student(folder)
        return cls(spec, tensors, name)

    def reset(self, load_N: float, config: Any) -> None:
        self.frames.clear()
        self.estimate = np.zeros(0)

    def features(self, obs: np.ndarray) -> np.ndarray:
        """The normalised frame stack after ``obs`` (the stack advanced by one observation)."""
        obs = np.asarray(obs, dtype=np.float32)
        if obs.shape != (OBS_SIZE,):
            raise ValueError(f"a student reads the {OBS_SIZE} bench observations, got shape {obs.shape}")
        if not self.frames:
            self.frames.extend([obs] * self.n_frames)
        else:
            self.frames.append(obs)
        return (np.concatenate(self.frames) - self._mean) * self._scale

    def act(self, obs: np.ndarray) -> np.ndarray:
        h = self.features(obs)
        for weight, bias in self._hidden:
            h = np.tanh(weight @ h + bias)
        if self._aux is not None:
            weight, bias, mean, std = self._aux
            self.estimate = (weight @ h + bias) * std + mean
        weight, bias = self._action
        return np.tanh(weight @ h + bias).astype(np.float32)

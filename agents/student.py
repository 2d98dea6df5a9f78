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

Two optional layout fields (absent in the first students, which load as before):

* ``"kind": "gru"`` (default ``"mlp"``): a recurrent student that reads the whole episode. A gated recurrent unit of
  ``"gru"`` cells (torch's ``nn.GRU`` equations, gates in the order reset, update, new) carries ``g`` from one
  decision to the next, from zero at the reset; the hidden layers read ``g`` instead of ``z``:
  ``r, u = sigmoid(W_ih z + b_ih + W_hh g + b_hh)`` (first two thirds), ``n = tanh(W_in z + b_in + r * (W_hn g +
  b_hn))``, ``g = (1 - u) * n + u * g``.
* ``"given_names"``: inputs appended after the frame stack (normalised with it: ``obs_mean`` and ``obs_std`` cover
  them), which the bench's observations do not hold: the bench's unknowns (``experiments.train_student --given
  truth``: the true ones, a privileged upper bound). Whoever runs the student sets :attr:`StudentController.given`
  (their values, in this order) before each decision.
* ``"start"``: actions played, in order, for the episode's first decisions instead of the network's (``mpc``'s
  designed excitation, :meth:`agents.mpc.MPCController.start_command`: the first decisions' right action depends
  on what the bench's sensors cannot yet tell, docs/notes/student-experiments.md); the network still reads them.
"""

from __future__ import annotations

from collections import deque
from pathlib import Path
from typing import Any

import numpy as np

from envs.triplanar_shear_v1 import BENCH_OBSERVATION

from .controller_base import Controller
from .numpy_networks import gru_step, read_network

WEIGHTS = "student.safetensors"
SPEC = "student.json"
FORMAT = 1
OBS_SIZE = BENCH_OBSERVATION.size   # the 15 bench observations
ACTION_SIZE = 2
KINDS = ("mlp", "gru")


class StudentFileError(ValueError):
    """A student folder that does not load (the message names the file and the field)."""


def tensor_shapes(spec: dict[str, Any]) -> dict[str, tuple[int, ...]]:
    """Every tensor a student of layout ``spec`` holds, with its shape (the loader accepts exactly these)."""
    n_in = int(spec["frames"]) * OBS_SIZE + len(spec.get("given_names", []))
    shapes: dict[str, tuple[int, ...]] = {"obs_mean": (n_in,), "obs_std": (n_in,)}
    width = n_in
    if spec.get("kind", "mlp") == "gru":
        cells = int(spec["gru"])
        shapes.update({"gru.weight_ih": (3 * cells, n_in), "gru.weight_hh": (3 * cells, cells),
                       "gru.bias_ih": (3 * cells,), "gru.bias_hh": (3 * cells,)})
        width = cells
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
    kind = spec.get("kind", "mlp")
    if kind not in KINDS:
        raise StudentFileError(f"{source}: field 'kind' must be one of {KINDS}, got {kind!r}")
    if kind == "gru" and not _positive_int(spec.get("gru"), 4096):
        raise StudentFileError(f"{source}: field 'gru' must be the number of cells, 1-4096, got {spec.get('gru')!r}")
    start = spec.get("start", [])
    if not (isinstance(start, list) and len(start) <= 1000 and all(
            isinstance(a, list) and len(a) == ACTION_SIZE and all(
                isinstance(v, (int, float)) and not isinstance(v, bool) and -1.0 <= v <= 1.0 for v in a)
            for a in start)):
        raise StudentFileError(f"{source}: field 'start' must be a list of actions [thrust, offset] within -1..1, "
                               f"got {start!r}")
    given = spec.get("given_names", [])
    if not (isinstance(given, list) and len(given) <= 64 and all(isinstance(a, str) for a in given)):
        raise StudentFileError(f"{source}: field 'given_names' must be a list of at most 64 names, got {given!r}")
    if given and kind != "mlp":
        raise StudentFileError(f"{source}: field 'given_names' needs kind 'mlp', got {kind!r}")
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
    spec, tensors = read_network(folder, SPEC, WEIGHTS, check_spec, tensor_shapes, StudentFileError, "student")
    if np.any(tensors["obs_std"] <= 0) or ("aux_std" in tensors and np.any(tensors["aux_std"] <= 0)):
        raise StudentFileError(f"{Path(folder) / WEIGHTS}: tensors 'obs_std' and 'aux_std' must be > 0")
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
        self.given_names: list[str] = list(spec.get("given_names", []))
        self.given: np.ndarray | None = None   # the given_names' values (set by whoever runs the student)
        self._mean, self._scale = tensors["obs_mean"], (1.0 / tensors["obs_std"]).astype(np.float32)
        self._hidden = [(tensors[f"hidden{k}.weight"], tensors[f"hidden{k}.bias"]) for k in range(len(spec["hidden"]))]
        self._action = (tensors["action.weight"], tensors["action.bias"])
        self._aux = (tensors["aux.weight"], tensors["aux.bias"], tensors["aux_mean"], tensors["aux_std"]) \
            if self.aux_names else None
        self.frames: deque = deque(maxlen=self.n_frames)
        self.estimate = np.zeros(0)
        self.start = [np.asarray(a, dtype=np.float32) for a in spec.get("start", [])]
        self._gru = None
        if spec.get("kind", "mlp") == "gru":
            self._gru = tuple(tensors[f"gru.{k}"] for k in ("weight_ih", "bias_ih", "weight_hh", "bias_hh"))
        self._g = np.zeros(int(spec.get("gru", 0)), dtype=np.float32)
        self._decisions = 0

    @classmethod
    def load(cls, folder: str | Path, name: str = "student") -> StudentController:
        spec, tensors = read_student(folder)
        return cls(spec, tensors, name)

    def reset(self, load_N: float, config: Any) -> None:
        self.frames.clear()
        self.estimate = np.zeros(0)
        self._g = np.zeros_like(self._g)
        self._decisions = 0

    def features(self, obs: np.ndarray) -> np.ndarray:
        """The normalised frame stack after ``obs`` (the stack advanced by one observation)."""
        obs = np.asarray(obs, dtype=np.float32)
        if obs.shape != (OBS_SIZE,):
            raise ValueError(f"a student reads the {OBS_SIZE} bench observations, got shape {obs.shape}")
        if not self.frames:
            self.frames.extend([obs] * self.n_frames)
        else:
            self.frames.append(obs)
        if not self.given_names:
            return self.normalised(np.concatenate(self.frames))
        given = None if self.given is None else np.asarray(self.given, dtype=np.float32)
        if given is None or given.shape != (len(self.given_names),):
            raise ValueError(f"this student reads {len(self.given_names)} given inputs ({self.given_names}) beside "
                             f"the observations: set its 'given' first, got {None if given is None else given.shape}")
        return self.normalised(np.concatenate([*self.frames, given]))

    def normalised(self, stacks: np.ndarray) -> np.ndarray:
        """Frame stacks (one per row, or one) normalised as the network reads them: ``(x - obs_mean) / obs_std``."""
        return (stacks - self._mean) * self._scale

    def _recur(self, z: np.ndarray) -> np.ndarray:
        """The GRU's state after input ``z`` (module docstring; torch's gate order: reset, update, new)."""
        self._g = gru_step(self._gru, self._g, z)
        return self._g

    def act(self, obs: np.ndarray) -> np.ndarray:
        action = self.network(obs)
        self._decisions += 1
        if self._decisions <= len(self.start):
            return self.start[self._decisions - 1].copy()
        return action

    def network(self, obs: np.ndarray) -> np.ndarray:
        """The network's action after ``obs`` (its state advanced: the frame stack, the GRU's)."""
        h = self.features(obs)
        if self._gru is not None:
            h = self._recur(h)
        for weight, bias in self._hidden:
            h = np.tanh(weight @ h + bias)
        if self._aux is not None:
            weight, bias, mean, std = self._aux
            self.estimate = (weight @ h + bias) * std + mean
        weight, bias = self._action
        return np.tanh(weight @ h + bias).astype(np.float32)

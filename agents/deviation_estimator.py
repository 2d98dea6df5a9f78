"""A bench estimate of the reference deviation (:func:`envs.core.reference_deviation`: the block's deviation from
its true case-C reference and the reference's slope, privileged) from the bench's observations alone, and the
composed controller that drives a reference-deviation PPO (:class:`agents.robust_policy.DeviationPolicy`) on it
(:class:`agents.estimated_policy.EstimatedDeviationPolicy`; this module stays free of the policies, so that the
training batch, :class:`agents.sb3_vec_env.DeviationSB3VecEnv`, can run the estimator in the loop):
the adaptation module of rapid motor adaptation (Kumar et al. 2021), trained by supervised learning on the
teacher's own rollouts (:mod:`experiments.deviation_estimator`).

An estimator is two files in one folder, neither of which can hold code: ``estimator.safetensors`` (float32 weights
and normalisations) and ``estimator.json`` (its layout, the policy run it feeds, the SHA-256 of the weights file, the
training record). It is evaluated here with numpy, O(1) per decision: a gated recurrent unit (torch's ``nn.GRU``
equations, gates in the order reset, update, new) reads each new bench observation, normalised, from a zero state
at the reset; a tanh layer and a linear head map its state to the ``targets`` columns of the 12 deviation values,
de-normalised; the ``fixed`` columns (zero or one by construction: CP1's x deviation and slope, the travel being
CP1's x displacement) are set to their constants.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from envs.core import REFERENCE_DEVIATION_DIM
from envs.triplanar_shear_v1 import BENCH_OBSERVATION

from .numpy_networks import gru_step, read_network

WEIGHTS = "estimator.safetensors"
SPEC = "estimator.json"
FORMAT = 1
OBS_SIZE = BENCH_OBSERVATION.size


class EstimatorFileError(ValueError):
    """An estimator folder that does not load (the message names the file and the field)."""


def tensor_shapes(spec: dict[str, Any]) -> dict[str, tuple[int, ...]]:
    """Every tensor an estimator of layout ``spec`` holds, with its shape."""
    cells, hidden, n_out = int(spec["gru"]), int(spec["hidden"]), len(spec["targets"])
    return {"in_mean": (OBS_SIZE,), "in_std": (OBS_SIZE,), "gru.weight_ih": (3 * cells, OBS_SIZE),
            "gru.weight_hh": (3 * cells, cells), "gru.bias_ih": (3 * cells,), "gru.bias_hh": (3 * cells,),
            "hidden.weight": (hidden, cells), "hidden.bias": (hidden,), "head.weight": (n_out, hidden),
            "head.bias": (n_out,), "out_mean": (n_out,), "out_std": (n_out,)}


def check_spec(spec: Any, source: str) -> dict[str, Any]:
    """``estimator.json``'s content, checked (refused naming the field)."""
    if not isinstance(spec, dict) or spec.get("format") != FORMAT:
        raise EstimatorFileError(f"{source}: field 'format' must be {FORMAT}")
    for field in ("gru", "hidden"):
        value = spec.get(field)
        if not (isinstance(value, int) and 0 < value <= 1024):
            raise EstimatorFileError(f"{source}: field {field!r} must be an integer 1-1024, got {value!r}")
    targets, fixed = spec.get("targets"), spec.get("fixed")
    if not (isinstance(targets, list) and isinstance(fixed, dict)
            and sorted(targets + [int(k) for k in fixed]) == list(range(REFERENCE_DEVIATION_DIM))):
        raise EstimatorFileError(f"{source}: fields 'targets' and 'fixed' must split the {REFERENCE_DEVIATION_DIM} "
                                 f"deviation columns, got {targets!r} and {fixed!r}")
    if not isinstance(spec.get("policy_run"), str):
        raise EstimatorFileError(f"{source}: field 'policy_run' must be the reference-deviation run's folder")
    if not (isinstance(spec.get("weights_sha256"), str) and len(spec["weights_sha256"]) == 64):
        raise EstimatorFileError(f"{source}: field 'weights_sha256' must be a SHA-256 (64 hex digits)")
    return spec


def read_estimator(folder: str | Path) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """(spec, tensors) of the estimator in ``folder``, checked: the weights file's SHA-256 the spec's, exactly the
    layout's tensors, finite float32."""
    return read_network(folder, SPEC, WEIGHTS, check_spec, tensor_shapes, EstimatorFileError, "estimator")


class DeviationEstimator:
    """The run-time estimator (module docstring): :meth:`reset` at each episode's start, :meth:`update` with each
    new bench observation returns the 12 estimated deviation values."""

    def __init__(self, spec: dict[str, Any], tensors: dict[str, np.ndarray]):
        self.spec = spec
        self._mean, self._scale = tensors["in_mean"], (1.0 / tensors["in_std"]).astype(np.float32)
        self._gru = tuple(tensors[f"gru.{k}"] for k in ("weight_ih", "bias_ih", "weight_hh", "bias_hh"))
        self._hidden = (tensors["hidden.weight"], tensors["hidden.bias"])
        self._head = (tensors["head.weight"], tensors["head.bias"], tensors["out_mean"], tensors["out_std"])
        self._targets = np.asarray(spec["targets"], dtype=np.int64)
        self._fixed = np.zeros(REFERENCE_DEVIATION_DIM)
        for column, value in spec["fixed"].items():
            self._fixed[int(column)] = float(value)
        self._g = np.zeros(int(spec["gru"]), dtype=np.float32)

    @classmethod
    def load(cls, folder: str | Path) -> DeviationEstimator:
        return cls(*read_estimator(folder))

    def reset(self) -> None:
        self._g = np.zeros_like(self._g)

    @property
    def state(self) -> np.ndarray:
        """The GRU's state after the last observation (a copy): what it keeps of the history, an input a policy
        may read beside the estimate (``env: reference_deviation_estimator_state``)."""
        return self._g.copy()

    def update(self, obs: np.ndarray) -> np.ndarray:
        """The estimate after ``obs`` (the GRU's state advanced by it)."""
        z = (np.asarray(obs, dtype=np.float32) - self._mean) * self._scale
        self._g = gru_step(self._gru, self._g, z)
        h = np.tanh(self._hidden[0] @ self._g + self._hidden[1])
        weight, bias, mean, std = self._head
        out = self._fixed.copy()
        out[self._targets] = (weight @ h + bias) * std + mean
        return out

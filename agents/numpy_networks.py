"""Small networks stored as data and run with numpy: a folder holds a JSON spec (the layout, the SHA-256 of the
weights file) and a safetensors file of float32 tensors, neither of which can hold code. Read by
:func:`read_network` (the student, :mod:`agents.student`; the deviation estimator, :mod:`agents.deviation_estimator`),
run one step at a time (:func:`gru_step`)."""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any, Callable

import numpy as np


def read_network(folder: str | Path, spec_name: str, weights_name: str, check_spec: Callable[[Any, str], dict],
                 tensor_shapes: Callable[[dict], dict[str, tuple[int, ...]]], error: type[ValueError],
                 what: str) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """(spec, tensors) of the network in ``folder``: ``spec_name`` checked by ``check_spec(spec, source)``, the
    weights file's SHA-256 the spec's ``weights_sha256``, and exactly the tensors of ``tensor_shapes(spec)``, finite,
    float32; refused otherwise by ``error`` naming the file and field (``what``: the kind of network, in the
    message)."""
    from safetensors import SafetensorError
    from safetensors.numpy import load as load_tensors
    folder = Path(folder)
    spec_path, weights_path = folder / spec_name, folder / weights_name
    try:
        spec = check_spec(json.loads(spec_path.read_text()), str(spec_path))
        data = weights_path.read_bytes()
    except OSError as err:
        raise error(f"{err.filename}: cannot read ({err.strerror})") from None
    except ValueError as err:
        if isinstance(err, error):
            raise
        raise error(f"{spec_path}: not JSON ({err})") from None
    if hashlib.sha256(data).hexdigest() != spec["weights_sha256"]:
        raise error(f"{weights_path}: SHA-256 differs from {spec_name}'s 'weights_sha256' (not this {what}'s weights)")
    try:
        tensors = load_tensors(data)
    except (SafetensorError, ValueError) as err:
        raise error(f"{weights_path}: not a safetensors file ({err})") from None
    expected = tensor_shapes(spec)
    if set(tensors) != set(expected):
        raise error(f"{weights_path}: tensors {sorted(set(tensors) ^ set(expected))} missing or unexpected for the "
                    f"layout of {spec_name}")
    for key, shape in expected.items():
        t = tensors[key]
        if t.shape != shape or t.dtype != np.float32 or not np.all(np.isfinite(t)):
            raise error(f"{weights_path}: tensor {key!r} must be finite float32 of shape {shape}, got {t.dtype} "
                        f"{t.shape}")
    return spec, tensors


def gru_step(gru: tuple[np.ndarray, ...], g: np.ndarray, z: np.ndarray) -> np.ndarray:
    """A gated recurrent unit's state after input ``z`` from state ``g``, float32: torch's ``nn.GRU`` equations,
    ``gru`` = (weight_ih, bias_ih, weight_hh, bias_hh), gates in torch's order (reset, update, new)."""
    w_ih, b_ih, w_hh, b_hh = gru
    gi, gh = w_ih @ z + b_ih, w_hh @ g + b_hh
    n = len(g)
    r = 1.0 / (1.0 + np.exp(-(gi[:n] + gh[:n])))
    u = 1.0 / (1.0 + np.exp(-(gi[n:2 * n] + gh[n:2 * n])))
    new = np.tanh(gi[2 * n:] + r * gh[2 * n:])
    return ((1.0 - u) * new + u * g).astype(np.float32)

"""Fixtures shared by the agents' tests."""

from __future__ import annotations

import hashlib
import json

import numpy as np
import pytest


class StudentFiles:
    """A student's two files made by hand (``agents.student``): ``tensors(spec)``, seeded weights of the spec's
    shapes (spreads positive); ``write(folder, spec, tensors=None)``, the weights and the spec naming their SHA-256."""

    @staticmethod
    def tensors(spec: dict) -> dict[str, np.ndarray]:
        from agents.student import tensor_shapes
        rng = np.random.default_rng(0)
        out = {k: rng.normal(size=shape).astype(np.float32) for k, shape in tensor_shapes(spec).items()}
        for spread in ("obs_std", "aux_std"):
            if spread in out:
                out[spread] = np.abs(out[spread]) + 1
        return out

    @staticmethod
    def write(folder, spec: dict, tensors: dict[str, np.ndarray] | None = None):
        from safetensors.numpy import save

        from agents.student import SPEC, WEIGHTS
        folder.mkdir(exist_ok=True)
        blob = save(StudentFiles.tensors(spec) if tensors is None else tensors)
        (folder / WEIGHTS).write_bytes(blob)
        (folder / SPEC).write_text(json.dumps({**spec, "weights_sha256": hashlib.sha256(blob).hexdigest()}))
        return folder


@pytest.fixture
def student_files() -> type[StudentFiles]:
    return StudentFiles


@pytest.fixture
def limit_actions():
    """:func:`_limit_actions` (a fixture: the test modules share it without importing one another)."""
    return _limit_actions


def _limit_actions(steps: int = 6, **settings) -> np.ndarray:
    """The actions ``limit`` (its settings ``settings``) sends in its first ``steps`` decisions on the nominal 40 N
    bench, each stepped on the env (the planner-setting tests compare them)."""
    from agents.heldout import nominal_benches
    from agents.limit import LimitController
    from envs.triplanar_shear_v1 import TriPlanarShearV1Env
    bench = nominal_benches([40.0])[0]
    env = TriPlanarShearV1Env()
    env.reset(seed=0, options={"bench": bench})
    controller = LimitController(**settings)
    controller.bind(env)
    controller.reset(bench.load_N, env.unwrapped.config)
    sent = []
    for _ in range(steps):
        sent.append(controller.act(None))
        env.step(sent[-1])
    return np.array(sent)


@pytest.fixture
def nominal_drive():
    """:func:`_nominal_drive` (a fixture: the test modules share it without importing one another)."""
    return _nominal_drive


def _nominal_drive(estimator, periods: int) -> list[np.ndarray]:
    """``estimator`` (``reset``, ``estimate``, ``advance``: a bank, a tracker, a worker) beside the first judge bench
    driven by the nominal command for ``periods`` periods, the test never ending; its ``periods + 1`` estimates."""
    from agents.mpc import nominal_command
    from envs.triplanar_shear_v1 import TriPlanarShearV1Env
    from experiments.train_student import judge_draws
    (_, bench), = judge_draws(1, {})
    env = TriPlanarShearV1Env()
    obs, _ = env.reset(seed=0, options={"bench": bench})
    estimator.reset(bench.load_N, env.unwrapped.config)
    action = nominal_command(env.unwrapped.config).astype(np.float32)
    estimates = []
    for _ in range(periods):
        estimates.append(estimator.estimate(obs))
        estimator.advance(action)
        obs, _, terminated, truncated, _ = env.step(action)
        assert not (terminated or truncated)
    estimates.append(estimator.estimate(obs))
    return estimates

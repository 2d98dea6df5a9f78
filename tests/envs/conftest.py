"""What the batched envs' tests share: stepping a batch beside N single envs and comparing every output bitwise."""

from __future__ import annotations

from typing import Any, Callable, Iterable, Sequence

import numpy as np
import pytest

#: ``check(batch_info, i, single_info, terminated, truncated)``: the version's own checks of env ``i``'s info
InfoCheck = Callable[[dict[str, Any], int, dict[str, Any], bool, bool], None]


def step_beside_singles(vec: Any, singles: Sequence[Any], batches: Iterable[np.ndarray], seed: int,
                        check_info: InfoCheck) -> set[str]:
    """Reset the batch with ``seed`` and single env ``i`` with ``seed + i``, step both with the same actions and assert
    every observation (float32), reward, termination and truncation bitwise equal, a single env that ended being
    reset as the batch's next-step autoreset does (the new episode's first observation, reward 0); ``check_info``
    compares the infos. Returns the episode ends seen."""
    obs, _ = vec.reset(seed=seed)
    for i, env in enumerate(singles):
        assert np.array_equal(obs[i], env.reset(seed=seed + i)[0])
    ended, reasons = [False] * len(singles), set()
    for batch in batches:
        obs, rewards, terminated, truncated, info = vec.step(batch)
        for i, env in enumerate(singles):
            if ended[i]:
                expected = (env.reset()[0], 0.0, False, False)
            else:
                o, r, te, tr, inf = env.step(batch[i])
                expected = (o, r, te, tr)
                check_info(info, i, inf, te, tr)
                if te or tr:
                    reasons.add(inf["reason"])
            assert obs[i].dtype == np.float32 and np.array_equal(obs[i], expected[0])
            assert rewards[i] == expected[1] and terminated[i] == expected[2] and truncated[i] == expected[3]
            ended[i] = bool(terminated[i] or truncated[i])
    return reasons


@pytest.fixture
def beside_singles() -> Callable[..., set[str]]:
    """:func:`step_beside_singles` (a fixture: a test never imports another test module)."""
    return step_beside_singles

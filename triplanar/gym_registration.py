"""The project's Gymnasium ids, registered by ``import triplanar`` as Gymnasium 1.x packages do it (``ale_py``,
``gymnasium_robotics``: importing the package registers its ids)::

    import gymnasium as gym
    env = gym.make("triplanar:TriPlanarShearRealistic-v0")   # imports triplanar, which registers every id

    import triplanar                                          # or this once, then the bare ids
    gym.register_envs(triplanar)                              # (optional: tells linters the import is used)
    env = gym.make("TriPlanarShearRealistic-v0")

Registering is cheap: the entry points are strings naming attributes of this module, and no env module is imported
until an env is made (:func:`__getattr__` resolves them then). ``import triplanar`` does not import Gymnasium either:
if Gymnasium is not loaded yet, the ids are registered the moment it is (:func:`register_when_gymnasium_loads`).

The entry points do not go through the bare name ``envs`` (the project's env package): a folder named ``envs`` in
the user's working directory comes first on ``sys.path`` and would hide it. :func:`env_package` finds the project's
package beside ``triplanar`` instead; it is ``envs`` itself wherever that name is the project's (so ``import envs``
and ``gym.make`` give the same classes), and is loaded under the private name :data:`PRIVATE_NAME` only when another
package holds the name.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import sys
from pathlib import Path
from types import ModuleType
from typing import Any, NamedTuple

ENVS_DIR = Path(__file__).resolve().parent.parent / "envs"
PRIVATE_NAME = "_triplanar_envs"

# The env classes the ids make, by the module of the env package that defines them.
ENV_CLASSES = {"TriPlanarShearEnv": "triplanar_shear", "TriPlanarShearVectorEnv": "vector",
               "TriPlanarShearV1Env": "triplanar_shear_v1", "TriPlanarShearV1VectorEnv": "vector_v1"}

# A return of -1 or more means a mimicry error under the project's 1 mm target: with the default travel-weighted
# reward an episode's distance terms sum to minus its mimicry error in mm, the action-rate terms are <= 0, and a
# failure costs failure_penalty_mm (50) times the untravelled fraction of the path.
REWARD_THRESHOLD = -1.0
# v1's length at its defaults: time_limit_s 2 s at 200 Hz, the first period in reset. The env truncates itself at
# time_limit_s; the registered limit is what tools that read spec.max_episode_steps see (a longer time_limit_s needs
# gym.make(..., max_episode_steps=N) to match, else Gymnasium's TimeLimit ends the episode at 399 steps).
V1_MAX_EPISODE_STEPS = 399


class EnvId(NamedTuple):
    id: str
    env_class: str
    vector_class: str
    max_episode_steps: int | None
    task: str


# Two tasks, each under a name of its own; the first published ids (one name, two versions) keep working.
IDS = (EnvId("TriPlanarShearIdeal-v0", "TriPlanarShearEnv", "TriPlanarShearVectorEnv", None, "ideal bench"),
       EnvId("TriPlanarShearRealistic-v0", "TriPlanarShearV1Env", "TriPlanarShearV1VectorEnv",
             V1_MAX_EPISODE_STEPS, "realistic bench"),
       EnvId("TriPlanarShear-v0", "TriPlanarShearEnv", "TriPlanarShearVectorEnv", None,
             "ideal bench (first published id of TriPlanarShearIdeal-v0)"),
       EnvId("TriPlanarShear-v1", "TriPlanarShearV1Env", "TriPlanarShearV1VectorEnv", V1_MAX_EPISODE_STEPS,
             "realistic bench (first published id of TriPlanarShearRealistic-v0)"))
IDEAL_ID, REALISTIC_ID = IDS[0].id, IDS[1].id


def register_envs() -> None:
    """Register every id of :data:`IDS` that is not registered yet (imports no env module)."""
    from gymnasium.envs.registration import register, registry
    for env_id in IDS:
        if env_id.id not in registry:
            register(id=env_id.id, entry_point=f"{__name__}:{env_id.env_class}",
                     vector_entry_point=f"{__name__}:{env_id.vector_class}",
                     max_episode_steps=env_id.max_episode_steps, reward_threshold=REWARD_THRESHOLD)


class _AfterGymnasium(importlib.abc.MetaPathFinder):
    """Runs :func:`register_envs` right after ``gymnasium`` is imported (once; then it leaves ``sys.meta_path``)."""

    def find_spec(self, name: str, path: Any = None, target: Any = None):
        if name != "gymnasium":
            return None
        sys.meta_path.remove(self)
        spec = importlib.util.find_spec(name)
        if spec is not None and spec.loader is not None:
            spec.loader = _RegisteringLoader(spec.loader)
        return spec


class _RegisteringLoader(importlib.abc.Loader):
    def __init__(self, loader: Any):
        self.loader = loader

    def create_module(self, spec: Any) -> ModuleType | None:
        return self.loader.create_module(spec)

    def exec_module(self, module: ModuleType) -> None:
        self.loader.exec_module(module)
        register_envs()

    def __getattr__(self, name: str) -> Any:  # the rest of the loader's interface (resources, source)
        return getattr(self.loader, name)


def register_when_gymnasium_loads() -> None:
    """Register now if Gymnasium is loaded, else as soon as it is (``import triplanar`` stays free of it)."""
    if "gymnasium" in sys.modules:
        register_envs()
    elif not any(isinstance(finder, _AfterGymnasium) for finder in sys.meta_path):
        sys.meta_path.insert(0, _AfterGymnasium())


def _is_project_envs(module: ModuleType | None) -> bool:
    origin = getattr(module, "__file__", None)
    return origin is not None and Path(origin).resolve().parent == ENVS_DIR


def env_package() -> ModuleType:
    """The project's env package: ``envs`` wherever that name resolves to it, else (a user's own ``envs`` comes
    first on ``sys.path``, or is imported) the same package from its place beside ``triplanar``, loaded under
    :data:`PRIVATE_NAME` so that the user's ``envs`` stays theirs."""
    for name in ("envs", PRIVATE_NAME):
        if _is_project_envs(sys.modules.get(name)):
            return sys.modules[name]
    if "envs" not in sys.modules:
        spec = importlib.util.find_spec("envs")   # (finding imports nothing)
        if spec is not None and spec.origin and Path(spec.origin).resolve().parent == ENVS_DIR:
            return importlib.import_module("envs")
    spec = importlib.util.spec_from_file_location(PRIVATE_NAME, ENVS_DIR / "__init__.py",
                                                  submodule_search_locations=[str(ENVS_DIR)])
    if spec is None or spec.loader is None:
        raise ImportError(f"the project's env package is missing from {ENVS_DIR}")
    module = importlib.util.module_from_spec(spec)
    sys.modules[PRIVATE_NAME] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[PRIVATE_NAME]
        raise
    return module


def __getattr__(name: str) -> Any:
    """The entry points' classes, resolved from the project's env package when an env is first made."""
    if name not in ENV_CLASSES:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    package = env_package()
    return getattr(importlib.import_module(f"{package.__name__}.{ENV_CLASSES[name]}"), name)

"""TriPlanarShear: the tri-planar sliding model of Galic, Glaser & Goodman (2008).

Quick use::

    from triplanar import paper_model, simulate
    result = simulate(paper_model("A", 32.5))
    print(result.status, result.message, result.summary())

Importing it also registers the Gymnasium ids (:mod:`triplanar.gym_registration`)::

    import gymnasium as gym
    env = gym.make("triplanar:TriPlanarShearRealistic-v0")
"""

from .compiled_cache import announce_compilation
from .effects import Effect, EffectError, Parameter, REGISTRY as EFFECTS, make_effect, register
from . import specimen_numbers  # noqa: F401  (registers the `specimen` effect: the given numbers, freeable by name)
from .measurement import MeasuredTest, MeasurementError, read_measurements, write_measurements
from .model import Loading, Model, paper_model
from .result import SimulationResult
from .simulate import simulate
from .specimen import (Foundation, Plane, Specimen, SpecimenError, load_toml, reference, scale_mass, scale_size,
                       scale_uniform)

from .gym_registration import register_when_gymnasium_loads

announce_compilation()  # (importing compiles nothing; a cold numba cache says so on stderr before it compiles)
register_when_gymnasium_loads()  # the Gymnasium ids (entry-point strings only: no env module, no Gymnasium import)

try:
    from importlib.metadata import version as _version
    __version__ = _version("triplanar-shear")
except Exception:  # not installed (run from a source tree)
    __version__ = "0.1.0"

PAPER_LOADS_N = (27.8, 30.3, 32.5, 35.0, 37.5, 40.0, 42.5, 45.0, 47.5, 49.6, 51.6, 55.6)

__all__ = ["Effect", "EffectError", "Parameter", "EFFECTS", "make_effect", "register", "MeasuredTest",
           "MeasurementError", "read_measurements", "write_measurements", "Loading", "Model", "paper_model",
           "SimulationResult", "simulate", "Foundation", "Plane", "Specimen", "SpecimenError",
           "load_toml", "reference", "scale_mass", "scale_size", "scale_uniform", "PAPER_LOADS_N"]

"""The hidden-effect scenarios the workbench is checked against (tests and benchmark share them).

Every registered effect with a ``scenario`` (``triplanar/effects.py``): the parameter values a dataset is made
with, which a fit must then recover.
"""

from __future__ import annotations

from ..effects import REGISTRY


def hidden_effects() -> dict[str, tuple[str, dict[str, float]]]:
    """effect -> (the ``--effect`` spec the data are made with, the parameters the fit must recover within 15 %)."""
    return {name: (f"{name}:" + ",".join(f"{k}={v!r}" for k, v in cls.scenario.items()), dict(cls.scenario))
            for name, cls in REGISTRY.items() if cls.scenario is not None}


#: the registered effects' scenarios when this module is imported (see :func:`hidden_effects`)
HIDDEN_EFFECTS: dict[str, tuple[str, dict[str, float]]] = hidden_effects()

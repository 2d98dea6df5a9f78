"""Controllers for TriPlanarShear-v0 (``act(obs) -> action``) and the one evaluation function."""

from .controllers import (
           Controller,
           LowFrictionTip,
           MomentMatching,
           SteelTip,
           TrackingTip,
)
from .evaluation import EpisodeResult, evaluate

SCRIPTED = (SteelTip, LowFrictionTip, TrackingTip, MomentMatching)

__all__ = [
           "SCRIPTED",
           "Controller",
           "EpisodeResult",
           "LowFrictionTip",
           "MomentMatching",
           "SteelTip",
           "TrackingTip",
           "evaluate",
]

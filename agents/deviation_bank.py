"""A specimen bank's real-time estimate of a bench's reference deviation, one episode at a time: what
``banked:RUN`` (:class:`agents.banked_deviation.BankedDeviationPolicy`) feeds its policy at the bench, and what a
training row of ``env: reference_deviation_bank: N`` (:class:`agents.sb3_vec_env.DeviationSB3VecEnv`) feeds PPO, the
same arithmetic in both so that a policy trained on the estimate is judged on the same estimate.

The bank is ``mpc``'s (:meth:`agents.mpc.MPCController.new_bank`, ``N`` hypotheses, no refinement), with no
resample-move (a plain particle filter from its first period: a move replays the history, tens of ms, more than a
period) and its weights tempered to an effective size of :data:`MIN_ESS` for the estimate
(:meth:`agents.estimator.SpecimenBank.deviation`); chosen on the judge draws, finding 13b of
``docs/notes/student-experiments.md``. A period: :meth:`DeviationBank.estimate` weighs the bank by the period just
measured (not at the episode's first observation) and returns the estimate; :meth:`DeviationBank.advance` runs every
hypothesis by the command the bench runs next.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from envs.triplanar_shear_v1 import B_RANGE

from .mpc import MPCController

BANK_SIZE = 16
MIN_ESS = 4.0


def bank_settings(bank_size: int = BANK_SIZE) -> MPCController:
    """The bank's settings: ``mpc``'s, with ``bank_size`` hypotheses and no refinement."""
    if isinstance(bank_size, bool) or not isinstance(bank_size, int) or bank_size < 1:
        raise ValueError(f"bank_size must be a positive integer, got {bank_size!r}")
    return MPCController(bank_size=bank_size, refine_every=0)


class WrapsDeviationBank:
    """For an estimator built around another (``deviation_bank``: a :class:`DeviationBank`, or an estimator built
    around one): the episode's ``SpecimenBank``, the periods seen and the estimate's tempering, the wrapped one's."""

    deviation_bank: Any

    @property
    def bank(self) -> Any:
        """The episode's ``SpecimenBank`` (None before the first reset)."""
        return self.deviation_bank.bank

    @property
    def periods(self) -> int:
        return self.deviation_bank.periods

    @property
    def min_ess(self) -> float:
        """The effective size the estimate's weights are tempered to."""
        return self.deviation_bank.min_ess


class DeviationBank:
    """One episode's specimen-bank estimate of the reference deviation (module docstring). ``settings``: the
    ``MPCController`` whose bank is built (its size, prior, seed); ``moves`` True lets the bank resample-move as
    ``mpc``'s does; ``min_ess``: the estimate's weights tempered to at least that effective size."""

    def __init__(self, settings: MPCController, *, moves: bool = False, min_ess: float = MIN_ESS):
        if not min_ess >= 1.0:
            raise ValueError(f"min_ess must be a number >= 1 (an effective sample size), got {min_ess!r}")
        self.settings, self.moves, self.min_ess = settings, bool(moves), float(min_ess)
        self.bank: Any = None
        self.periods = 0

    @classmethod
    def of_size(cls, bank_size: int = BANK_SIZE, **options: Any) -> DeviationBank:
        """:func:`bank_settings` of ``bank_size``."""
        return cls(bank_settings(bank_size), **options)

    def reset(self, load_N: float, config: Any) -> None:
        """A new episode at ``load_N`` on the bench of ``config`` (a ``ShearConfig``)."""
        self.bank = self.settings.new_bank(load_N, config)
        if not self.moves:
            self.bank.rejuvenate_ess = 0.0   # (an effective size is never below zero: no resample-move)
        self.periods = 0

    def estimate(self, obs: np.ndarray) -> np.ndarray:
        """The estimate after observation ``obs`` (one frame of the bench's observation): the bank weighed by its
        measurement unless it is the episode's first."""
        if self.periods:   # the measurement of the period the last command ran
            self.bank.weigh(np.array(obs[B_RANGE:B_RANGE + 9], dtype=float))
        self.periods += 1
        return self.bank.deviation(self.min_ess)

    def advance(self, action: np.ndarray) -> None:
        """Every hypothesis advanced by ``action``, the command the bench runs this period."""
        self.bank.predict(np.asarray(action, dtype=np.float64))


def estimate_error_mm(estimate: np.ndarray, truth: np.ndarray) -> float:
    """An estimate's error against the true deviation (:func:`envs.core.reference_deviation`'s 12 values): the mean
    over the three contact points of the x-z distance between their first six values."""
    d = (np.asarray(estimate)[:6] - np.asarray(truth)[:6]).reshape(3, 2)
    return float(np.mean(np.hypot(d[:, 0], d[:, 1])))

"""How a reference-deviation PPO (``env: reference_deviation: true``, :class:`agents.robust_policy.DeviationPolicy`)
drives when its deviation input carries an estimator's error, on the students' judge benches
(:func:`experiments.train_student.judge_outcomes`): what a bench estimator of the deviation must achieve.

``python -m experiments.deviation_noise --run RUN --bias-mm 0.1 0.2 [--noise-mm 0.2] --n 100 [--out FILE]``

Five of the six deviation values (mm; :func:`envs.core.reference_deviation`) get a Gaussian error of standard
deviation ``--bias-mm``, drawn once per episode (the slowly varying error of an estimate of the case-C path: a
per-point distance error of about 1.25 times it), plus ``--noise-mm`` drawn at every decision. CP1's x deviation is
left exact: it is zero by construction (the travel is CP1's x displacement and the reference is indexed by it; the
training normaliser saw it constant, so any error there would be an input the policy never met), as is the
reference's slope. The errors come from one generator seeded ``--seed``, in the judge's bench order. Prints, as JSON,
one :func:`experiments.judge`-style row per ``--bias-mm`` value (0 included: the run itself).
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

import numpy as np

from agents.heldout import FAILURE_SCORE_MM
from agents.robust_policy import DeviationPolicy, load_policy
from agents.sb3_vec_env import ESTIMATED_DEVIATION

from .judge import emit
from .train_student import judge_outcomes, judged_stats

ESTIMATED = ESTIMATED_DEVIATION   # the deviation values an estimator must supply (CP1 z, CP2 x, CP2 z, CP3 x, CP3 z)


class NoisyDeviationPolicy(DeviationPolicy):
    """A :class:`DeviationPolicy` whose deviation input is off by a per-episode bias and per-decision noise."""

    def __init__(self, policy: DeviationPolicy, bias_mm: float, noise_mm: float, seed: int = 0):
        super().__init__(policy.model, policy.normalizer, f"{policy.name} bias {bias_mm:g} noise {noise_mm:g}",
                         policy.n_frames)
        self.bias_mm, self.noise_mm = bias_mm, noise_mm
        self.rng = np.random.default_rng(seed)
        self._bias = np.zeros(ESTIMATED.stop - ESTIMATED.start)

    def reset(self, load_N: float, config: Any) -> None:
        super().reset(load_N, config)
        self._bias = self.rng.normal(0.0, self.bias_mm, len(self._bias))

    def _deviation(self) -> np.ndarray:
        value = super()._deviation().copy()
        value[ESTIMATED] += self._bias + self.rng.normal(0.0, self.noise_mm, len(self._bias))
        return value


def probe(run: str, biases: list[float], noise_mm: float, n: int, seed: int = 0) -> dict[str, Any]:
    """The run judged with each bias (and ``noise_mm``) on the first ``n`` judge benches."""
    policy = load_policy(run)
    if not isinstance(policy, DeviationPolicy):
        raise ValueError(f"--run {run}: not a reference_deviation run (its config.json has no env.reference_deviation)")
    rows = {}
    for bias in biases:
        outcomes = judge_outcomes(NoisyDeviationPolicy(policy, bias, noise_mm, seed), {}, n)
        rows[f"bias {bias:g} mm, noise {noise_mm:g} mm"] = {
            **judged_stats([outcomes]),
            "bench_scores_mm": [o.mimicry_error_mm if o.success else FAILURE_SCORE_MM for o in outcomes]}
    return {"run": run, "n": n, "seed": seed, "rows": rows}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m experiments.deviation_noise", description=__doc__.split("\n\n")[0])
    parser.add_argument("--run", required=True, help="a finished reference_deviation run (agents.trainer)")
    parser.add_argument("--bias-mm", type=float, nargs="+", default=[0.0], help="per-episode error's sigma, mm")
    parser.add_argument("--noise-mm", type=float, default=0.0, help="per-decision error's sigma, mm")
    parser.add_argument("--n", type=int, default=100, help="the first N judge benches (default 100)")
    parser.add_argument("--seed", type=int, default=0, help="the errors' generator seed")
    parser.add_argument("--out", help="also write the JSON here")
    args = parser.parse_args(argv)
    if any(b < 0 for b in args.bias_mm) or args.noise_mm < 0:
        parser.error("--bias-mm and --noise-mm must be >= 0")
    try:
        result = probe(args.run, args.bias_mm, args.noise_mm, args.n, args.seed)
    except ValueError as error:
        print(f"error: {error}", file=sys.stderr)
        return 2
    emit(result, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())

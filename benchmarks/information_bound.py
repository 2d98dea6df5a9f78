"""How much error one episode's measurements leave, whatever the controller does with them: a linearised
information bound for ``mpc`` on the tuning benches.

``PYTHONPATH=. python benchmarks/information_bound.py --benches 20 --out runs/information_bound [--workers 2]
[--limit-run runs/t200_limit] [--mpc FIELD=VALUE]``

For each of the first tuning benches (stream ``agents.heldout.TUNING_SEED``) ``mpc`` (with the ``--mpc`` settings,
as ``bench_mpc.py`` takes them) runs one episode and its commands are kept. Along those commands the bench's noiseless rangefinder signals (nine contact-point displacements
per period, ``TriPlanarShear-v1``'s bench at its defaults) are differentiated by central differences (2 % of each
range) with respect to every unknown that v1 draws (one-sided at the edge of its range) (tip and contact friction, mass centre, mass, dips, the tilted
planes' dip directions; the horizontal plane's direction, an angle around the circle, is left out). From that the
Fisher information of the first ``k`` periods under the rangefinders' Gaussian noise (``sensor_noise_m``, 0.2 mm),
added to a Gaussian prior of v1's ranges' variances (a uniform range's), gives a posterior covariance of the unknowns
after every period (the Cramér-Rao form, linear about the bench's truth). Propagated through the sensitivities of
the case-C reference at the block's travel (the reference table differentiated at a fixed travel, linearly
interpolated as the env does), it gives, for each period, the expected horizontal distance of each contact point
from the posterior's reference given the measurements of the periods before (mean over the three points: the env's
distance). Its travel average (the env's trapezoid rule) is ``reference bound``: the mimicry error that remains for
a controller that could put the block exactly where the measurements so far place the case-C path. ``deviation
bound`` is the same for the block's deviation from that path (position minus reference, both uncertain): what the
controller cannot know about its own error at the time it acts.

What it is and is not: a bound for controllers that see what ``mpc`` saw (its commands set what is excited; another
excitation would give another bound, at a cost in error), linearised (stick/slip switches make the signals only
piecewise smooth) and with a Gaussian in place of the uniform prior. It says how much of ``mpc``'s error the
information explains, not that no controller could do better. Writes ``OUT/summary.json`` (atomically), with a
per-episode checkpoint under ``OUT/tasks`` (running it again resumes). Results go to ``docs/actuator-study.md`` by hand.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np

from bench_mpc import controller_settings, run_base

from agents.estimator import PARAMETERS, bench_of, geometry_ranges, hypothesis_of, prior_ranges
from agents.heldout import TUNING_SEED, random_benches, run_episode
from agents.mpc import MPCController
from envs.core import OBS_POS, make_config
from envs.prediction import snapshot
from envs.triplanar_shear_v1 import Bench, TriPlanarShearV1Env
from experiments.stats import bootstrap_ci
from triplanar.executor import TaskCheckpoint, pool_scope, run_tasks
from triplanar.workbench.report import write_json

STEP = 0.02  # central-difference step, a fraction of each unknown's range
SAMPLES = 4000  # normal draws for the expected distance of a 2-d Gaussian


class Recorder:
    """A bench controller that passes ``controller``'s actions on and keeps them."""

    def __init__(self, controller: MPCController):
        self.controller, self.name, self.commands = controller, controller.name, []

    def reset(self, load_N: float, config) -> None:
        self.controller.reset(load_N, config)

    def act(self, obs: np.ndarray) -> np.ndarray:
        action = self.controller.act(obs)
        self.commands.append(np.array(action, dtype=float))
        return action


def signals(bench: Bench, commands: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """The noiseless rangefinder signals (periods x 9, m) of ``bench`` under ``commands``, its case-C reference table
    and the travel target."""
    env = TriPlanarShearV1Env(observation_mode="state", sensor_noise_m=0.0)
    env.reset(seed=0, options={"bench": bench})
    reference = np.array(snapshot(env).ref)
    out = []
    for raw in commands:
        obs, _, terminated, truncated, _ = env.step(np.asarray(raw, dtype=np.float32))
        out.append(np.array(obs[OBS_POS:OBS_POS + 9], dtype=float))
        if terminated or truncated:
            break
    return np.array(out), reference, env.config.travel_m


def at_travel(reference: np.ndarray, s: np.ndarray, travel: float) -> np.ndarray:
    """The reference table (rows at equal steps of travel up to ``travel``) at each travel of ``s``, linear between
    rows and held at the ends, as the env reads it."""
    grid = np.linspace(0.0, travel, len(reference))
    return np.stack([np.interp(s, grid, column) for column in reference.T], axis=1)


def expected_distance_mm(cov: np.ndarray, z: np.ndarray) -> float:
    """The mean over the three contact points of the expected horizontal distance (mm) of a zero-mean Gaussian
    displacement with covariance ``cov`` (9 x 9: x1, x2, x3 of CP1..CP3)."""
    total = 0.0
    for i in range(3):
        block = cov[np.ix_([3 * i, 3 * i + 2], [3 * i, 3 * i + 2])]
        factor = np.linalg.cholesky(block + 1e-24 * np.eye(2))
        total += float(np.mean(np.linalg.norm(z @ factor.T, axis=1)))
    return 1e3 * total / 3.0


def travel_average(distance: np.ndarray, travel: np.ndarray) -> float:
    """The env's trapezoid rule over the travel of each period."""
    ds = np.abs(np.diff(np.concatenate([[0.0], travel])))
    previous = np.concatenate([[distance[0]], distance[:-1]])
    return float(np.sum(0.5 * (distance + previous) * ds) / np.sum(ds))


def bound(bench: Bench, commands: np.ndarray, sensor_noise_m: float = 2e-4) -> dict | None:
    """The reference and deviation bounds (module docstring) of ``bench`` under ``commands``; None if a perturbed
    bench ends before the bench does (the differences are then not defined)."""
    prior, foundation = make_config(None).base_specimen()
    low, high = prior_ranges(prior)
    glow, ghigh, circular = geometry_ranges(prior, foundation)
    low, high = np.concatenate([low, glow]), np.concatenate([high, ghigh])
    free = np.flatnonzero((high > low) & ~np.concatenate([np.zeros(len(PARAMETERS), dtype=bool), circular]))
    span = high - low
    theta = hypothesis_of(bench)
    path, _, travel = signals(bench_of(prior, theta, bench.load_N), commands)
    n, s = len(path), path[:, 0]
    d_signal, d_reference = [], []
    for j in free:
        # central where the range allows, one-sided at its edge (a horizontal plane's dip near 0)
        ends = np.clip(theta[j] + np.array([STEP, -STEP]) * span[j], low[j], high[j])
        (up, ref_up, _), (down, ref_down, _) = (
            signals(bench_of(prior, np.where(np.arange(len(theta)) == j, end, theta), bench.load_N), commands[:n])
            for end in ends)
        if len(up) < n or len(down) < n:
            return None
        h = ends[0] - ends[1]
        d_signal.append((up - down) / h)
        d_reference.append((at_travel(ref_up, s, travel) - at_travel(ref_down, s, travel)) / h)
    d_signal, d_reference = np.array(d_signal), np.array(d_reference)  # (unknowns, periods, 9)
    information = np.diag(12.0 / span[free] ** 2)  # the prior: a uniform range's variance
    z = np.random.default_rng(0).standard_normal((SAMPLES, 2))
    reference_mm, deviation_mm = np.zeros(n), np.zeros(n)
    for k in range(n):
        cov = np.linalg.inv(information)  # given the periods before k
        g_reference = d_reference[:, k, :].T
        g_deviation = (d_signal[:, k, :] - d_reference[:, k, :]).T
        reference_mm[k] = expected_distance_mm(g_reference @ cov @ g_reference.T, z)
        deviation_mm[k] = expected_distance_mm(g_deviation @ cov @ g_deviation.T, z)
        jacobian = d_signal[:, k, :].T / sensor_noise_m
        information = information + jacobian.T @ jacobian
    return {"reference_bound_mm": travel_average(reference_mm, s), "deviation_bound_mm": travel_average(deviation_mm, s),
            "reference_profile_mm": reference_mm.tolist(), "deviation_profile_mm": deviation_mm.tolist(),
            "travel_fraction": (s / travel).tolist()}


def bench_task(task: tuple[int, tuple]) -> dict:
    index, settings = task
    bench = random_benches(index + 1, TUNING_SEED)[index]
    recorder = Recorder(MPCController(**dict(settings)))
    outcome = run_episode(recorder, bench, seed=index, bench_set="tuning", index=index)
    result = bound(bench, np.array(recorder.commands)) or {}
    return {"index": index, "success": outcome.success, "mpc_error_mm": outcome.mimicry_error_mm, **result}


def mean_ci(values: list[float]) -> tuple[float, float, float]:
    """The mean over benches and its bootstrap 95 % interval (:func:`experiments.stats.bootstrap_ci`)."""
    return bootstrap_ci(np.asarray(values, dtype=float)[None, :], lambda t: float(np.nanmean(t)))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--benches", type=int, default=20, help="the first N tuning benches (N >= 1)")
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--limit-run", type=Path, help="a bench_mpc.py run of limit on the tuning stream, at least as "
                        "many benches")
    parser.add_argument("--mpc", action="append", default=[], metavar="FIELD=VALUE", help="an MPCController setting")
    args = parser.parse_args()
    settings = tuple(sorted(controller_settings(args.mpc, "--mpc", MPCController).items()))
    with pool_scope(args.workers) as ex:
        results = run_tasks(bench_task, [(i, settings) for i in range(args.benches)], ex, progress=True, desc="bound",
                            checkpoint=TaskCheckpoint(args.out / "tasks"))
    rows = [r for r in results if r["success"] and "deviation_bound_mm" in r]
    if not rows:
        raise SystemExit(f"none of the {args.benches} benches pooled (mpc failed or a perturbed bench ended early)")
    summary = {"benches": args.benches, "stream": TUNING_SEED, "mpc": dict(settings), "pooled": len(rows),
               "left_out": [r["index"] for r in results if r not in rows]}
    limit = {}
    if args.limit_run:  # its errors per bench, the same benches checked as bench_mpc.py's --against does
        base = run_base(summary, args.limit_run, "--limit-run")
        if "limit" not in base:
            raise SystemExit(f"--limit-run {args.limit_run}: no limit row in its summary.json")
        limit = {i: math.nan if e is None else float(e) for i, e in enumerate(base["limit"][1])}
    columns = {"reference bound": "reference_bound_mm", "deviation bound": "deviation_bound_mm",
               "mpc error": "mpc_error_mm"}
    print(f"{len(rows)} of {args.benches} tuning benches (mpc successful, differences defined); mean (95 % CI), mm:")
    for label, key in columns.items():
        summary[key] = mean_ci([r[key] for r in rows])
        print(f"  {label}: {summary[key][0]:.3f} ({summary[key][1]:.3f}-{summary[key][2]:.3f})")
    if limit:
        mine = [r for r in rows if r["index"] in limit]
        summary["limit_error_mm"] = mean_ci([limit[r["index"]] for r in mine])
        summary["quadrature_mm"] = mean_ci([math.hypot(limit[r["index"]], r["deviation_bound_mm"]) for r in mine])
        excess = [r["mpc_error_mm"] - limit[r["index"]] for r in mine]
        summary["excess_mm"] = mean_ci(excess)
        summary["excess_bound_correlation"] = float(np.corrcoef(excess, [r["deviation_bound_mm"] for r in mine])[0, 1])
        print(f"  limit error ({args.limit_run}, {len(mine)} benches): {summary['limit_error_mm'][0]:.3f} "
              f"({summary['limit_error_mm'][1]:.3f}-{summary['limit_error_mm'][2]:.3f}); limit and deviation bound in "
              f"quadrature: {summary['quadrature_mm'][0]:.3f}; mpc minus limit: {summary['excess_mm'][0]:.3f} "
              f"({summary['excess_mm'][1]:.3f}-{summary['excess_mm'][2]:.3f}), its correlation with the deviation "
              f"bound bench by bench {summary['excess_bound_correlation']:.2f}")
    fractions = np.linspace(0.1, 1.0, 10)
    profile = np.mean([np.interp(fractions, r["travel_fraction"], r["deviation_profile_mm"]) for r in rows], axis=0)
    summary["deviation_profile_mm"] = profile.tolist()
    print("  deviation bound at 10 %, 20 %, ..., 100 % of the travel: " + " ".join(f"{v:.2f}" for v in profile))
    write_json(summary, args.out / "summary.json")


if __name__ == "__main__":
    main()

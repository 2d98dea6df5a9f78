"""The model-based controllers on the default bench: held-out unknown specimens (bench observations), ``limit``
(perfect knowledge), ``mpc`` and the scripted controllers for reference, plus the CPU time of a control decision.

``PYTHONPATH=. python benchmarks/bench_mpc.py --benches 50 --out runs/bench_mpc [--workers 2]``; ``--limit-sweep``:
``limit`` at six nominal loads with shorter/longer horizons and more samples instead; ``--identify FIT.json
[--tip-deg D]``: ``mpc`` with a fit as prior against the drawing's prior instead. ``--stream 20020`` (the tuning
stream, ``agents.heldout.TUNING_SEED``) and the controller ``mpc_true`` (``mpc``'s planner and settings with its
bank replaced by the bench's true state: what ``mpc`` would do if it estimated perfectly) separate estimation error
from planning error, ``mpc_true_reference`` (``mpc`` aiming at the bench's own case-C reference, its estimate
otherwise its own: :class:`TrueReferenceMPC`) what knowing where to go is worth, and ``mpc_given_GROUPS`` (``mpc`` told some unknowns exactly, e.g. ``mpc_given_tip``,
``mpc_given_tip_friction_centre``: :class:`GivenMPC`) what each unknown costs; for ``mpc`` the table also gives the
RMS error of the estimator's final estimate against the bench's truth and how far the bank's case-C reference ends
from the bench's (``--hindsight``: also that of a sharp bank given the whole episode's measurements). ``--set stress``: the stress set (outside
v1's ranges) instead of the held-out benches; ``--against OUT``: also the bench-by-bench differences from an earlier
run on the same benches (a variant against the current settings, with an interval; a run of the same stream on
more benches gives its first ``--benches``); ``--against-study CSV``: the
same against the study's rows of the same controller and of ``limit`` (its per-episode CSV), with the ratio to the
limit; ``--mpc FIELD=VALUE`` / ``--limit FIELD=VALUE``: a setting of ``mpc`` (and ``mpc_true``, ``mpc_given_*``) /
``limit`` (variants).

Episodes go through the project's executor (``run_tasks``, local processes) with a per-episode checkpoint under
``OUT/tasks`` (running it again resumes). Writes ``OUT/summary.json`` (atomically) and prints a table with the
study's statistics (:func:`experiments.stats.row_stats`): success rate with its interval, mean mimicry error over
successes and the score (a failure counts 10 mm, ``agents.heldout``) with their bootstrap 95 % intervals, the ratio
of each score to ``limit``'s on the same benches, CPU time per episode and, for ``mpc``, per decision (mean, p95,
p99, max: ``time.process_time`` around ``act``, the estimator's update plus planning, or the plan followed between
replans; a process's first ``mpc`` episode follows an untimed short one, so that numba's cache loading is not
counted), and where along the travel each controller's error is made (:func:`travel_profile`).
Results go to ``docs/actuator-study.md`` by hand, with the command.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np

from agents.bench_controllers import make_controller
from agents.heldout import (
    FAILURE_SCORE_MM,
    HELDOUT_SEED,
    heldout_benches,
    random_benches,
    run_episode,
    stress_benches,
    summarise,
)
from experiments.stats import row_stats
from triplanar.executor import TaskCheckpoint, pool_scope, run_tasks
from triplanar.workbench.report import write_json

SCRIPTED = {"frictionless_tip": {}, "moment_matching": {}, "pi_feedback": {"kp": -20.0, "ki": 200.0},
            "adaptive": {"gain_deg_per_m_s": -1e5}}
ENV = {"frictionless_tip": {"tip_friction_deg": 0.0}}


class ToldMPC:
    """``mpc`` told some of the bench's truth (a diagnosis, not a controller a laboratory could build): it reads the
    env through :meth:`bind`, as ``limit`` does, and a subclass's ``reset`` hands the truth to ``mpc``'s bank."""

    needs_env = True

    def __init__(self, name: str, **params) -> None:
        from agents.mpc import MPCController
        self.controller = MPCController(name=name, **params)
        self.name, self.act = name, self.controller.act

    def bind(self, env) -> None:
        self._env = env.unwrapped

    @property
    def info(self) -> dict:
        return self.controller.info

    @property
    def bank(self):
        return self.controller.bank


class TrueStateMPC(ToldMPC):
    """``mpc`` whose bank is the bench's true state (one hypothesis, tracked exactly with the commands sent): its
    planner and settings with perfect estimation."""

    def reset(self, load_N: float, config) -> None:
        from agents.estimator import hypothesis_of
        from envs.prediction import snapshot
        self.controller.reset(load_N, config)
        bank = self.bank
        bank.states, bank.theta = [snapshot(self._env)], hypothesis_of(self._env.episode_bench)[None, :]
        bank.log_w, bank.ll, bank.alive, bank.jitter = np.zeros(1), np.zeros(1), np.ones(1, dtype=bool), 0.0
        bank.refine_every = 0  # the truth needs no fit (a refinement would replace it by draws around one)


class TrueReferenceMPC(ToldMPC):
    """``mpc`` whose plans aim at the bench's own case-C reference (every planning hypothesis carries it in place of
    its own), its bank and predictions unchanged: what knowing only where to go is worth, against ``mpc_true``
    (knowing everything)."""

    def reset(self, load_N: float, config) -> None:
        from envs.prediction import snapshot
        self.controller.reset(load_N, config)
        truth, best = snapshot(self._env).ref, self.bank.best

        def aimed(count: int, min_ess: float = 1.0):
            states, weights = best(count, min_ess)
            for state in states:
                state.ref = truth.copy()
            return states, weights
        self.bank.best = aimed


GIVEN = {"tip": ("tip_friction_deg",), "friction": ("friction1_deg", "friction2_deg", "friction3_deg"),
         "centre": ("mass_centre1_m", "mass_centre2_m", "mass_centre3_m")}


def given_groups(name: str) -> list[str]:
    """The groups of :data:`GIVEN` a ``mpc_given_...`` controller is told (a clear error for an unknown one)."""
    groups = name.removeprefix("mpc_given_").split("_")
    unknown = [g for g in groups if g not in GIVEN]
    if unknown:
        raise SystemExit(f"--controllers {name}: {unknown} not among the groups {sorted(GIVEN)}")
    return groups


class GivenMPC(ToldMPC):
    """``mpc`` told some of the bench's unknowns exactly (``mpc_given_tip``, ``mpc_given_friction_centre``, ...: the
    groups of :data:`GIVEN` joined by ``_``): every hypothesis holds them at the truth, the rest is estimated as
    ``mpc`` does. What knowing each unknown is worth."""

    def __init__(self, name: str, **params) -> None:
        super().__init__(name, **params)
        self.groups = given_groups(name)

    def reset(self, load_N: float, config) -> None:
        from agents.estimator import PARAMETERS, hypothesis_of
        self.controller.reset(load_N, config)
        truth = hypothesis_of(self._env.episode_bench)
        bank = self.bank  # refilled within the told intervals (``mpc``'s reset filled it without them)
        bank.intervals = {**(bank.intervals or {}),
                          **{f: (float(truth[PARAMETERS.index(f)]),) * 2 for g in self.groups for f in GIVEN[g]}}
        bank.reset(load_N)


def estimate_errors(estimate: dict, bench) -> dict:
    """The final estimate's error against the bench's truth: tip and contact friction (deg), mass centre (mm)."""
    from agents.estimator import hypothesis_of
    truth = hypothesis_of(bench)
    return {"tip_deg": [estimate["tip_friction_deg"] - truth[0]],
            "friction_deg": [estimate[f"friction{k}_deg"] - truth[k] for k in (1, 2, 3)],
            "mass_centre_mm": [1e3 * (estimate[f"mass_centre{k}_m"] - truth[3 + k]) for k in (1, 2, 3)],
            "dip_deg": [estimate[f"dip{k}_deg"] - truth[7 + k] for k in (1, 2, 3)]}


def benches_of(n: int, stream: int | str) -> list:
    """The held-out benches, the stress set (``stream`` "stress") or the first ``n`` draws of another stream."""
    if stream == "stress":
        return stress_benches(n)
    return heldout_benches(n) if stream == HELDOUT_SEED else random_benches(n, stream)


def reference_errors(bank, bench, index: int, hindsight: bool) -> dict:
    """How far the bank's belief of the bench's case-C reference (:meth:`agents.estimator.SpecimenBank.reference`)
    ends from the bench's own (mm, as the mimicry error measures paths); with ``hindsight`` also that of a bank
    given every measurement of the episode with nothing added to the sensor noise and refined by least squares
    every 10 periods (:meth:`~agents.estimator.SpecimenBank.refine`): what the episode's measurements tell."""
    from dataclasses import replace

    from agents.estimator import reference_distance_mm
    from envs.prediction import snapshot
    from envs.triplanar_shear_v1 import TriPlanarShearV1Env
    env = TriPlanarShearV1Env()
    env.reset(seed=index, options={"bench": bench})
    truth = snapshot(env).ref
    out = {"reference_error_mm": reference_distance_mm(bank.reference(), truth)}
    if hindsight:
        sharp = replace(bank, model_error_m=0.0, refine_every=10, seed=bank.seed + 1)
        sharp.reset(bench.load_N)
        for raw, measured in bank.history[:-2]:  # a hypothesis a little faster than the bench ends the test there
            sharp.observe(raw, measured)
        out["hindsight_reference_error_mm"] = reference_distance_mm(sharp.reference(), truth)
    return out


def episode(task: tuple[str, dict, int, int, int | str, bool]) -> dict:
    """One held-out episode of controller ``name``: its outcome, CPU time and, for ``mpc``, per-decision times,
    the final estimate's errors and its reference's (:func:`reference_errors`)."""
    name, params, index, n, stream, hindsight = task
    if name.startswith("mpc"):
        from bench_mpc_decisions import warm_up
        warm_up()
    bench = benches_of(n, stream)[index]
    if name == "frictionless_tip":
        from agents.heldout import with_tip
        bench = with_tip(bench, 0.0)
    if name == "mpc_true":
        controller = TrueStateMPC(name, **params)
    elif name == "mpc_true_reference":
        controller = TrueReferenceMPC(name, **params)
    elif name.startswith("mpc_given_"):
        controller = GivenMPC(name, **params)
    else:
        controller = make_controller(name, **params)
    decisions: list[tuple[float, bool]] = []
    if name.startswith("mpc"):
        act = controller.act

        def timed(obs):
            action = act(obs)
            decisions.append((controller.info["cpu_s"], controller.info["planned"]))
            return action
        controller.act = timed
    path: list[tuple[float, float]] = []
    start = time.process_time()
    outcome = run_episode(controller, bench, seed=index, index=index,
                          bench_set="stress" if stream == "stress" else "heldout",
                          on_step=lambda info: path.append((info["travel_m"], info["distance_mm"])))
    out = asdict(outcome)
    out.update(cpu_s=time.process_time() - start, decisions_cpu_s=decisions, path=path)
    if name == "mpc" or name.startswith("mpc_given_"):
        out["fallbacks"] = controller.info["fallbacks"]
        out["estimate_errors"] = estimate_errors(controller.info["estimate"], bench)
        out.update(reference_errors(controller.bank, bench, index, hindsight))
    return out


PROFILE_FRACTIONS = np.linspace(0.1, 1.0, 10)


def travel_profile(results: list[dict]) -> tuple[np.ndarray, float, int] | None:
    """Where along the travel the error is made: over the successful episodes, the mean distance to the case-C path
    (mm) at :data:`PROFILE_FRACTIONS` of each episode's travel, and the mean share of the mimicry error (travel-
    averaged distance, trapezoid rule as the env's) made in the first fifth of the travel (mm); None without paths
    (runs written before they were recorded)."""
    paths = [np.asarray(r["path"]) for r in results if r["success"] and len(r.get("path", ())) > 1]
    if not paths:
        return None
    at, early = [], []
    for p in paths:
        travel = np.concatenate([[0.0], p[:, 0]])
        distance = np.concatenate([[0.0], p[:, 1]])
        at.append(np.interp(PROFILE_FRACTIONS * travel[-1], travel, distance))
        fine = np.linspace(0.0, 0.2 * travel[-1], 201)
        early.append(np.trapezoid(np.interp(fine, travel, distance), fine) / travel[-1])
    return np.mean(at, axis=0), float(np.mean(early)), len(paths)


LIMIT_SETTINGS = ((24, 32, 3), (48, 64, 4), (96, 64, 4))  # (horizon, samples, iterations); the default is the middle


def limit_episode(task: tuple[tuple[int, int, int], float]) -> dict:
    """``limit`` with the given planner settings at one nominal load (default bench): how far from optimal it is."""
    (horizon, samples, iterations), load = task
    from agents.heldout import nominal_benches
    from agents.limit import LimitController
    start = time.process_time()
    outcome = run_episode(LimitController(horizon=horizon, samples=samples, iterations=iterations),
                          nominal_benches([load])[0], bench_set="nominal")
    return {**asdict(outcome), "cpu_s": time.process_time() - start}


def limit_sweep(out: Path, workers: int, loads: list[float]) -> None:
    tasks = [(setting, load) for setting in LIMIT_SETTINGS for load in loads]
    with pool_scope(workers) as ex:
        results = run_tasks(limit_episode, tasks, ex, progress=True, desc="limit sweep",
                            checkpoint=TaskCheckpoint(out / "tasks"))
    rows = []
    for setting in LIMIT_SETTINGS:
        mine = [r for (s, _), r in zip(tasks, results) if s == setting]
        ok = [r["mimicry_error_mm"] for r in mine if r["success"]]
        rows.append({"horizon": setting[0], "samples": setting[1], "iterations": setting[2],
                     "success_rate": len(ok) / len(mine), "mimicry_error_mm": float(np.mean(ok)) if ok else math.nan,
                     "per_load": [r["mimicry_error_mm"] for r in mine],
                     "cpu_s_per_episode": float(np.mean([r["cpu_s"] for r in mine]))})
        print(f"limit horizon {setting[0]}, {setting[1]} samples x {setting[2]} iterations: success "
              f"{100 * rows[-1]['success_rate']:.1f} %, error {rows[-1]['mimicry_error_mm']:.3f} mm, "
              f"{rows[-1]['cpu_s_per_episode']:.1f} CPU s/episode")
    write_json({"loads_N": loads, "rows": rows}, out / "limit_sweep.json")


def identify_then_control(fit: str, tip_deg: float | None, n: int) -> None:
    """``mpc`` with the fit as prior against the drawing's prior, on ``n`` benches drawn around the fitted specimen
    (stream 30030) with the laboratory's tip ``tip_deg`` (the fitted one if not given); v1's nominal specimen is
    the fit (``nominal_specimen``)."""
    from agents.heldout import with_tip
    from agents.mpc import MPCController
    from envs.core import make_config
    from triplanar.prior import load_prior
    specimen, foundation = make_config(None).base_specimen()
    fitted = load_prior(fit, specimen, foundation)
    tip = fitted.tip_friction_deg if tip_deg is None else tip_deg
    benches = [with_tip(b, tip) for b in random_benches(n, 30_030, {"specimen": fitted})]
    for name, prior in (("fit's prior", fit), ("drawing's prior", specimen)):
        outcomes = [run_episode(MPCController(prior=prior), b, env_kwargs={"nominal_specimen": fit}, seed=i, index=i)
                    for i, b in enumerate(benches)]
        row = summarise(outcomes)
        print(f"mpc, {name}: {row['n_episodes']} benches, success {100 * row['success_rate']:.1f} %, error over "
              f"successes {row['mimicry_error_mm']:.2f} mm, score {row['score']:.2f} mm")


def controller_settings(pairs: list[str], option: str, cls: type) -> dict:
    """``FIELD=VALUE`` pairs of ``option`` as settings of the dataclass ``cls`` (values parsed as JSON numbers or
    booleans)."""
    out = {}
    for pair in pairs:
        field, sep, value = pair.partition("=")
        if not sep or field not in cls.__dataclass_fields__:
            raise SystemExit(f"{option} {pair!r}: expected FIELD=VALUE with FIELD one of {cls.__name__}'s settings")
        try:
            out[field] = json.loads(value)
        except json.JSONDecodeError:
            raise SystemExit(f"{option} {pair!r}: VALUE must be a number or true/false") from None
    return out


def paired_differences(summary: dict, base: dict[str, tuple[list, list]], label: str) -> None:
    """Bench-by-bench differences of each controller's score (and error, over benches both succeeded on) from the
    same controller's in ``base`` (name -> scores, errors on the same benches, e.g. an earlier run's summary or the
    study's rows): mean and bootstrap 95 % interval (:func:`experiments.stats.bootstrap_ci`), so that a variant is
    compared with the same benches' noise removed; with ``base["limit"]`` also the ratio of the scores' means with
    its paired bootstrap interval."""
    from experiments.stats import bootstrap_ci, hierarchical_resamples, mean_of_successes
    for name, row in summary["controllers"].items():
        for other in dict.fromkeys((name, "limit")):
            if other not in base:
                continue
            scores, errors = (np.asarray(v, dtype=float) for v in base[other])
            score = np.array(row["scores"]) - scores
            ok = np.array(row["errors"], dtype=float) - errors  # NaN: either failed
            d, lo, hi = bootstrap_ci(score[None, :], lambda t: float(np.mean(t)))
            e, elo, ehi = bootstrap_ci(ok[None, :], mean_of_successes)
            print(f"  {name} minus {other} of {label}: score {d:+.3f} mm ({lo:+.3f} to {hi:+.3f}), error over benches "
                  f"both succeeded on {e:+.3f} mm ({elo:+.3f} to {ehi:+.3f}, {int(np.isfinite(ok).sum())} benches)")
            if other == "limit" and name != "limit":
                mine = np.array(row["scores"])
                _, benches = hierarchical_resamples(1, len(mine))  # the same benches for both: paired
                rlo, rhi = np.quantile(mine[benches].mean(axis=1) / scores[benches].mean(axis=1), [0.025, 0.975])
                r = mine.mean() / scores.mean()
                print(f"  {name} score / limit's of {label}: {r:.2f} ({rlo:.2f}-{rhi:.2f})")


def run_base(summary: dict, against: Path, option: str = "--against") -> dict[str, tuple[list, list]]:
    """An earlier run's scores and errors per controller (``--against``, or the ``option`` named in the error) on the
    same benches: a run of the same stream with at least as many (its first ``--benches``: every stream's benches are
    its first startable draws, each episode's noise seeded by its index)."""
    base = json.loads((against / "summary.json").read_text())
    n = summary["benches"]
    if base["stream"] != summary["stream"] or base["benches"] < n:
        raise SystemExit(f"{option} {against}: other benches ({base['benches']} of stream {base['stream']})")
    return {name: (row["scores"][:n], row["errors"][:n]) for name, row in base["controllers"].items()}


def study_base(summary: dict, episodes_csv: Path) -> dict[str, tuple[list, list]]:
    """The study's one-replicate rows (seed 0) of the same bench set from its per-episode CSV
    (``heldout_episodes.csv``, ``--against-study``): scores and errors per controller, first ``--benches`` benches."""
    import csv
    set_name = "stress" if summary["stream"] == "stress" else "heldout"
    if summary["stream"] not in ("stress", HELDOUT_SEED):
        raise SystemExit("--against-study: the study's rows are of the held-out and stress benches only")
    n, base = summary["benches"], {}
    with open(episodes_csv, newline="") as f:
        rows = [r for r in csv.DictReader(f) if r["bench_set"] == set_name and r["seed"] == "0"]
    for name in {r["controller"] for r in rows}:
        mine = sorted((r for r in rows if r["controller"] == name), key=lambda r: int(r["index"]))[:n]
        if len(mine) == n:
            errors = [float(r["mimicry_error_mm"]) if r["success"] == "1" else math.nan for r in mine]
            base[name] = ([FAILURE_SCORE_MM if math.isnan(e) else e for e in errors], errors)
    return base


def parse_args() -> argparse.Namespace:
    from agents.mpc import MPCController
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--benches", type=int, default=50)
    parser.add_argument("--out", default="runs/bench_mpc")
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--controllers", default="limit,mpc," + ",".join(SCRIPTED))
    parser.add_argument("--hindsight", action="store_true",
                        help="for mpc, also how far a sharp bank given the whole episode's measurements places the "
                             "case-C reference (several CPU s per episode)")
    parser.add_argument("--replan-every", type=int, default=None,
                        help="mpc replans every N control periods (default: the controller's, "
                             f"{MPCController.replan_every})")
    parser.add_argument("--mpc", action="append", default=[], metavar="FIELD=VALUE",
                        help="an MPCController setting for mpc, mpc_true and mpc_given_*, e.g. --mpc start_periods=0 "
                             "(repeatable; the variants of docs/actuator-study.md)")
    parser.add_argument("--limit", action="append", default=[], metavar="FIELD=VALUE",
                        help="a LimitController setting, e.g. --limit normal_margin=0.1 (repeatable)")
    parser.add_argument("--stream", type=int, default=HELDOUT_SEED,
                        help="draw the benches from this seed stream instead of the held-out one (an independent set)")
    parser.add_argument("--set", choices=("heldout", "stress"), default="heldout",
                        help="stress: the stress set (agents.heldout.stress_benches: outside v1's ranges) instead of "
                             "the held-out benches (--stream is then ignored)")
    parser.add_argument("--limit-sweep", action="store_true",
                        help="instead: limit at the nominal loads (default bench) with shorter and longer horizons "
                             "and more samples (does its figure still fall?)")
    parser.add_argument("--identify", metavar="FIT.json",
                        help="instead: mpc with this fit as prior against the drawing's prior (identify, then control)")
    parser.add_argument("--tip-deg", type=float, default=None, help="with --identify: the laboratory's tip friction")
    parser.add_argument("--against", metavar="OUT", default=None,
                        help="also print each controller's bench-by-bench differences from the same controller in "
                             "this earlier run's summary (same --benches and --stream)")
    parser.add_argument("--against-study", metavar="CSV", default=None,
                        help="also the differences from the study's rows of the same controller and its limit in "
                             "this per-episode CSV (docs/actuator-study/heldout_episodes.csv), with the ratio to "
                             "the limit")
    return parser.parse_args()


def print_table(summary: dict) -> None:
    """The run's table (markdown) and, per controller, its CPU, estimate and travel-profile lines."""
    print("| controller | episodes | success (95 % CI) | error over successes, mm (95 % CI) | score, mm (95 % CI) | "
          "/ limit | CPU s/episode |")
    for name, r in summary["controllers"].items():
        print(f"| `{name}` | {r['n_episodes']} | {100 * r['success_rate']:.1f} % ({100 * r['success_low']:.1f}-"
              f"{100 * r['success_high']:.1f}) | {r['mimicry_error_mm']:.2f} ({r['error_low_mm']:.2f}-"
              f"{r['error_high_mm']:.2f}) | {r['score']:.2f} ({r['score_low']:.2f}-{r['score_high']:.2f}) | "
              f"{r.get('ratio_to_limit', math.nan):.2f} | {r['cpu_s_per_episode']:.2f} |")
        if "decision_cpu_ms_mean" in r:
            print(f"  {name}: decision CPU {r['decision_cpu_ms_mean']:.2f} ms mean, {r['decision_cpu_ms_p95']:.2f} ms "
                  f"p95, {r.get('decision_cpu_ms_p99', math.nan):.2f} ms p99, {r.get('decision_cpu_ms_max', math.nan):.2f}"
                  f" ms max (replanning {r['planning_cpu_ms_mean']:.2f} ms mean, {r['planning_cpu_ms_p95']:.2f} ms p95; "
                  f"following the plan {r['following_cpu_ms_mean']:.2f} ms mean); estimator fallbacks "
                  f"{r['fallbacks']}; wall {r['wall_s']:.0f} s")
        else:
            print(f"  {name}: wall {r['wall_s']:.0f} s")
        if "reference_error_mm" in r:
            print(f"  {name}: the bank's case-C reference ends {r['reference_error_mm']:.3f} mm (mean) from the "
                  "bench's" + (f"; with hindsight {r['hindsight_reference_error_mm']:.3f} mm"
                               if "hindsight_reference_error_mm" in r else ""))
        if "profile_mm" in r:
            print(f"  {name}: distance to the case-C path at 10 %, 20 %, ..., 100 % of the travel (mean over "
                  f"{r['profile_episodes']} successes): " + " ".join(f"{v:.2f}" for v in r["profile_mm"])
                  + f" mm; made in the first fifth of the travel {r['error_first_fifth_mm']:.3f} mm of the error")
        if "estimate_rms" in r:
            print(f"  {name}: RMS error of the final estimate: " + ", ".join(f"{k} {v:.2f}" for k, v in r["estimate_rms"].items()))


def main() -> None:
    args = parse_args()
    out = Path(args.out)
    if args.identify:
        identify_then_control(args.identify, args.tip_deg, args.benches)
        return
    if args.limit_sweep:
        limit_sweep(out, args.workers, [27.8, 32.5, 37.5, 42.5, 47.5, 51.6])
        return
    names = args.controllers.split(",")
    for name in names:
        if name.startswith("mpc_given_"):
            given_groups(name)
    stream = "stress" if args.set == "stress" else args.stream
    summary = {"benches": args.benches, "stream": stream, "controllers": {}}
    from agents.limit import LimitController
    from agents.mpc import MPCController
    mpc = controller_settings(args.mpc, "--mpc", MPCController)
    if args.replan_every is not None:
        mpc["replan_every"] = args.replan_every
    own = {**SCRIPTED, "limit": controller_settings(args.limit, "--limit", LimitController)}
    for name in names:
        params = mpc if name.startswith("mpc") else own.get(name, {})
        tasks = [(name, params, i, args.benches, stream, args.hindsight) for i in range(args.benches)]
        wall = time.perf_counter()
        with pool_scope(args.workers) as ex:
            results = run_tasks(episode, tasks, ex, progress=True, desc=name,
                                checkpoint=TaskCheckpoint(out / "tasks"))
        wall = time.perf_counter() - wall
        from agents.heldout import Outcome
        outcomes = [Outcome(**{k: r[k] for k in Outcome.__dataclass_fields__}) for r in results]
        row = row_stats([[o.mimicry_error_mm for o in outcomes]], [[o.success for o in outcomes]],
                        FAILURE_SCORE_MM)
        row.update(cpu_s_per_episode=float(np.mean([r["cpu_s"] for r in results])), wall_s=wall,
                   scores=[o.mimicry_error_mm if o.success else FAILURE_SCORE_MM for o in outcomes],
                   errors=[o.mimicry_error_mm for o in outcomes])
        decisions = [d for r in results for d in r["decisions_cpu_s"]]
        if decisions:
            cpu = np.array([d[0] for d in decisions])
            planned = np.array([d[1] for d in decisions], dtype=bool)
            row.update(decision_cpu_ms_mean=1e3 * float(np.mean(cpu)),
                       decision_cpu_ms_p95=1e3 * float(np.percentile(cpu, 95)),
                       decision_cpu_ms_p99=1e3 * float(np.percentile(cpu, 99)),
                       decision_cpu_ms_max=1e3 * float(np.max(cpu)),
                       planning_cpu_ms_mean=1e3 * float(np.mean(cpu[planned])),
                       planning_cpu_ms_p95=1e3 * float(np.percentile(cpu[planned], 95)),
                       following_cpu_ms_mean=1e3 * float(np.mean(cpu[~planned])) if (~planned).any() else math.nan,
                       fallbacks=int(sum(r.get("fallbacks", 0) for r in results)))
        for key in ("reference_error_mm", "hindsight_reference_error_mm"):
            values = [r[key] for r in results if key in r]
            if values:
                row[key] = float(np.mean(values))
                row[key + "_per_bench"] = values
        profile = travel_profile(results)
        if profile is not None:
            row.update(profile_mm=profile[0].tolist(), error_first_fifth_mm=profile[1], profile_episodes=profile[2])
        if any("estimate_errors" in r for r in results):
            row["estimate_rms"] = {k: float(np.sqrt(np.mean([e ** 2 for r in results for e in r["estimate_errors"][k]])))
                                   for k in results[0]["estimate_errors"]}
        summary["controllers"][name] = row
    if "limit" in summary["controllers"]:
        limit = summary["controllers"]["limit"]["score"]
        for row in summary["controllers"].values():
            row["ratio_to_limit"] = row["score"] / limit
    write_json(summary, out / "summary.json")
    print_table(summary)
    if args.against:
        paired_differences(summary, run_base(summary, Path(args.against)), str(args.against))
    if args.against_study:
        paired_differences(summary, study_base(summary, Path(args.against_study)), "the study")
    print(json.dumps({k: v["score"] for k, v in summary["controllers"].items()}))


if __name__ == "__main__":
    main()

"""``triplanar evaluate``: any scripted, model-based (mpc, limit) or shipped controller on the held-out, stress or nominal benches, with the
statistics of :mod:`experiments.stats`.

Writes ``OUT/{bench_set}.csv`` (one row: the controller, design, bench set, the statistics columns of
:data:`experiments.tables.STATS_FIELDS` and the mean return with its interval, :data:`RETURN_FIELDS`),
``OUT/{bench_set}_episodes.csv`` (one row per episode and seed),
``OUT/{bench_set}.json`` (the same row with its settings) and ``OUT/{bench_set}.png``; each complete or not at all.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

from agents.controller_specs import ScriptedSpec, ShippedSpec
from agents.heldout import BENCH_SETS, FAILURE_SCORE_MM
from triplanar.workbench.executor import ExecutorLike, run_tasks

from . import tables
from .designs import Design, design_by_name
from .episodes import EpisodeBatch, outcome_table, parts_of, run_part
from .stats import return_stats, row_stats

DEFAULT_DESIGN = "default"
OWN_BENCH = "leave --design out to run it on its model card's bench"
STEEL_TIP_DEG = 8.0     # the nominal specimen's tip: what the model-based controllers assume on the default bench
# Gains tuned by the bench study on its tuning benches (docs/actuator-study/tuning.csv); the study re-tunes them.
PI_GAINS = {"kp": -20.0, "ki": 200.0}
ADAPTIVE_GAINS = {"gain_deg_per_m_s": -1e5}
# name -> (agents.bench_controllers factory, fixed tip of its hardware (None: the bench's), uses the assumed tip)
SCRIPTED = {"steel_tip": ("fixed_tip", None, False), "teflon_tip": ("fixed_tip", 3.0, False),
            "frictionless_tip": ("fixed_tip", 0.0, False), "tracking_tip": ("tracking_tip", None, False),
            "moment_matching": ("moment_matching", None, True), "pi_feedback": ("pi_feedback", None, True),
            "adaptive": ("adaptive", None, False)}
# Controllers that predict with the project's compiled model (agents/mpc.py, agents/limit.py): ``mpc`` from the
# bench's observations, ``limit`` with perfect knowledge of the specimen and state, and ``information_bound``
# (agents/information_bound.py): ``limit`` after mpc's start, its error and what the bench's sensors leave unknown in
# quadrature. The last two are references a design is judged against, not controllers a laboratory can build;
# ``mpc`` runs, but not in real time (docs/performance.md). Costly: ~17-60 s (mpc), ~3 s (limit) and ~5 s
# (information_bound) of CPU per episode on the default bench.
MODEL_BASED = {"mpc": ("mpc", None, False), "limit": ("limit", None, False),
               "information_bound": ("information_bound", None, False)}
REFERENCES = ("limit", "information_bound")
NOT_REAL_TIME = ("mpc", *REFERENCES)
BUILTIN = {**SCRIPTED, **MODEL_BASED}
RETURN_FIELDS = ("mean_return", "return_low", "return_high")   # the summary's mean episode return, 95 % interval


MAX_BENCHES = 100_000   # --n: about a day of CPU for a scripted controller; more is a typo
PART_BENCHES = 50       # benches per task: 3 seeds x 200 benches make 12 tasks, which two workers share evenly
MAX_SEED = 2**32 - 1


def runs_in_real_time(label: str) -> bool:
    """Whether the controller of a table's row (``best_scripted:NAME`` for the best scripted one) runs within the
    bench's 5 ms period: every scripted and learned controller; not ``mpc``, nor the references."""
    return label.split(":")[-1] not in NOT_REAL_TIME


def check_seeds(seeds: Sequence[int] | None) -> None:
    """Seeds are counted as independent replicates: each once, each a valid generator seed."""
    if seeds is None:
        return
    for s in seeds:
        if isinstance(s, bool) or not isinstance(s, int) or not 0 <= s <= MAX_SEED:
            raise ValueError(f"--seeds: expected integers in [0, {MAX_SEED}], got {s!r}")
    repeated = sorted({s for s in seeds if list(seeds).count(s) > 1})
    if repeated:
        raise ValueError(f"--seeds: seed(s) {', '.join(map(str, repeated))} given more than once (the same "
                         "episodes would be counted again, narrowing the intervals)")


def controller_names(zoo_dir: Path | None = None) -> list[str]:
    """Every controller ``evaluate`` knows: the scripted and model-based ones, then the shipped agents."""
    from agents.zoo import shipped_names
    return list(BUILTIN) + shipped_names(zoo_dir)


def design_names() -> list[str]:
    from .designs import DESIGNS
    return [DEFAULT_DESIGN] + [d.name for d in DESIGNS]


def scripted_batch(name: str, design: Design | None, bench_set: str, n: int, seed: int,
                   pi: dict[str, float] | None = None, adaptive: dict[str, float] | None = None,
                   label: str | None = None) -> EpisodeBatch:
    """The batch of scripted controller ``name`` on ``design`` (None: the default bench)."""
    factory, fixed_tip, assumes_tip = BUILTIN[name]
    bench_tip = design.tip_friction_deg if design is not None else None
    params: dict[str, float] = {}
    if assumes_tip:
        params["tip_friction_deg"] = bench_tip if bench_tip is not None else STEEL_TIP_DEG
    if factory == "pi_feedback":
        params.update(pi or PI_GAINS)
    if factory == "adaptive":
        params.update(adaptive or ADAPTIVE_GAINS)
    if factory == "mpc" and design is not None:  # it predicts with the hardware and the tip the laboratory built
        params.update(design.env_kwargs(), tip_friction_deg=design.tip_friction_deg)
    kwargs = tuple(sorted(design.env_kwargs().items())) if design is not None else ()
    return EpisodeBatch.of(ScriptedSpec(factory, tuple(params.items())), label or name, bench_set, n,
                           fixed_tip if fixed_tip is not None else bench_tip, kwargs, seed)


def batches_for(controller: str, design: Design | None, bench_set: str, n: int, seeds: Sequence[int] | None,
                zoo_dir: Path | None = None, default_named: bool = False) -> list[EpisodeBatch]:
    """One batch per seed of ``controller`` (scripted: noise replicates, default seed 0; shipped: its training
    seeds, default all of its card's). ``design`` None: the default bench, or a shipped agent's own card's bench
    unless ``default_named`` (the default bench was asked for by name: an agent of another bench is refused)."""
    if controller in BUILTIN:
        return [scripted_batch(controller, design, bench_set, n, s) for s in (seeds or [0])]
    from agents.zoo import bench_arguments, check_bench, check_layout, read_card
    card = read_card(controller, zoo_dir)
    check_layout(card, {**card["env_kwargs"], **(design.env_kwargs() if design is not None else {})})  # before any work
    if design is not None:   # an agent runs on its card's bench only
        check_bench(card, bench_arguments({**card["env_kwargs"], **design.env_kwargs(),
                                           "tip_friction_deg": design.tip_friction_deg}), f"design {design.name!r}",
                    OWN_BENCH)
    elif default_named:
        check_bench(card, bench_arguments({}), f"design {DEFAULT_DESIGN!r}", OWN_BENCH)
    chosen = list(seeds) if seeds else list(card["seeds"])
    unknown = [s for s in chosen if s not in card["seeds"]]
    if unknown:
        raise ValueError(f"--seeds {unknown}: shipped agent {controller!r} has seeds {card['seeds']}")
    kwargs = tuple(sorted(design.env_kwargs().items())) if design is not None else ()
    # Without a design the agent runs on its own hardware (its card's arguments), known tip included.
    tip = design.tip_friction_deg if design is not None else card["env_kwargs"].get("tip_friction_deg")
    return [EpisodeBatch.of(ShippedSpec(controller, s, str(zoo_dir) if zoo_dir else None), controller, bench_set,
                            n, tip, kwargs) for s in chosen]


@dataclass
class Evaluation:
    controller: str
    design: str
    bench_set: str
    seeds: list[int]
    stats: dict[str, Any]
    outcomes: list[list[Any]]    # per seed, per bench (agents.heldout.Outcome)
    wall_s: float


def evaluate(controller: str, *, design: str | None = None, bench_set: str = "heldout", n: int = 200,
             seeds: Sequence[int] | None = None, executor: ExecutorLike = None, zoo_dir: Path | None = None,
             progress: bool = True) -> Evaluation:
    """Run ``controller`` on ``n`` benches of ``bench_set`` (the nominal set has its 12 loads) for each seed, on
    ``design`` (None: the default bench, or a shipped agent's card's; a shipped agent asked to run on another bench,
    ``"default"`` included, is refused naming the first argument that differs)."""
    from agents import zoo
    zoo_dir = Path(zoo_dir or zoo.ZOO_DIR)   # named explicitly in every task
    names = controller_names(zoo_dir)
    if controller not in names:
        raise ValueError(f"unknown controller {controller!r}; choose from {names}")
    if bench_set not in BENCH_SETS:
        raise ValueError(f"unknown bench set {bench_set!r}; choose from {list(BENCH_SETS)}")
    if isinstance(n, bool) or not isinstance(n, int) or not 0 < n <= MAX_BENCHES:
        raise ValueError(f"--n: expected a number of benches in [1, {MAX_BENCHES}], got {n!r}")
    check_seeds(seeds)
    if design is not None and design not in design_names():
        raise ValueError(f"unknown design {design!r}; choose from {design_names()}")
    chosen = None if design in (None, DEFAULT_DESIGN) else design_by_name(design)
    batches = batches_for(controller, chosen, bench_set, n, seeds, zoo_dir, default_named=design == DEFAULT_DESIGN)
    started = time.perf_counter()
    results = run_in_parts(batches, executor, progress, f"{controller} on {bench_set}")
    errors, success = outcome_table(batches, results)
    returns = [[o.episode_return for o in r] for r in results]
    return Evaluation(controller, design or DEFAULT_DESIGN, bench_set, [b.seed for b in batches],
                      {**row_stats(errors, success, FAILURE_SCORE_MM), **return_stats(returns)}, results,
                      time.perf_counter() - started)


def run_in_parts(batches: Sequence[EpisodeBatch], executor: ExecutorLike, progress: bool,
                 desc: str) -> list[list[Any]]:
    """Each batch's outcomes, run as parts of :data:`PART_BENCHES` benches (one task per part: a batch per seed
    would leave a worker idle whenever the seeds do not divide among the workers; a part's episodes are numbered
    as in its whole batch, so the outcomes are the whole batch's)."""
    parts = [(i, part) for i, b in enumerate(batches) for part in parts_of(b, PART_BENCHES)]
    done = run_tasks(run_part, [part for _, part in parts], executor=executor, progress=progress, desc=desc)
    results: list[list[Any]] = [[] for _ in batches]
    for (i, _), outcomes in zip(parts, done):
        results[i] += outcomes
    return results


def write(evaluation: Evaluation, out_dir: str | Path) -> list[Path]:
    """The CSV, episodes CSV, JSON and PNG of an evaluation, replacing an earlier set in ``out_dir`` as a whole
    (:func:`triplanar.output_set.replace_set`: a kill leaves the earlier four files or the new four)."""
    from triplanar.output_set import replace_set

    from . import bench_plots
    e, stem = evaluation, evaluation.bench_set
    names = [f"{stem}.csv", f"{stem}_episodes.csv", f"{stem}.json", f"{stem}.png"]

    def write_set(folder: Path) -> None:
        paths = [folder / name for name in names]
        tables.write_csv(paths[0], ["controller", "design", "bench_set", *tables.STATS_FIELDS, *RETURN_FIELDS],
                         [[e.controller, e.design, e.bench_set, *tables.stats_cells(e.stats),
                           *(tables.fmt(e.stats[k]) for k in RETURN_FIELDS)]])
        tables.write_csv(paths[1], tables.EPISODE_FIELDS,
                         [tables.episode_cells(o, seed) for seed, outcomes in zip(e.seeds, e.outcomes)
                          for o in outcomes])
        tables.write_json(paths[2], {"controller": e.controller, "design": e.design, "bench_set": e.bench_set,
                                     "seeds": e.seeds, "wall_s": e.wall_s, **e.stats})
        label = e.controller if e.design == DEFAULT_DESIGN else f"{e.controller} ({e.design})"
        bench_plots.rows_plot(paths[3], [(label, e.bench_set, e.stats, e.outcomes)],
                              f"TriPlanarShear-v1, {e.design} bench, {e.bench_set} benches")

    return replace_set(out_dir, names, write_set)

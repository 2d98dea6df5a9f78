"""Regenerate the paper's results section from the model and a laboratory dataset.

:func:`reproduce` simulates cases A-F (one task per run, through any executor of :mod:`triplanar.executor`),
computes the tables and the claim verdicts; :func:`write_outputs` draws the figures (one task per figure: the
worker returns the PNG's bytes and this process writes it, so a Ray worker on another machine works too) and writes ``results.json``, ``tables.md``, ``claims.md`` and
``report.md`` into one directory.
"""

from __future__ import annotations

import hashlib
import json
import os
import tempfile
import time
from collections import defaultdict
from contextlib import nullcontext
from pathlib import Path
from typing import Sequence


from ..atomic import write_atomic
from ..effects import Effect
from ..measurement import MeasuredTest, read_measurements
from ..specimen import Foundation, Specimen, reference
from ..executor import ExecutorLike, SerialExecutor, executor_scope, pool_scope, run_tasks
from . import claims as C
from . import figures as Fg
from . import tables as T
from .cases import CASE_TITLES, Run, Simulator, reference_runs, scaled_runs
from .reproduction import Reproduction

FIG6_LOAD_N = 32.5
DEFAULT_DATA = Path(__file__).resolve().parents[2] / "data" / "lab_traces.csv"


def default_data_path() -> Path:
    """The shipped laboratory dataset (``data/lab_traces.csv`` in the repository)."""
    return DEFAULT_DATA


def reproduce(data_path: str | os.PathLike[str] | None = None, specimen: Specimen | None = None,
              foundation: Foundation | None = None, effects: Sequence[Effect] = (),
              progress: bool = True, executor: ExecutorLike = "serial") -> Reproduction:
    """Read the dataset, simulate every case (through ``executor``; default in this process), compute tables and
    claims (no files written)."""
    t0 = time.perf_counter()
    ref_specimen, ref_foundation = reference()
    specimen, foundation = specimen or ref_specimen, foundation or ref_foundation
    path = Path(data_path) if data_path is not None else default_data_path()
    rest = specimen.contact_points_m
    tests = read_measurements(path, rest_positions=rest)
    by_load: dict[float, list[MeasuredTest]] = defaultdict(list)
    for test in tests:
        by_load[test.shear_force_N].append(test)
    loads = sorted(by_load)
    simulator = Simulator(specimen, foundation, tuple(effects))
    runs = reference_runs(loads) + scaled_runs(specimen)
    t1 = time.perf_counter()
    unique = list({run.key: run for run in runs}.values())
    results = run_tasks(simulator.simulate_run, unique, executor, progress, desc="simulating cases A-F")
    simulator.results.update((run.key, result) for run, result in zip(unique, results))
    t2 = time.perf_counter()
    case_rows = {case: [T.case_row(r, simulator(r), by_load[r.force_N], rest) for r in runs
                        if r.family == case] for case in "ABC"}
    data_rows = [T.data_row(f, by_load[f], rest) for f in loads]
    scaled_rows = [T.scaled_row(r, simulator(r), simulator(Run(r.family, "B", r.force_N, r.factor, r.travel_m)))
                   for r in runs if r.family in "DEF" and r.case == "A"]
    rep = Reproduction(path, loads, dict(by_load), rest, foundation, simulator, runs, case_rows, data_rows,
                       scaled_rows, [], {})
    rep.claims = C.evaluate(rep)
    t3 = time.perf_counter()
    rep.seconds = {"read": t1 - t0, "simulate": t2 - t1, "tables_and_claims": t3 - t2}
    return rep


# -- figures ---------------------------------------------------------------------------------------

def figure_specs(rep: Reproduction) -> list[Fg.FigureSpec]:
    """Fig. 6 and Figs. 11-16 analogues as plain data."""
    sim, specs = rep.simulator, []
    fig6_load = min(rep.loads, key=lambda f: abs(f - FIG6_LOAD_N))
    specs.append(Fg.FigureSpec(
        "fig06_traces.png", f"Laboratory dataset: the {len(rep.tests_by_load[fig6_load])} tests at {fig6_load:g} N "
        "(overhead view)", (Fg.Panel(f"{fig6_load:g} N", tuple(Fg.measured_trace(t.positions)
                                                                for t in rep.tests_by_load[fig6_load])),),
        1, rep.foundation, rest_positions=rep.rest, size=5.0))
    for case, number in zip("ABC", (11, 12, 13)):
        panels = []
        for run in (r for r in rep.runs if r.family == case):
            traces = (Fg.model_trace(sim(run).contact_points),) + tuple(
                Fg.measured_trace(t.positions) for t in rep.tests_by_load[run.force_N])
            panels.append(Fg.Panel(f"{run.force_N:g} N", traces))
        specs.append(Fg.FigureSpec(f"fig{number}_case_{case}.png", CASE_TITLES[case], tuple(panels), 4, rep.foundation))
    for family, number in zip("DEF", (14, 15, 16)):
        panels = []
        for run in sorted((r for r in rep.runs if r.family == family and r.case == "A"),
                          key=lambda r: (r.row, r.column)):
            other = Run(family, "B", run.force_N, run.factor, run.travel_m)
            label = {"D": "size", "E": "mass", "F": "scale"}[family]
            panels.append(Fg.Panel(f"{label} x{run.factor:g}, {run.force_N:.4g} N",
                                   (Fg.model_trace(sim(other).contact_points),
                                    Fg.measured_trace(sim(run).contact_points))))
        specs.append(Fg.FigureSpec(f"fig{number}_case_{family}.png", CASE_TITLES[family], tuple(panels), 3,
                                   rep.foundation))
    return specs


def render_png(spec: Fg.FigureSpec) -> bytes:
    """Draw ``spec`` and return the PNG's bytes (a task: the result, not a file on the worker, comes back)."""
    with tempfile.TemporaryDirectory(prefix="triplanar-fig-") as tmp:
        return Fg.render(spec, tmp).read_bytes()


def render_figures(specs: list[Fg.FigureSpec], out_dir: Path, workers: int = 2, progress: bool = True,
                   executor: ExecutorLike = None) -> list[Path]:
    """Draw every figure (each is independent) through ``executor``, or when ``None`` in ``workers`` processes
    (in this process for 1); each PNG is written here, atomically."""
    if executor is None:
        scope = pool_scope(workers) if workers > 1 and len(specs) > 1 else nullcontext(SerialExecutor())
    else:
        scope = executor_scope(executor, len(specs))
    with scope as ex:
        pngs = run_tasks(render_png, specs, ex, progress, desc="drawing figures")
    paths = []
    for spec, png in zip(specs, pngs):
        path = out_dir / spec.name
        write_atomic(path, lambda tmp: tmp.write_bytes(png))
        paths.append(path)
    return paths


# -- files -------------------------------------------------------------------------------------------

def results_json(rep: Reproduction) -> dict:
    def case(r: T.CaseRow) -> dict:
        return {"case": r.case, "force_N": r.force_N, "distance_to_data": r.distance.as_dict(),
                "dilation_end_mm": (r.dilation_m * 1e3).tolist(), "rotation_end_deg": r.rotation_deg,
                "peak_speed_m_s": r.peak_speed_m_s, "status": r.status, "travel_m": r.travel_m}

    def data(r: T.DataRow) -> dict:
        return {"force_N": r.force_N, "n_tests": r.n_tests, "dilation_mean_mm": (r.dilation_mean_m * 1e3).tolist(),
                "dilation_sd_mm": (r.dilation_sd_m * 1e3).tolist(), "rotation_mean_deg": r.rotation_mean_deg,
                "rotation_sd_deg": r.rotation_sd_deg, "end_travel_m": list(r.end_travel_m),
                "peak_speed_m_s": r.peak_speed_m_s}

    def scaled(r: T.ScaledRow) -> dict:
        return {"case": r.family, "factor": r.factor, "force_N": r.force_N, "A_vs_B": r.distance.as_dict(),
                "dilation_A_mm": (r.dilation_A_m * 1e3).tolist(), "dilation_B_mm": (r.dilation_B_m * 1e3).tolist(),
                "rotation_A_deg": r.rotation_A_deg, "rotation_B_deg": r.rotation_B_deg, "status": list(r.status)}

    return {"data": rep.data_path.name, "data_sha256": hashlib.sha256(rep.data_path.read_bytes()).hexdigest(),
            "loads_N": rep.loads,
            "cases": {k: [case(r) for r in v] for k, v in rep.case_rows.items()},
            "dataset": [data(r) for r in rep.data_rows], "scaled": [scaled(r) for r in rep.scaled_rows],
            "claims": [{"number": c.number, "claim": c.claim, "figure": c.figure, "verdict": c.verdict,
                        "details": c.details} for c in rep.claims]}


def tables_md(rep: Reproduction) -> str:
    parts = ["## Laboratory dataset\n", T.data_table_md(rep.data_rows)]
    for case in "ABC":
        parts += [f"\n## Case {case}: model vs dataset\n",
                  "Distance = horizontal distance from each measured sample to the model at the same CP1 travel, "
                  "pooled over the repeats; dilation and rotation are the model's at the end of its travel.\n\n",
                  T.case_table_md(rep.case_rows[case])]
    parts += ["\n## Cases D, E, F: with (A) vs without (B) end friction\n",
              "Distances and dilations at reference size (divided by the length factor c for D and F).\n\n",
              T.scaled_table_md(rep.scaled_rows)]
    return "".join(parts)


def report_md(rep: Reproduction, figure_names: list[str]) -> str:
    figs = "\n".join(f"![{name}]({name})" for name in figure_names)
    return (f"# Paper reproduction (generated)\n\nDataset: `{rep.data_path.name}`, loads "
            f"{', '.join(f'{f:g}' for f in rep.loads)} N.\n\n## Claims\n\n{C.claims_table_md(rep.claims)}\n"
            f"{tables_md(rep)}\n## Figures\n\n{figs}\n")


def _write_text(path: Path, text: str) -> None:
    write_atomic(path, lambda tmp: tmp.write_text(text, encoding="utf-8"))


def write_outputs(rep: Reproduction, out_dir: str | os.PathLike[str], workers: int = 2,
                  progress: bool = True, executor: ExecutorLike = None) -> list[Path]:
    """Figures (through ``executor``, or ``workers`` processes), ``results.json``, ``tables.md``, ``claims.md``,
    ``report.md`` in ``out_dir``."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    paths = render_figures(figure_specs(rep), out, workers, progress, executor)
    rep.seconds["figures"] = time.perf_counter() - t0
    _write_text(out / "results.json", json.dumps(results_json(rep), indent=1) + "\n")
    _write_text(out / "tables.md", tables_md(rep))
    _write_text(out / "claims.md", C.claims_table_md(rep.claims))
    _write_text(out / "report.md", report_md(rep, [p.name for p in paths]))
    return paths + [out / n for n in ("results.json", "tables.md", "claims.md", "report.md")]


def run_paper(out_dir: str | os.PathLike[str], data_path: str | os.PathLike[str] | None = None,
              specimen: Specimen | None = None, foundation: Foundation | None = None,
              effects: Sequence[Effect] = (), workers: int | None = None, progress: bool = True,
              executor: ExecutorLike = None) -> Reproduction:
    """``triplanar paper`` in one call: :func:`reproduce` then :func:`write_outputs` into ``out_dir``, both
    through ``executor`` (``None``: a pool of ``workers`` processes, default up to 2, made for the call)."""
    workers = workers if workers is not None else min(2, os.cpu_count() or 1)
    scope = pool_scope(workers) if executor is None else executor_scope(executor)
    with scope as ex:
        rep = reproduce(data_path, specimen, foundation, effects, progress, ex)
        write_outputs(rep, out_dir, workers, progress, ex)
    return rep

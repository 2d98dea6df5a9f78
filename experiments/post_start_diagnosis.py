"""What happens right after a student's opening excitation (``--start-periods``) on a judge bench: the student drives
(as ``train_student --judge`` runs it: the bench's index seeds the noise) with ``limit`` alongside it, shown the
same true state each period, so each decision has the student's action and ``limit``'s in the same state; then the
same bench with ``limit`` driving from the same excitation (the student's ``start`` played first). Per decision:
both actions (thrust, tip offset, normalised), the smallest normal reaction as a share of the load (``lift_off``
ends the episode at zero) and the smallest distance of a contact point from crossing onto another plane, in mm
(``left_plane`` at zero).

``PYTHONPATH=. python -m experiments.post_start_diagnosis --student DIR --benches 11 41 43 [--labels L ...]``
prints JSON; ``--handover K ...`` adds the outcome when the student drives up to decision K and ``limit`` from it
on (the last decision from which ``limit`` still saves the bench); with ``--labels`` each decision's frame stack also gets its distance (normalised as the student
normalises) to the nearest labelled decision of the folders.
"""

from __future__ import annotations

import argparse
import json
from typing import Any

import numpy as np

from agents.heldout import TUNING_SEED
from agents.limit import LimitController
from agents.student import StudentController
from envs.prediction import crossing_slopes, margin_intrusion, new_workspace
from envs.triplanar_shear_v1 import TriPlanarShearV1Env
from triplanar import kernel as K

from .distill_labels import bench_of_draw, load_labels
from .train_student import judge_draws


def margins(env: Any) -> tuple[float, float]:
    """(smallest normal reaction / load, smallest distance of a contact point from another plane, mm) now."""
    state = env.unwrapped.get_state()
    ws = new_workspace()
    least_normal = 1.0 - margin_intrusion(state.y, state.p, state.st, 1.0, ws)
    cp, slopes = np.empty((3, 3)), crossing_slopes(state.p)
    K.contact_points_ws(state.y, state.p, cp, ws)
    gaps, pair = [], 0
    for i in range(3):
        for j in range(3):
            if i != j:
                if slopes[pair] > 0.0:
                    gaps.append(K.plane_gap(cp, state.p, i, j, pair) / slopes[pair])
                pair += 1
    return float(least_normal), 1e3 * float(min(gaps)) if gaps else float("nan")


def replay(student: Any, bench: Any, seed: int, limit_drives_after: int | None,
           limit_settings: dict[str, float] | None = None) -> dict[str, Any]:
    """One episode: the student (or any controller, ``mpc``) drives (``limit_drives_after`` None) or plays its start
    and ``limit`` drives from decision ``limit_drives_after``; ``limit`` labels every decision either way."""
    env = TriPlanarShearV1Env(**getattr(student, "env_kwargs", {}))
    obs, info = env.reset(seed=seed, options={"bench": bench})
    teacher = LimitController(**(limit_settings or {}))
    teacher.bind(env)
    teacher.reset(bench.load_N, env.config)
    student.reset(bench.load_N, env.config)
    rows = []
    while True:
        least_normal, plane_mm = margins(env)
        own, label = student.act(obs), teacher.act(obs)
        drive = limit_drives_after is not None and len(rows) >= limit_drives_after
        action = label if drive else own
        rows.append({"student": [round(float(v), 3) for v in own], "limit": [round(float(v), 3) for v in label],
                     "least_normal_share": round(least_normal, 3), "least_plane_mm": round(plane_mm, 3),
                     "obs": [float(v) for v in obs]})
        obs, _, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            break
    return {"reason": info["reason"], "steps": len(rows), "success": bool(info["is_success"]),
            "mimicry_error_mm": float(info["mimicry_error_mm"]), "decisions": rows}


def stacks(student: StudentController, decisions: list[dict]) -> np.ndarray:
    """The student's normalised frame stacks along an episode (its ``features``, replayed)."""
    student.reset(0.0, None)
    return np.array([student.features(np.asarray(d["obs"], np.float32)) for d in decisions])


def labelled_stacks(student: StudentController, folders: list[str]) -> np.ndarray:
    """The labelled frame stacks of ``folders``, normalised as the student normalises."""
    return student.normalised(load_labels(folders, student.n_frames)["x"])


def nearest_label(student: StudentController, labelled: np.ndarray, decisions: list[dict]) -> list[float]:
    """Each decision's distance (normalised units) to the nearest of the ``labelled`` frame stacks."""
    here = stacks(student, decisions)
    return [float(np.sqrt(((labelled - h) ** 2).sum(axis=1)).min()) for h in here]


def diagnose(folder: str, benches: list[int], labels: list[str] | None, handovers: list[int] = (),
             with_mpc: bool = False, limit_settings: dict[str, float] | None = None) -> dict[str, Any]:
    student = StudentController.load(folder)
    draws = judge_draws(max(benches) + 1, student.env_kwargs)
    labelled = labelled_stacks(student, labels) if labels else None
    found = {}
    for index in benches:
        draw, bench = draws[index]
        assert bench_of_draw(TUNING_SEED, draw, student.env_kwargs) is not None
        runs = {"student": replay(student, bench, index, None, limit_settings),
                "limit_after_start": replay(student, bench, index, len(student.start), limit_settings)}
        for k in handovers:   # the student drives up to decision k, limit from it on
            run = replay(student, bench, index, k, limit_settings)
            runs[f"limit_from_{k}"] = {key: run[key] for key in ("reason", "steps", "success", "mimicry_error_mm")}
        if with_mpc:   # mpc, which sees only the bench, drives from its own start
            from agents.mpc import MPCController
            runs["mpc"] = replay(MPCController(), bench, index, None, limit_settings)
            for d in runs["mpc"]["decisions"]:
                d.pop("obs")
        if labelled is not None:
            for run in (runs["student"], runs["limit_after_start"]):
                for d, gap in zip(run["decisions"], nearest_label(student, labelled, run["decisions"])):
                    d["nearest_label"] = round(gap, 3)
        for run in (runs["student"], runs["limit_after_start"]):
            for d in run["decisions"]:
                d.pop("obs")
        found[str(index)] = {"draw": draw, **runs}
    return found


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m experiments.post_start_diagnosis",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("--student", required=True, help="a student folder (experiments.train_student)")
    parser.add_argument("--benches", type=int, nargs="+", required=True, help="judge benches' indices")
    parser.add_argument("--labels", nargs="*", help="label folders for the nearest-label distance")
    parser.add_argument("--handover", type=int, nargs="*", default=[], metavar="K", help="also: the student "
                        "drives up to decision K and limit from it on (the outcome only)")
    parser.add_argument("--mpc", action="store_true", help="also: mpc drives (its actions beside limit's)")
    parser.add_argument("--limit", action="append", default=[], metavar="FIELD=VALUE",
                        help="a LimitController setting (repeatable), e.g. plane_margin_m=0.0005")
    args = parser.parse_args(argv)
    try:
        settings = {k: float(v) for k, v in (item.split("=", 1) for item in args.limit)}
    except ValueError:
        parser.error(f"--limit takes FIELD=NUMBER, got {args.limit}")
    from dataclasses import fields
    known = {f.name for f in fields(LimitController)}
    if set(settings) - known:
        parser.error(f"--limit: no LimitController field {sorted(set(settings) - known)}; fields: {sorted(known)}")
    print(json.dumps(diagnose(args.student, args.benches, args.labels, args.handover, args.mpc, settings),
                     indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

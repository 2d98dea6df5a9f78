"""Where a student's action departs from its teacher's, along the episode: for label folders (any round; a later
round's driver is a student, so its shards hold what the student did and what the teacher would have done), per
span of decision indices, the spread of the teacher's labels (the RMS error of the best constant guess for that
span), the RMS error of a student replayed on the recorded observations (``--student``: its action after the same
observation history) and that of the action that ran; then every failed episode of the folders: its reason, its
length and the first decision whose action ran more than 0.3 from the label.

``PYTHONPATH=. python -m experiments.student_diagnosis --labels DIR [DIR ...] [--student DIR]`` prints JSON. What it
reads from it (docs/notes/student-experiments.md): a student whose error at a span is no smaller than the label
spread there cannot tell the teacher's action from what it has seen so far.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from agents.student import StudentController

from .distill_labels import label_shards

SPANS = ((0, 1), (1, 2), (2, 4), (4, 8), (8, 16), (16, 32), (32, 10_000))
DEPARTS = 0.3   # an action this far from the label (either component) departs from it


def _rms(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(((a - b) ** 2).mean())) if len(a) else float("nan")


def diagnose(folders: list[Path], student: StudentController | None) -> dict:
    by_span: dict = {span: {"label": [], "student": [], "ran": []} for span in SPANS}
    failures = []
    for path in label_shards(folders):
        with np.load(path, allow_pickle=False) as s:
            if not bool(s["started"]):
                continue
            label, ran, obs = s["expert_action"], s["action"], s["obs"]
            if student is not None:
                student.reset(0.0, None)
                own = np.array([student.act(o) for o in obs])
            for lo, hi in SPANS:
                by_span[(lo, hi)]["label"].append(label[lo:hi])
                by_span[(lo, hi)]["ran"].append(ran[lo:hi])
                if student is not None:
                    by_span[(lo, hi)]["student"].append(own[lo:hi])
            if not bool(s["success"]):
                far = np.flatnonzero(np.abs(ran - label).max(axis=1) > DEPARTS)
                failures.append({"shard": path.name, "reason": str(s["reason"]), "steps": int(s["steps"]),
                                 "first_departure": int(far[0]) if len(far) else None})
    spans = []
    for (lo, hi), parts in by_span.items():
        label = np.concatenate(parts["label"])
        row = {"decisions": f"{lo}-{min(hi, 10_000) - 1}", "n": int(len(label)),
               "label_spread_rms": _rms(label, label.mean(axis=0)) if len(label) else float("nan"),
               "ran_vs_label_rms": _rms(np.concatenate(parts["ran"]), label)}
        if student is not None:
            row["student_vs_label_rms"] = _rms(np.concatenate(parts["student"]), label)
        spans.append(row)
    return {"spans": spans, "failures": failures, "episodes": sum(len(p) > 0 for p in by_span[SPANS[0]]["label"])}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m experiments.student_diagnosis",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("--labels", nargs="+", required=True, help="label folders (experiments.distill_labels)")
    parser.add_argument("--student", help="a student folder replayed on the recorded observations")
    args = parser.parse_args(argv)
    student = StudentController.load(args.student) if args.student else None
    print(json.dumps(diagnose([Path(f) for f in args.labels], student), indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Where a student's action departs from its teacher's, along the episode: for label folders (any round; a later
round's driver is a student, so its shards hold what the student did and what the teacher would have done), per
span of decision indices, the spread of the teacher's labels (the RMS error of the best constant guess for that
span), the RMS error of a student replayed on the recorded observations (``--student``: its action after the same
observation history) and that of the action that ran; then every failed episode of the folders: its reason, its
length and the first decision whose action ran more than 0.3 from the label.

``PYTHONPATH=. python -m experiments.student_diagnosis --labels DIR [DIR ...] [--student DIR]`` prints JSON
(``--student DIR --validation`` instead of ``--labels``: the student's own validation episodes). What it
reads from it (docs/notes/student-experiments.md): a student whose error at a span is no smaller than the label
spread there cannot tell the teacher's action from what it has seen so far.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from agents.student import StudentController

from .distill_labels import label_shards, truth_values

SPANS = ((0, 1), (1, 2), (2, 4), (4, 8), (8, 16), (16, 32), (32, 10_000))
DEPARTS = 0.3   # an action this far from the label (either component) departs from it


def _rms(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(((a - b) ** 2).mean())) if len(a) else float("nan")


def diagnose(folders: list[Path], student: StudentController | None, shards: list[Path] | None = None) -> dict:
    """``shards``: exactly these shard files instead of the folders' (:func:`validation_shards`)."""
    by_span: dict = {span: {"label": [], "student": [], "ran": []} for span in SPANS}
    failures = []
    for path in label_shards(folders) if shards is None else shards:
        with np.load(path, allow_pickle=False) as s:
            if not bool(s["started"]):
                continue
            label, ran, obs = s["expert_action"], s["action"], s["obs"]
            if student is not None:
                student.reset(0.0, None)
                if student.given_names:   # a privileged student (train_student --given truth): the bench's truth
                    student.given = truth_values(s["truth"], student.given_names)
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


def validation_shards(folder: Path) -> list[Path]:
    """The shards of the episodes a student held out for validation (its training record's
    ``validation_episodes``, counted over the started shards its run read, in order)."""
    from .train_student import CHECKPOINT, SPEC, load_checkpoint_meta
    record = json.loads((folder / SPEC).read_text())["training"]
    held = set(record["validation_episodes"])
    started = []
    for path in load_checkpoint_meta(folder / CHECKPOINT)["shards"]:
        with np.load(path, allow_pickle=False) as s:
            if bool(s["started"]):
                started.append(Path(path))
    return [path for k, path in enumerate(started) if k in held]


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m experiments.student_diagnosis",
                                     description=__doc__.split("\n\n")[0])
    parser.add_argument("--labels", nargs="+", default=[], help="label folders (experiments.distill_labels)")
    parser.add_argument("--student", help="a student folder replayed on the recorded observations")
    parser.add_argument("--validation", action="store_true", help="instead of --labels: the student's own "
                        "validation episodes (held out of its training)")
    args = parser.parse_args(argv)
    if bool(args.labels) == args.validation or (args.validation and not args.student):
        parser.error("give --labels, or --validation with --student")
    student = StudentController.load(args.student) if args.student else None
    shards = validation_shards(Path(args.student)) if args.validation else None
    print(json.dumps(diagnose([Path(f) for f in args.labels], student, shards), indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

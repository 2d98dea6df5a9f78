"""Fingerprint the workbench's verdicts, to prove that a speed-up or a change of structure changes no report.

Diagnoses five small datasets of the project's generator (4 loads x 2 repeats, 2 folds, every default candidate):
a hidden plane tilt, rangefinder gain and time offset without the model-form step, end friction with it, and a
wrong given cohesion (refit), then compares the JSON reports, timing fields removed, with an earlier record::

    .venv/bin/python benchmarks/workbench_fingerprint.py --save /tmp/before.json     # before the change
    .venv/bin/python benchmarks/workbench_fingerprint.py --compare /tmp/before.json  # after it

Prints the CPU seconds of the five diagnoses and, per report, whether it is the same to the last digit (JSON floats
keep every bit), else the fields that differ. About 30 CPU s. ``benchmarks/fingerprint.py`` does the same for the
traces and the environments' rollouts.
"""

from __future__ import annotations

import json
import sys
import time
from typing import Any

LOADS = (27.8, 35.0, 45.0, 55.6)
TIMING = ("seconds", "fit_seconds")


def _without_timing(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _without_timing(v) for k, v in value.items() if k not in TIMING}
    if isinstance(value, list):
        return [_without_timing(v) for v in value]
    return value


def record() -> dict[str, Any]:
    from triplanar import make_effect
    from triplanar.labdata import generate_lab_data
    from triplanar.workbench import Diagnoser, ModelSpec
    from triplanar.workbench.scenarios import HIDDEN_EFFECTS

    def diagnose(effect: str, seed: int, model_form: bool, given: str | None = None) -> dict[str, Any]:
        tests, _ = generate_lab_data(loads=LOADS, repeats=2, effects=[make_effect(effect)], seed=seed)
        base = ModelSpec.from_effects([make_effect(given)]) if given else None
        diag = Diagnoser(folds=2, progress=False, model_form=model_form, executor="serial").fit(tests, base)
        return _without_timing(json.loads(json.dumps(diag.report_, default=repr)))

    out = {name: diagnose(HIDDEN_EFFECTS[name][0], 1, name == "end_friction")
           for name in ("plane_tilt", "rangefinder_gain", "time_offset", "end_friction")}
    out["refit"] = diagnose("cohesion:c_N=0.35", 2, False, given="cohesion:c_N=0.15")
    return out


def differences(before: Any, after: Any, path: str = "") -> list[str]:
    """The paths at which two reports differ (a key on one side only counts)."""
    if isinstance(before, dict) and isinstance(after, dict):
        return [d for k in sorted(set(before) | set(after), key=str)
                for d in ([f"{path}/{k}: only on one side"] if (k in before) != (k in after)
                          else differences(before[k], after[k], f"{path}/{k}"))]
    if isinstance(before, list) and isinstance(after, list) and len(before) == len(after):
        return [d for i, (a, b) in enumerate(zip(before, after)) for d in differences(a, b, f"{path}[{i}]")]
    return [] if before == after else [f"{path}: {str(before)[:60]} -> {str(after)[:60]}"]


def main() -> int:
    from fingerprint import save_or_compare      # (benchmarks/ is on the path when a script of it runs)
    args = save_or_compare(__doc__.splitlines()[0], "JSON")
    started = time.process_time()
    current = record()
    print(f"five diagnoses: {time.process_time() - started:.1f} CPU s")
    if args.save:
        with open(args.save, "w") as f:
            json.dump(current, f)
        print(f"wrote {len(current)} reports to {args.save}")
        return 0
    with open(args.compare) as f:
        before = json.load(f)
    same = True
    for name in sorted(before):
        found = differences(before[name], current.get(name))
        print(f"{name}: " + ("the same" if not found else f"{len(found)} differences: " + "; ".join(found[:5])))
        same = same and not found
    return 0 if same else 1


if __name__ == "__main__":
    sys.exit(main())

"""The instruments' given numbers in the audit: a calibration run's kept evidence re-decided with today's rules and
with the rules before them (2026-11-29, issue 33; ``docs/notes/workbench-calibration-tuning.md``).

Before: the audit's rule of commit ee5b8f5 (a number said whenever it explains; a twin from the linearised screen
alone), the instruments' audit entries removed and the instrument causes that came only through their columns taken
out of the specimen numbers' groups, every combination step named. Exact for evidence gathered with
``MAX_AUDITED_INSTRUMENTS`` (the specimen's audit is then what it was). Prints the counts of each and every dataset
whose verdict, named entries or confidence differ::

    PYTHONPATH=. python benchmarks/given_audit_variants.py OUT      # OUT of workbench_calibration.py run
"""

import glob
import json
import sys
from dataclasses import replace
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
import workbench_calibration as calib
from triplanar.instrument_numbers import INSTRUMENT_NUMBERS
from triplanar.workbench import rules
from triplanar.workbench.rules import MARGIN, MIN_IMPROVEMENT, Reason, _capped

INSTR_EFFECTS = {n.effect for n in INSTRUMENT_NUMBERS.values()}
TODAY = (rules._given_numbers, rules._drop_idle)

def base_given_numbers(ev, draft):
    """The audit's rule of commit ee5b8f5 (its sentences shortened: only their presence is counted)."""
    named = {e.effect for e in draft.effects}
    examined = named | ({ev.best.effect, *(c.effect for c in ev.lookalikes)} if ev.best is not None else set())
    for a in ev.given_numbers:
        fit = a.fitted
        if fit is None or not fit.plausible or fit.improvement < MIN_IMPROVEMENT:
            continue
        draft.reasons.append(Reason(f"your given {a.name} = ...", "MIN_IMPROVEMENT"))
        twins = [g for g in a.group if g in examined]
        rival = bool(named) and fit.cv_error_mm <= MARGIN * draft.unexplained_mm
        if twins:
            draft.groups.append({"members": [*twins, a.name], "source": "given", "deciding_measurement": ""})
        if (twins or rival) and draft.confidence == "high":
            draft.confidence = "low"
            draft.effects = [_capped(e) for e in draft.effects]
    return draft

def leading(ev):
    cands = [c for c in ev.ranked if c.kind == "candidate" and len(c.params) == 1 and not c.per_test]
    return {c.effect for c in sorted(cands, key=lambda c: c.cv_error_mm)[:rules.SCREEN_EFFECTS]}

def base_view(ev):
    lead = leading(ev)
    kept = tuple(replace(a, group=tuple(g for g in a.group if g not in INSTR_EFFECTS or g in lead))
                 for a in ev.given_numbers if a.name not in INSTRUMENT_NUMBERS)
    return replace(ev, given_numbers=kept)

orig_decide = rules.decide

def run(out, base):
    """Every kept dataset of ``out`` re-decided with the rules before (``base``) or today's."""
    if base:
        rules._given_numbers, rules._drop_idle = base_given_numbers, (lambda steps: (steps, []))
        rules.decide = lambda ev: orig_decide(base_view(ev))
    else:
        rules._given_numbers, rules._drop_idle = TODAY
        rules.decide = orig_decide
    rows = {}
    for f in sorted(glob.glob(f"{out}/results/*.json")):
        r = json.load(open(f))
        r2 = calib.redecide_dataset((r["label"], r["seed"], out, None))
        if r2 is not None:
            r2["clock_rate"] = r.get("clock_rate")
            rows[(r["label"], r["seed"])] = r2
    return rows

def key(r):
    """What a verdict says and how it scores."""
    s = calib.score(r)
    return (r["verdict"], tuple(m["effect"] for m in r["missing_effects"]), r["confidence"], s["right"],
            s["right_in_group"], s["high_wrong"])


def line(name, rs):
    """The counts of one set of rows."""
    rows = list(rs.values())
    inlib = [r for r in rows if r["kind"] in ("effect", "refit", "pair") and r["seed"] // 100 != 60]
    clean = [r for r in rows if r["kind"] == "none_missing"]
    beyond = [r for r in rows if r["seed"] // 100 == 60]

    def cnt(rr, f):
        return sum(1 for r in rr if calib.score(r)[f])
    hint = sum(1 for r in rows if r["kind"] != "given_number" and not r.get("clock_rate") and "your given" in r["reason"])
    print(f"{name:6s} n={len(rows)} right {cnt(rows, 'right')} (group {cnt(rows, 'right_in_group')}), high on a wrong "
          f"answer {cnt(rows, 'high_wrong')}, high {sum(r['confidence'] == 'high' for r in rows)} | in-library (effect, "
          f"refit, pair) right {cnt(inlib, 'right')}/{len(inlib)} | clean none_missing {cnt(clean, 'right')}/"
          f"{len(clean)} | first beyond part {cnt(beyond, 'right')}/{len(beyond)} (group {cnt(beyond, 'right_in_group')})"
          f" | 'your given' on datasets whose numbers are right: {hint}")


def main() -> None:
    out = sys.argv[1]
    base, today = run(out, True), run(out, False)
    line("before", base)
    line("today", today)
    for k in sorted(base, key=lambda k: k[1]):
        if key(base[k]) != key(today[k]):
            print(f"  s{k[1]} {k[0]}: {key(base[k])} -> {key(today[k])}")


if __name__ == "__main__":
    main()

"""The outside-force rule (``rules._outside_force``) and its variants on kept calibration results: for each, how many
right ``high`` verdicts it would lower (its cost) and how many wrong ones (its benefit), then every dataset that was
``high`` without the rule with the rule's inputs (the rows' ``evidence.outside_force``, kept by
``benchmarks/workbench_calibration.py run`` since the rule; only a ``high`` can change, so one run gives before and
after)::

    PYTHONPATH=. python benchmarks/outside_force_variants.py DIR/results [SEED_MIN SEED_MAX]

"right": the verdict right and, where the truth has a value, inside the named interval (the table's "high on a wrong
answer" counts the others).
"""
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import workbench_calibration as wc

rows = [json.loads(p.read_text()) for p in sorted(Path(sys.argv[1]).glob("*.json"))]
if len(sys.argv) > 3:
    rows = [r for r in rows if int(sys.argv[2]) <= r["seed"] <= int(sys.argv[3])]
VARIANTS = {
    **{f"fewer params, within {k:g} se": (lambda k: lambda o: o["force_parameters"] < o["named_parameters"]
                                          and o["difference_mm2"] <= k * o["difference_se_mm2"])(k)
       for k in (0.5, 1.5, 2.5, 3.0)},
    **{f"as many params or fewer, within {k:g} se": (lambda k: lambda o: o["force_parameters"] <= o["named_parameters"]
                                                     and o["difference_mm2"] <= k * o["difference_se_mm2"])(k)
       for k in (1.5, 2.0)},
    "fewer params, within 1 se": lambda o: o["force_parameters"] < o["named_parameters"]
    and o["difference_mm2"] <= 1.0 * o["difference_se_mm2"],
    "fewer params, within 2 se (the rule)": lambda o: o["force_parameters"] < o["named_parameters"]
    and o["difference_mm2"] <= 2.0 * o["difference_se_mm2"],
    "fewer params, force better (diff <= 0)": lambda o: o["force_parameters"] < o["named_parameters"]
    and o["difference_mm2"] <= 0,
    "fewer or as many params, within 1 se": lambda o: o["force_parameters"] <= o["named_parameters"]
    and o["difference_mm2"] <= 1.0 * o["difference_se_mm2"],
    "any params, within 1 se": lambda o: o["difference_mm2"] <= 1.0 * o["difference_se_mm2"],
    "fewer params, force cv <= MARGIN x named": lambda o: o["force_parameters"] < o["named_parameters"]
    and o["force_cv_mm"] <= 1.25 * o["named_cv_mm"],
    "any params, force cv <= MARGIN x named": lambda o: o["force_cv_mm"] <= 1.25 * o["named_cv_mm"],
}
high = []
for r in rows:
    ev = r["evidence"]
    before = ev.get("confidence_without_located", r["confidence"])
    if before != "high":
        continue
    # right as if the rule had not acted: score the row with its confidence before
    s = wc.score({**r, "confidence": "high"})
    high.append((r, s["right"] and s["value_ok"] is not False, ev.get("outside_force")))
print(f"{len(rows)} rows, {len(high)} high without the rule "
      f"({sum(ok for _, ok, _ in high)} right, {sum(not ok for _, ok, _ in high)} wrong)")
for name, fires in VARIANTS.items():
    hit = [(r, ok) for r, ok, o in high if o is not None and fires(o)]
    print(f"- {name}: fires on {len(hit)}: right highs lowered {sum(ok for _, ok in hit)}, wrong highs lowered "
          f"{sum(not ok for _, ok in hit)} ({', '.join('s' + str(r['seed']) + ('' if ok else '!') for r, ok in hit)})")
print()
for r, ok, o in high:
    if o is None:
        print(f"s{r['seed']} {r['label']}: {'right' if ok else 'WRONG'}; nothing located (no force found, or one "
              f"parameter named: diagnose does not locate then)")
        continue
    print(f"s{r['seed']} {r['label']}: {'right' if ok else 'WRONG'}; named {o['named_parameters']} p "
          f"{o['named_cv_mm']:.3f} mm, force {o['force']} ({o['force_parameters']} p) {o['force_cv_mm']:.3f} mm, "
          f"diff {o['difference_mm2']:+.4f} +- {o['difference_se_mm2']:.4f} mm^2 "
          f"(z {o['difference_mm2'] / o['difference_se_mm2'] if o['difference_se_mm2'] else float('nan'):+.1f})")

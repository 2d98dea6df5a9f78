"""The paper's claims (the numbered list of ``docs/paper-reproduction.md``, "Claim by claim"), each
evaluated from the reproduction's numbers with a criterion fixed in advance (constants below).

Verdicts: ``holds``, ``holds partly`` (true at some loads or for some of its parts, not all), ``does not
hold``. Each claim carries the figure that decides it, so the report can quote it.
"""

from __future__ import annotations

import numpy as np

from .cases import SCALE_FACTORS, SCALED_LOADS_N, Run
from .metrics import model_vs_model
from ..outcome import Outcome
from .reproduction import Claim, Reproduction

#: A mean horizontal mismatch below this is invisible at the scale of the paper's panels (claims 1, 4).
VISIBLE_M = 1.0e-3
#: Largest single-sample mismatch still called a match (claim 1): a few times the 0.2 mm rangefinder noise.
MATCH_MAX_M = 3.0e-3
#: "Several times larger" (claim 2).
SEVERAL = 3.0
#: Geometric similarity (claims 6, 8): paths equal, at reference size, to the integrator's accuracy.
SIMILAR_M = 1.0e-6
#: Identity (claim 7).
IDENTICAL_M = 1.0e-9
#: Scale independence of the end effect (claim 8): A-vs-B distance / c equal across scales, relatively.
SCALE_FREE_REL = 0.01
#: "Close to 1 m/s" (claim 9).
PEAK_SPEED_RANGE_M_S = (0.8, 1.2)


CLAIMS = {
    1: "Case A (end friction in the model) matches the laboratory traces at all 12 loads.",
    2: "Without end friction (case B) CP1 shows significant lateral (+e3) dilation; with it (case A) very little.",
    3: "Case A and case B rotate the block in opposite senses (A: front toward +e3 faster than the rear, "
       "counter-clockwise; B: clockwise).",
    4: "The A/B difference shrinks as the shear load grows, fastest at CP2 and CP3; CP1 still differs at 55.6 N.",
    5: "Case C (hydrostatic) differs from the laboratory traces more than case B.",
    6: "Case D (size x0.5 and x2, same mass) gives geometrically similar paths.",
    7: "Case E (mass x0.5 and x2, shear load scaled alike, same size) gives identical paths.",
    8: "Case F (size x0.5, x1, x2 at equal density, shear = weight/2) gives geometrically similar paths within "
       "each row, and the end effect does not shrink with scale.",
    9: "Peak sliding velocity close to 1 m/s at the highest loads.",
}


def _verdict(n_true: int, n_all: int) -> str:
    return "holds" if n_true == n_all else ("does not hold" if n_true == 0 else "holds partly")


#: Reference-size travels at which paths are compared for similarity and identity (claims 6-8).
CHECKPOINTS_M = tuple(np.linspace(0.01, 0.08, 8))


def similarity_gap(rep: Reproduction, run1: Run, run2: Run) -> float:
    """Largest 3-D distance between two runs' contact points brought to the reference size (positions / c),
    at the reference-size travels ``CHECKPOINTS_M``. Each checkpoint is its own simulation stopped exactly
    there, so no interpolation enters: the two runs' adaptive steps differ (the energy bookkeeping in the
    state scales with the mass), and interpolating between different steps alone differs by ~1e-9 m."""
    gap = 0.0
    for s in CHECKPOINTS_M:
        r1 = rep.simulator.stopped_at(run1, s * run1.length_scale)
        r2 = rep.simulator.stopped_at(run2, s * run2.length_scale)
        if r1.status is not Outcome.TRAVEL or r2.status is not Outcome.TRAVEL:
            return float("inf")
        gap = max(gap, float(np.abs(r1.contact_points[-1] / run1.length_scale
                                    - r2.contact_points[-1] / run2.length_scale).max()))
    return gap


def claim_1(rep: Reproduction) -> Claim:
    rows = rep.case_rows["A"]
    ok = [bool(np.all(r.distance.mean_m < VISIBLE_M) and np.all(r.distance.max_m < MATCH_MAX_M)) for r in rows]
    worst_mean = max(rows, key=lambda r: r.distance.mean_m.max())
    worst_max = max(rows, key=lambda r: r.distance.max_m.max())
    b_means = [float(r.distance.mean_m.mean()) for r in rep.case_rows["B"]]
    fig = (f"case A vs dataset: largest mean distance {worst_mean.distance.mean_m.max() * 1e3:.2f} mm "
           f"(CP{int(worst_mean.distance.mean_m.argmax()) + 1}, {worst_mean.force_N:g} N), largest single-sample "
           f"distance {worst_max.distance.max_m.max() * 1e3:.2f} mm ({worst_max.force_N:g} N); case B for comparison: "
           f"{min(b_means) * 1e3:.1f}-{max(b_means) * 1e3:.1f} mm mean over CPs; criterion mean < "
           f"{VISIBLE_M * 1e3:g} mm and max < {MATCH_MAX_M * 1e3:g} mm: met at {sum(ok)}/{len(ok)} loads")
    return Claim(1, CLAIMS[1], fig, _verdict(sum(ok), len(ok)),
                 {"loads_met": sum(ok), "loads": len(ok),
                  "mean_mm": [r.distance.mean_m.tolist() for r in rows]})


def claim_2(rep: Reproduction) -> Claim:
    a, b = rep.case_rows["A"], rep.case_rows["B"]
    ratios = [rb.dilation_m[0] / ra.dilation_m[0] for ra, rb in zip(a, b)]
    ok = [bool(ra.dilation_m[0] > 0 and r >= SEVERAL) for ra, r in zip(a, ratios)]
    fig = (f"CP1 lateral dilation at 8 cm: case B {min(r.dilation_m[0] for r in b) * 1e3:.1f}-"
           f"{max(r.dilation_m[0] for r in b) * 1e3:.1f} mm, case A {min(r.dilation_m[0] for r in a) * 1e3:.1f}-"
           f"{max(r.dilation_m[0] for r in a) * 1e3:.1f} mm; ratio B/A {min(ratios):.1f}-{max(ratios):.1f} "
           f"(criterion >= {SEVERAL:g}: met at {sum(ok)}/{len(ok)} loads)")
    return Claim(2, CLAIMS[2], fig, _verdict(sum(ok), len(ok)),
                 {"ratio_B_over_A": [float(r) for r in ratios],
                  "cp1_dilation_A_mm": [float(r.dilation_m[0] * 1e3) for r in a],
                  "cp1_dilation_B_mm": [float(r.dilation_m[0] * 1e3) for r in b]})


def claim_3(rep: Reproduction) -> Claim:
    a, b = rep.case_rows["A"], rep.case_rows["B"]
    ok = [bool(ra.rotation_deg > 0 > rb.rotation_deg) for ra, rb in zip(a, b)]
    failing = [ra.force_N for ra, o in zip(a, ok) if not o]
    data_ccw = [d.rotation_mean_deg > 0 for d in rep.data_rows]
    fig = (f"rotation at 8 cm: case A {min(r.rotation_deg for r in a):+.2f} to {max(r.rotation_deg for r in a):+.2f} "
           f"deg, case B {min(r.rotation_deg for r in b):+.2f} to {max(r.rotation_deg for r in b):+.2f} deg; opposite "
           f"senses (A > 0 > B) at {sum(ok)}/{len(ok)} loads"
           + (f"; not at {', '.join(f'{f:g}' for f in failing)} N (case A "
              f"{', '.join(f'{r.rotation_deg:+.2f}' for r, o in zip(a, ok) if not o)} deg)" if failing else "")
           + f"; dataset at 5 cm: counter-clockwise at {sum(data_ccw)}/{len(data_ccw)} loads")
    return Claim(3, CLAIMS[3], fig, _verdict(sum(ok), len(ok)),
                 {"rotation_A_deg": [r.rotation_deg for r in a], "rotation_B_deg": [r.rotation_deg for r in b],
                  "dataset_rotation_deg": [d.rotation_mean_deg for d in rep.data_rows]})


def ab_distances(rep: Reproduction) -> np.ndarray:
    """(n_loads, 3) mean A-vs-B horizontal distance per contact point (m), loads ascending."""
    out = []
    for f in rep.loads:
        out.append(model_vs_model(rep.simulator(Run("A", "A", f)), rep.simulator(Run("B", "B", f))).mean_m)
    return np.array(out)


def claim_4(rep: Reproduction) -> Claim:
    d = ab_distances(rep)
    monotone = [bool(np.all(np.diff(d[:, k]) < 0)) for k in range(3)]
    shrink = d[-1] / d[0]
    fastest = bool(shrink[1] < shrink[0] and shrink[2] < shrink[0])
    cp1_differs = bool(d[-1, 0] >= VISIBLE_M)
    parts = [monotone[1] and monotone[2], fastest, cp1_differs]
    rises = {k + 1: [f"{rep.loads[i + 1]:g}" for i in np.flatnonzero(np.diff(d[:, k]) >= 0)] for k in range(3)}
    fig = (f"mean A-vs-B distance {rep.loads[0]:g} N -> {rep.loads[-1]:g} N: CP1 {d[0, 0] * 1e3:.1f} -> "
           f"{d[-1, 0] * 1e3:.1f} mm (x{shrink[0]:.2f}), CP2 {d[0, 1] * 1e3:.1f} -> {d[-1, 1] * 1e3:.1f} mm "
           f"(x{shrink[1]:.2f}), CP3 {d[0, 2] * 1e3:.1f} -> {d[-1, 2] * 1e3:.1f} mm (x{shrink[2]:.2f}); "
           f"falls at every step: CP1 {monotone[0]}, CP2 {monotone[1]}, CP3 {monotone[2]}"
           + "".join(f" (CP{k} rises at {', '.join(v)} N)" for k, v in rises.items() if v and k > 1)
           + f"; CP2/CP3 shrink faster than CP1: {fastest}; CP1 still >= {VISIBLE_M * 1e3:g} mm at "
           f"{rep.loads[-1]:g} N: {cp1_differs}")
    return Claim(4, CLAIMS[4], fig, _verdict(sum(parts), len(parts)),
                 {"ab_mean_mm": (d * 1e3).tolist(), "monotone": monotone, "shrink_ratio": shrink.tolist()})


def claim_5(rep: Reproduction) -> Claim:
    b, c = rep.case_rows["B"], rep.case_rows["C"]
    mb = np.array([r.distance.mean_m.mean() for r in b])
    mc = np.array([r.distance.mean_m.mean() for r in c])
    ok = mc > mb
    cp = np.array([[rc.distance.mean_m[k] > rb.distance.mean_m[k] for k in range(3)] for rb, rc in zip(b, c)])
    fig = (f"mean distance to the dataset, averaged over CP1-3: case C {mc.min() * 1e3:.1f}-{mc.max() * 1e3:.1f} mm, "
           f"case B {mb.min() * 1e3:.1f}-{mb.max() * 1e3:.1f} mm; C farther at {int(ok.sum())}/{len(ok)} loads "
           f"(per contact point, C farther: CP1 {int(cp[:, 0].sum())}, CP2 {int(cp[:, 1].sum())}, "
           f"CP3 {int(cp[:, 2].sum())} of {len(ok)} loads)")
    return Claim(5, CLAIMS[5], fig, _verdict(int(ok.sum()), len(ok)),
                 {"mean_B_mm": (mb * 1e3).tolist(), "mean_C_mm": (mc * 1e3).tolist(),
                  "C_farther_per_cp": cp.sum(axis=0).tolist()})


def _scaled_run(family: str, case: str, factor: float, force: float) -> Run:
    return Run(family, case, force, factor, 0.08 * factor if family in ("D", "F") else 0.08)


def claim_6(rep: Reproduction) -> Claim:
    lo, hi = SCALE_FACTORS["D"]
    gaps = {f"{case} {f:g} N": similarity_gap(rep, _scaled_run("D", case, lo, f), _scaled_run("D", case, hi, f))
            for case in "AB" for f in SCALED_LOADS_N}
    worst = max(gaps.values())
    fig = (f"largest difference between the x{lo:g} and x{hi:g} paths at reference size, at {len(CHECKPOINTS_M)} "
           f"travels from 1 to 8 cm: {worst:.1e} m over {len(gaps)} load/case pairs (criterion < {SIMILAR_M:g} m)")
    return Claim(6, CLAIMS[6], fig, "holds" if worst < SIMILAR_M else "does not hold", {"gap_m": gaps})


def claim_7(rep: Reproduction) -> Claim:
    lo, hi = SCALE_FACTORS["E"]
    gaps = {f"{case} {f:g} N": similarity_gap(rep, _scaled_run("E", case, lo, f * lo), _scaled_run("E", case, hi, f * hi))
            for case in "AB" for f in SCALED_LOADS_N}
    worst = max(gaps.values())
    fig = (f"largest difference between the x{lo:g} and x{hi:g} mass paths, at {len(CHECKPOINTS_M)} travels from 1 "
           f"to 8 cm: {worst:.1e} m over {len(gaps)} load/case pairs (criterion < {IDENTICAL_M:g} m)")
    return Claim(7, CLAIMS[7], fig, "holds" if worst < IDENTICAL_M else "does not hold", {"gap_m": gaps})


def claim_8(rep: Reproduction) -> Claim:
    rows = [r for r in rep.scaled_rows if r.family == "F"]
    ref = next(r for r in rows if r.factor == 1.0)
    gaps = {}
    for r in rows:
        if r.factor != 1.0:
            for case in "AB":
                gaps[f"{case} x{r.factor:g}"] = similarity_gap(
                    rep, _scaled_run("F", case, r.factor, r.force_N), _scaled_run("F", case, 1.0, ref.force_N))
    rel = max(float(np.max(np.abs(r.distance.mean_m / ref.distance.mean_m - 1))) for r in rows)
    similar = max(gaps.values()) < SIMILAR_M
    scale_free = rel < SCALE_FREE_REL
    fig = (f"paths within a row differ by at most {max(gaps.values()):.1e} m at reference size, at "
           f"{len(CHECKPOINTS_M)} travels from 1 to 8 cm (criterion < "
           f"{SIMILAR_M:g} m); A-vs-B mean distance / c at scales "
           f"{', '.join(f'{r.factor:g}' for r in rows)}: CP1 "
           f"{', '.join(f'{r.distance.mean_m[0] * 1e3:.2f}' for r in rows)} mm (largest relative change "
           f"{rel:.1e}; criterion < {SCALE_FREE_REL:g})")
    return Claim(8, CLAIMS[8], fig, _verdict(int(similar) + int(scale_free), 2),
                 {"gap_m": gaps, "ab_mean_mm_per_scale": {f"{r.factor:g}": (r.distance.mean_m * 1e3).tolist()
                                                          for r in rows}})


def claim_9(rep: Reproduction) -> Claim:
    a = rep.case_rows["A"][-1]
    b = rep.case_rows["B"][-1]
    lo, hi = PEAK_SPEED_RANGE_M_S
    data = rep.data_rows[-1]
    ok = lo <= a.peak_speed_m_s <= hi
    fig = (f"peak contact-point speed at {a.force_N:g} N: case A {a.peak_speed_m_s:.2f} m/s at 8 cm (case B "
           f"{b.peak_speed_m_s:.2f} m/s); dataset (tests stopped at {data.end_travel_m[0] * 100:.1f}-"
           f"{data.end_travel_m[1] * 100:.1f} cm) {data.peak_speed_m_s:.2f} m/s; criterion {lo:g}-{hi:g} m/s")
    return Claim(9, CLAIMS[9], fig, "holds" if ok else "does not hold",
                 {"peak_A_m_s": a.peak_speed_m_s, "peak_B_m_s": b.peak_speed_m_s,
                  "dataset_peak_m_s": data.peak_speed_m_s})


CHECKS = (claim_1, claim_2, claim_3, claim_4, claim_5, claim_6, claim_7, claim_8, claim_9)


def evaluate(rep: Reproduction) -> list[Claim]:
    return [check(rep) for check in CHECKS]


def claims_table_md(claims: list[Claim]) -> str:
    head = "| # | the paper's claim | the number here | verdict |\n|---:|---|---|---|\n"
    return head + "\n".join(f"| {c.number} | {c.claim} | {c.figure} | **{c.verdict}** |" for c in claims) + "\n"

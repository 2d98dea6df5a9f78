"""Whether a calibration dataset's cause shows above the noise at all: a criterion of the truth alone, fixed before
any verdict is seen.

A cause that moves the traces less than the error a perfect model leaves on one test is not a finding any rule
should make from a few repeats: the workbench would have to name something the data do not show. So each dataset
carries its *detectability* ``D``: the RMS discrepancy (the workbench's distance, ``triplanar.workbench.fit``)
between the noise-free traces of the truth and the model as given, over the dataset's loads to 6.5 cm, divided by the
RMS discrepancy the truth's own model leaves on two noisy repeats per load drawn with the dataset's noise and friction
scatter (what a perfect model leaves on one test). Both are computed with the compiled kernel
(``triplanar.labdata.run_lab_test``): the criterion is about the size of the cause, which the kernel and the
independent laboratory agree on to ~0.01 mm, not about how the data were made.

The limit, ``DETECTABLE = 1``: below it the cause adds less to the error than the noise and the specimen already put
there (the model as given leaves at most sqrt(2) x a perfect model's error), so the expected verdict is
``none_missing``. For a pair, each effect's ``D`` is the same ratio for the model holding the other effect: an effect
below the limit is not expected to be named (with one left, the expected verdict is ``library_effect`` naming it).
The limit was fixed from this argument before the verdicts of any dataset were looked at under it; it is the same on
both parts.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

#: A cause shows when it moves the traces by at least this many times the error a perfect model leaves on one test.
DETECTABLE = 1.0
STOP_M = 0.065              # the noise-free comparison's travel (the middle of the manual stop's 5-8 cm)
PERFECT_REPEATS = 2


def _effects(cfg: dict[str, Any], library: list, with_outside: bool) -> list:
    from triplanar import make_effect
    from triplanar.specimen import reference

    from calibration_plugins import OUTSIDE
    effects = [make_effect(f"{n}:" + ",".join(f"{k}={v}" for k, v in p.items())) for n, p in library]
    if with_outside:
        spec, _ = reference()
        for name, p in cfg["outside"]:
            params = dict(p)
            if name == "outside_travel_hardening":
                params["x0_m"] = float(spec.mass_centre_world[0])
            effects.append(OUTSIDE[name](**params))
    return effects


def _tests(cfg: dict[str, Any], effects: list, noise_m: float, scatter_deg: float, repeats: int,
           stop_range: tuple[float, float]) -> list:
    from triplanar.labdata import LabTest, foundation_plan_box, run_lab_test
    from triplanar.specimen import reference
    box = foundation_plan_box(reference()[0])
    tests = []
    for force in cfg["loads_N"]:
        for repeat in range(1, repeats + 1):
            _, test = run_lab_test(LabTest(force, repeat, cfg["seed"] + 10**6, "B", tuple(effects), None, None,
                                           noise_m, cfg["rate_hz"], scatter_deg, stop_range, box))
            if test is not None:
                tests.append(test)
    return tests


def _error(effects: list, tests: list) -> float:
    from triplanar.workbench import ModelSpec
    from triplanar.workbench.fit import discrepancies, evaluate_spec, overall_error
    return overall_error(discrepancies(evaluate_spec(ModelSpec.from_effects(effects), tests)))


def detectability(cfg: dict[str, Any]) -> dict[str, Any]:
    """``{"signal_mm", "perfect_mm", "ratio", "components": {effect: ratio} (pairs), "expected_verdict",
    "expected_effects"}`` of the dataset made from ``cfg`` (``workbench_calibration.settings``)."""
    truth_lib = [tuple(x) for x in cfg["truth"]]
    truth = _tests(cfg, _effects(cfg, truth_lib, True), 0.0, 0.0, 1, (STOP_M, STOP_M))
    if cfg.get("clock_rate", 1.0) != 1.0:       # a logger clock running fast or slow: the truth's times as recorded
        truth = [replace(t, t_s=t.t_s * cfg["clock_rate"]) for t in truth]
    perfect = _tests(cfg, _effects(cfg, truth_lib, False), cfg["noise_m"], cfg["friction_scatter_deg"],
                     PERFECT_REPEATS, tuple(cfg["stop_range_m"]))
    perfect_mm = _error(_effects(cfg, truth_lib, False), perfect)
    signal_mm = _error(_effects(cfg, [tuple(x) for x in cfg["given"]], False), truth)
    ratio = signal_mm / perfect_mm if perfect_mm > 0 else math.inf
    out: dict[str, Any] = {"signal_mm": signal_mm, "perfect_mm": perfect_mm, "ratio": ratio, "components": {},
                           "limit": DETECTABLE}
    expected, named = cfg["expected_verdict"], [n for n, _ in truth_lib]
    if cfg["kind"] == "pair":
        for name, _ in truth_lib:
            others = [x for x in truth_lib if x[0] != name]
            out["components"][name] = _error(_effects(cfg, others, False), truth) / perfect_mm
        named = [n for n, d in out["components"].items() if d >= DETECTABLE]
        expected = {2: "library_effects", 1: "library_effect"}.get(len(named), "none_missing")
    if cfg["kind"] != "none_missing" and ratio < DETECTABLE:
        expected, named = "none_missing", []
    if cfg["kind"] in ("none_missing", "outside_library"):
        named = []
    out.update(expected_verdict=expected, expected_effects=named)
    return out

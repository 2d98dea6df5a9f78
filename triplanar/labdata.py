"""A stand-in laboratory: measured traces made the way the paper's laboratory made them.

The paper's measurements (Galic, Glaser & Goodman 2008, section 5.1, Fig. 11: 50 constant-force tests at
12 loads, four repeats each, manually terminated, tracked by laser rangefinders) are not public. This
module makes a substitute dataset in the measured-trace format (``docs/measurement-format.md``):

* the laboratory's "true" physics is :func:`triplanar.paper_model` (``case``, default ``"B"``) with a set
  of effects (default: the steel load tip's end friction at 8 degrees, which makes it the paper's case A);
  the effects may include ones a user's model lacks;
* repeat-to-repeat scatter: every friction angle of the model (the three contact angles, and the tip
  angle when end friction is on) is drawn per test from a normal distribution with standard deviation
  ``scatter_deg`` about its nominal value (clipped to [0, 44] degrees);
* sampling at ``rate_hz`` in time from the start of sliding (``t_s = k / rate_hz``), positions taken from
  the simulated trajectory by cubic Hermite interpolation in time (the integrator's positions and
  velocities at the bracketing steps: accurate to the integrator's own tolerance);
* laser-rangefinder noise: independent Gaussian noise, standard deviation ``noise_m``, on every
  coordinate (x1, x2, x3) of every contact point of every sample;
* manual termination: each test stops when CP1 has moved a travel drawn uniformly from ``stop_range_m``
  (the last sample is the last one at or before that instant).

Possible range. A contact point cannot leave the foundation block, whose plan is 30 cm (along e1) by
45 cm (along e3) (paper section 2). Its position relative to the contact points is not given in the
paper; here (:func:`foundation_plan_box`) its rear edge is 1 cm behind CP1's rest position and it is
centred laterally on the contact points' rest span: for the reference specimen x1 in [-0.15, 0.15] m and
x3 in [-0.105, 0.345] m. For another specimen the block is assumed scaled with it (x1 sizes by the
contact points' rest span along e1 over the reference's 0.14 m, x3 sizes by their span along e3 over
0.24 m). A test whose noise-free trajectory would carry a contact point off that plan is cut at the last
sample still on it (the laboratory would have to stop there); the truth records this. With 0.2 mm noise
and centimetres of margin the noisy samples stay on it too (the tests check every sample).

* parameters that differ from test to test (``per_test``, e.g. the phase of a ripple that is not locked to the
  actuator's start): each test draws its own value of each, uniformly over the given range; the truth records
  them.

Determinism: every test draws from its own ``numpy`` Generator seeded by ``(seed, load in mN, repeat)``,
so a test is the same whichever other loads are generated with it (the per-test parameters come from a
separate stream, ``(seed, load in mN, repeat, 1)``, so a dataset without them is unchanged).
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable, Sequence

import numpy as np

from . import PAPER_LOADS_N
from .atomic import remove_stale_temporaries, temporary_path
from .effects import ContactFriction, Effect, EndFriction
from .executor import ExecutorLike, run_tasks
from .measurement import MeasuredTest, MeasurementError, write_measurements
from .model import Model, paper_model
from .result import SimulationResult
from .simulate import simulate
from .specimen import Foundation, Specimen, reference, to_toml
from .outcome import Outcome
from .paths import travel as path_travel

#: Plan dimensions of the foundation block, metres: along e1, along e3 (paper section 2, Fig. 4).
FOUNDATION_PLAN_M = (0.30, 0.45)
#: Distance from CP1's rest position back to the foundation block's rear edge (assumption, see module doc).
FOUNDATION_REAR_MARGIN_M = 0.01
#: The reference specimen's contact-point spans at rest (L12 along e1, L23 along e3), m.
REFERENCE_SPAN_M = (0.14, 0.24)
#: Friction angles stay within the bounds of :class:`triplanar.effects.ContactFriction`.
FRICTION_BOUNDS_DEG = (0.0, 44.0)

TRUTH_FORMAT = "triplanar-lab-truth/1"


def default_effects() -> tuple[Effect, ...]:
    """The laboratory's default physics beyond case B: the steel tip's end friction, 8 degrees."""
    return (EndFriction(phi_deg=8.0),)


def package_version() -> str:
    """This package's version (installed metadata, else ``pyproject.toml``, else ``"unknown"``)."""
    try:
        from importlib.metadata import PackageNotFoundError, version
        try:
            return version("triplanar-shear")
        except PackageNotFoundError:
            pass
    except ImportError:  # pragma: no cover
        pass
    pyproject = Path(__file__).resolve().parents[1] / "pyproject.toml"
    try:
        import tomllib
        return str(tomllib.loads(pyproject.read_text(encoding="utf-8"))["project"]["version"])
    except (OSError, KeyError, ValueError):
        return "unknown"


@dataclass(frozen=True)
class PlanBox:
    """An axis-aligned rectangle in plan (x1, x3), metres."""

    x1_min: float
    x1_max: float
    x3_min: float
    x3_max: float

    def contains(self, positions: np.ndarray) -> np.ndarray:
        """For (..., 3) points: whether each lies on the plan (bounds included)."""
        x1, x3 = positions[..., 0], positions[..., 2]
        return (x1 >= self.x1_min) & (x1 <= self.x1_max) & (x3 >= self.x3_min) & (x3 <= self.x3_max)

    def as_dict(self) -> dict[str, float]:
        return {"x1_min_m": self.x1_min, "x1_max_m": self.x1_max, "x3_min_m": self.x3_min, "x3_max_m": self.x3_max}


def foundation_plan_box(specimen: Specimen) -> PlanBox:
    """The foundation block's plan for ``specimen`` (module doc: 30 cm x 45 cm for the reference, rear edge
    1 cm behind CP1 at rest, centred laterally on the contact points' rest span; scaled with the specimen's
    contact-point spans for another specimen)."""
    cps = specimen.contact_points_m
    span1 = float(np.ptp(cps[:, 0])) / REFERENCE_SPAN_M[0]
    span3 = float(np.ptp(cps[:, 2])) / REFERENCE_SPAN_M[1]
    rear = float(cps[:, 0].min()) - FOUNDATION_REAR_MARGIN_M * span1
    mid3 = 0.5 * float(cps[:, 2].min() + cps[:, 2].max())
    length, width = FOUNDATION_PLAN_M[0] * span1, FOUNDATION_PLAN_M[1] * span3
    return PlanBox(rear, rear + length, mid3 - width / 2, mid3 + width / 2)


def hermite_in_time(result: SimulationResult, t_query: np.ndarray) -> np.ndarray:
    """(m, 3, 3) contact-point positions at times ``t_query`` (within the simulated span), by cubic Hermite
    interpolation of the integrator's positions and velocities at the bracketing steps
    (:meth:`SimulationResult.contact_points_at`); refuses times outside the span."""
    t = result.t
    t_query = np.asarray(t_query, dtype=float)
    if t_query.size and (t_query.min() < t[0] - 1e-15 or t_query.max() > t[-1] + 1e-12):
        raise ValueError(f"times must lie within [{t[0]:g}, {t[-1]:g}] s, the simulated span")
    return result.contact_points_at(t_query)


def _friction_angles(model: Model) -> list[float]:
    """The model's friction angles that scatter: three contacts, plus the tip when end friction acts."""
    angles = list(model.specimen.friction_deg)
    if model.tan_phi_EF > 0:
        angles.append(model.specimen.tip_friction_deg)
    return angles


def _with_angles(model: Model, angles: Sequence[float]) -> Model:
    extra: list[Effect] = [ContactFriction(phi1_deg=angles[0], phi2_deg=angles[1], phi3_deg=angles[2])]
    if len(angles) > 3:
        extra.append(EndFriction(phi_deg=angles[3]))
    return model.with_effects(extra)


def _effect_record(effect: Effect) -> dict[str, object]:
    return {"name": effect.name, "parameters": dict(effect.values), "spec": repr(effect)}


def _check_arguments(loads: Sequence[float], repeats: int, noise_m: float, rate_hz: float, scatter_deg: float,
                     stop_range_m: tuple[float, float]) -> None:
    if not loads:
        raise ValueError("loads: give at least one shear force")
    for f in loads:
        if not (math.isfinite(f) and f > 0):
            raise ValueError(f"loads: every shear force must be a positive number of newtons, got {f}")
    if len({round(float(f) * 1000) for f in loads}) != len(loads):
        raise ValueError(f"loads: each shear force may appear once (to 1 mN), got {list(loads)}")
    if not (isinstance(repeats, (int, np.integer)) and repeats >= 1):
        raise ValueError(f"repeats must be a positive integer, got {repeats!r}")
    if not (math.isfinite(noise_m) and noise_m >= 0):
        raise ValueError(f"noise_m must be >= 0 m, got {noise_m}")
    if not (math.isfinite(rate_hz) and rate_hz > 0):
        raise ValueError(f"rate_hz must be > 0, got {rate_hz}")
    if not (math.isfinite(scatter_deg) and scatter_deg >= 0):
        raise ValueError(f"scatter_deg must be >= 0 degrees, got {scatter_deg}")
    lo, hi = stop_range_m
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo <= hi):
        raise ValueError(f"stop_range_m must be (low, high) with 0 < low <= high metres, got {stop_range_m}")


@dataclass(frozen=True)
class LabTest:
    """One test of the campaign, a task of :func:`run_lab_test` (picklable, so any executor runs it)."""

    force_N: float
    repeat: int
    seed: int
    case: str
    effects: tuple[Effect, ...]
    specimen: Specimen | None
    foundation: Foundation | None
    noise_m: float
    rate_hz: float
    scatter_deg: float
    stop_range_m: tuple[float, float]
    box: PlanBox
    per_test: tuple[tuple[str, str, float, float], ...] = ()   # (effect, parameter, low, high)


def run_lab_test(job: LabTest) -> tuple[dict, MeasuredTest | None]:
    """Simulate one test: ``(record, test)``, or ``(record with a reason, None)`` when it is skipped. Its random
    draws come from its own Generator seeded by ``(seed, load in mN, repeat)``: the same wherever it runs."""
    force, repeat, rate_hz = job.force_N, job.repeat, job.rate_hz
    effects, drawn = job.effects, {}
    if job.per_test:
        own = np.random.default_rng(np.random.SeedSequence([job.seed, int(round(force * 1000)), repeat, 1]))
        for name, param, lo, hi in job.per_test:
            drawn.setdefault(name, {})[param] = float(own.uniform(lo, hi))
        effects = tuple(type(e)(**{**e.values, **drawn[e.name]}) if e.name in drawn else e for e in effects)
    nominal = paper_model(job.case, force, specimen=job.specimen, foundation=job.foundation, effects=effects)
    test_id = f"F{force:g}N-r{repeat}"
    rng = np.random.default_rng(np.random.SeedSequence([job.seed, int(round(force * 1000)), repeat]))
    nominal_angles = _friction_angles(nominal)
    angles = np.clip(np.asarray(nominal_angles) + rng.normal(0.0, job.scatter_deg, len(nominal_angles)),
                     *FRICTION_BOUNDS_DEG)
    stop = float(rng.uniform(job.stop_range_m[0], job.stop_range_m[1]))
    model = _with_angles(nominal, angles.tolist())
    result = simulate(model, travel_m=stop)
    record = {"test_id": test_id, "shear_force_N": force, "repeat": repeat,
              "friction_deg": [float(a) for a in angles[:3]],
              "tip_friction_deg": float(angles[3]) if len(angles) > 3 else None,
              "stop_travel_m": stop, "status": result.status.label, "message": result.message,
              **({"per_test": drawn} if drawn else {})}
    if result.status is Outcome.HELD:
        return {**record, "reason": "the block never slid"}, None
    t_s = np.arange(0, int(math.floor(result.t[-1] * rate_hz + 1e-9)) + 1) / rate_hz
    clean = hermite_in_time(result, t_s)
    recorded_t, recorded = t_s, clean
    for effect in effects:        # instrument effects: what the instruments make of the true motion
        recorded_t, recorded = effect.read(recorded_t, recorded, model.specimen.contact_points_m)
    noisy = recorded + rng.normal(0.0, job.noise_m, clean.shape)
    on_plan = (job.box.contains(clean) & job.box.contains(noisy)).all(axis=1)
    cut = int(np.argmin(on_plan)) if not on_plan.all() else len(t_s)
    record["cut_at_foundation_edge"] = cut < len(t_s)
    t_s, clean, noisy = t_s[:cut], clean[:cut], noisy[:cut]
    if len(t_s) < 3:
        return {**record, "reason": f"only {len(t_s)} sample(s) at {rate_hz:g} Hz on the foundation block"}, None
    record.update(n_samples=len(t_s), duration_s=float(t_s[-1]),
                  final_travel_m=float(path_travel(clean[-1], clean[0])))
    return record, MeasuredTest(test_id=test_id, shear_force_N=force, positions=noisy, t_s=recorded_t[:cut])


def generate_lab_data(loads: Sequence[float] = PAPER_LOADS_N, repeats: int = 4,
                      effects: Iterable[Effect] | None = None, noise_m: float = 2e-4, rate_hz: float = 200.0,
                      scatter_deg: float = 0.2, stop_range_m: tuple[float, float] = (0.05, 0.08), seed: int = 0,
                      specimen: Specimen | None = None, foundation: Foundation | None = None,
                      case: str = "B", executor: ExecutorLike = "serial",
                      progress: bool = False,
                      per_test: dict[str, dict[str, tuple[float, float]]] | None = None
                      ) -> tuple[list[MeasuredTest], dict]:
    """Simulate a laboratory campaign of constant-force shear tests (paper section 5.1).

    Args:
        loads: commanded shear forces, N (default: the paper's 12 levels).
        repeats: tests per load (paper: four).
        effects: the laboratory's physics added to ``case`` (``None``: end friction at 8 degrees).
        noise_m: standard deviation of the rangefinder noise on every coordinate, m.
        rate_hz: sampling rate, Hz (samples at ``k / rate_hz`` s after sliding starts).
        scatter_deg: standard deviation of each friction angle between repeats, degrees.
        stop_range_m: each test stops at a CP1 travel drawn uniformly from this range, m.
        seed: the dataset's seed.
        specimen, foundation: default the reference specimen.
        case: the paper case the effects are added to (``"B"``: actuator without end friction).
        executor: where the tests are simulated (:mod:`triplanar.executor`: ``"serial"``, default; ``None`` or
            ``"local"``, a process pool; ``"ray"``); every backend gives the same dataset.
        progress: a progress bar on stderr.
        per_test: ``{effect: {parameter: (low, high)}}``: parameters of ``effects`` that each test draws anew,
            uniformly over the range (e.g. ``{"thrust_ripple": {"phase_rad": (-math.pi, math.pi)}}``); each
            test's values are in ``truth["tests"][i]["per_test"]``.

    Returns ``(tests, truth)``: the tests in load order then repeat order (ids ``F27.8N-r1``...), and a
    JSON-ready dict with everything used (effects, per-test friction angles and stop travel, noise, rate,
    seed, package version, the specimen as TOML, what happened in each test). A test that never slides or yields fewer than 3
    samples is left out of ``tests`` and listed in ``truth["skipped"]``.
    """
    loads = [float(f) for f in loads]
    _check_arguments(loads, repeats, noise_m, rate_hz, scatter_deg, tuple(stop_range_m))
    effects = default_effects() if effects is None else tuple(effects)
    draws = []
    for name, params in (per_test or {}).items():
        effect = next((e for e in effects if e.name == name), None)
        if effect is None:
            raise ValueError(f"per_test: effect {name!r} is not among the effects "
                             f"({', '.join(e.name for e in effects)})")
        for param, (lo, hi) in params.items():
            spec = effect.parameters.get(param)
            if spec is None:
                raise ValueError(f"per_test: effect {name!r} has no parameter {param!r}")
            if not (math.isfinite(lo) and math.isfinite(hi) and spec.lower <= lo <= hi <= spec.upper):
                raise ValueError(f"per_test: {name}.{param} range ({lo}, {hi}) must lie within "
                                 f"[{spec.lower}, {spec.upper}]")
            draws.append((name, param, float(lo), float(hi)))
    ref_specimen, ref_foundation = reference()
    base_specimen, base_foundation = specimen or ref_specimen, foundation or ref_foundation
    box = foundation_plan_box(paper_model(case, loads[0], specimen=specimen, foundation=foundation,
                                          effects=effects).specimen)
    lab_tests = [LabTest(force, repeat, int(seed), case, tuple(effects), specimen, foundation, noise_m, rate_hz,
                         scatter_deg, (float(stop_range_m[0]), float(stop_range_m[1])), box, tuple(draws))
                 for force in loads for repeat in range(1, repeats + 1)]
    tests: list[MeasuredTest] = []
    records: list[dict] = []
    skipped: list[dict] = []
    for record, test in run_tasks(run_lab_test, lab_tests, executor, progress, desc="lab tests"):
        if test is None:
            skipped.append(record)
        else:
            tests.append(test)
            records.append(record)
    truth = {
        "format": TRUTH_FORMAT,
        "package_version": package_version(),
        "case": case.upper(),
        "effects": [_effect_record(e) for e in effects],
        "specimen": base_specimen.name,
        "specimen_toml": to_toml(base_specimen, base_foundation),
        "loads_N": loads, "repeats": int(repeats), "seed": int(seed),
        "noise_m": float(noise_m), "rate_hz": float(rate_hz), "scatter_deg": float(scatter_deg),
        "stop_range_m": [float(stop_range_m[0]), float(stop_range_m[1])],
        **({"per_test": {n: {p: [lo, hi] for m, p, lo, hi in draws if m == n} for n, *_ in draws}}
           if draws else {}),
        "scatter_applies_to": "each friction angle (CP1..CP3, and the tip when end friction acts), "
                              "normal with sd scatter_deg about its nominal value, clipped to [0, 44] deg",
        "noise_applies_to": "x1, x2 and x3 of every contact point of every sample, independent Gaussian",
        "foundation_plan_m": box.as_dict(),
        "tests": records,
        "skipped": skipped,
    }
    return tests, truth


def write_lab_data(path: str | os.PathLike[str], tests: Sequence[MeasuredTest], truth: dict,
                   truth_path: str | os.PathLike[str] | None = None) -> tuple[Path, Path]:
    """Write ``tests`` as a measured-trace CSV at ``path`` and ``truth`` as JSON beside it (default
    ``<path>.truth.json``). Both are written to temporary files first and moved into place only when both
    are complete; the JSON gains ``data_file`` and ``data_sha256`` (the CSV's SHA-256) so the two can be
    matched later. Returns the two paths."""
    path = Path(path)
    truth_file = Path(truth_path) if truth_path is not None else path.with_name(path.name + ".truth.json")
    if path.resolve() == truth_file.resolve():
        raise ValueError(f"the truth file must differ from the data file ({path})")
    if not tests:
        raise MeasurementError(path, None, None, "no tests to write")
    for target in (path, truth_file):
        target.parent.mkdir(parents=True, exist_ok=True)
    remove_stale_temporaries(path)  # left by a killed earlier run
    remove_stale_temporaries(truth_file)
    # Two files, one transaction: write_atomic replaces one file; here the truth JSON carries the CSV's digest, goes
    # in first, and is put back if the CSV then cannot be moved into place, so the renames are done by hand.
    tmp_csv = temporary_path(path)
    tmp_json = temporary_path(truth_file)
    backup: bytes | None = None
    try:
        try:
            write_measurements(tmp_csv, tests)
        except MeasurementError as err:  # name the user's file, not the temporary one
            raise MeasurementError(path, err.row, err.column, err.detail) from None
        digest = hashlib.sha256(tmp_csv.read_bytes()).hexdigest()
        record = {**truth, "data_file": path.name, "data_sha256": digest}
        with open(tmp_json, "w", encoding="utf-8") as fh:
            json.dump(record, fh, indent=1, sort_keys=False)
            fh.write("\n")
            fh.flush()
            os.fsync(fh.fileno())
        backup = truth_file.read_bytes() if truth_file.exists() else None
        os.replace(tmp_json, truth_file)
        try:
            os.replace(tmp_csv, path)
        except BaseException:
            # The CSV could not be moved into place: put the old truth file back (or remove the new one).
            if backup is None:
                truth_file.unlink(missing_ok=True)
            else:
                truth_file.write_bytes(backup)
            raise
    finally:
        tmp_csv.unlink(missing_ok=True)
        tmp_json.unlink(missing_ok=True)
    return path, truth_file


def read_truth(path: str | os.PathLike[str]) -> dict:
    """Read a truth JSON written by :func:`write_lab_data`."""
    with open(path, encoding="utf-8") as fh:
        return json.load(fh)

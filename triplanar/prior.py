"""Identify, then control: a specimen identified on the workbench (``fit.json`` of ``triplanar fit``) or given as a
specimen TOML (``docs/specimen-format.md``), as the prior of :class:`agents.mpc.MPCController` (``prior=``) and as
v1's nominal specimen (``gym.make("TriPlanarShear-v1", nominal_specimen=path)``).

A ``fit.json`` gives fitted effect parameters on top of the drawing; those that are properties of the specimen
become its fields: ``end_friction.phi_deg`` -> ``tip_friction_deg`` (the tip is the bench's, so it is taken as
the tip the fitted tests ran with), ``contact_friction.phi1_deg..phi3_deg`` -> ``friction_deg``. Any other fitted
effect (a plane tilt, a rate law, an actuator rise...) is not a specimen field and is refused, naming it, rather
than silently dropped. A TOML is refused when its foundation or its geometry (contact points, load point) is not
the bench's: the controller's hypotheses and v1's bench share them.
"""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import numpy as np

from triplanar.specimen import Foundation, Specimen, load_toml

SPECIMEN_EFFECTS = {"end_friction": ("phi_deg",), "contact_friction": ("phi1_deg", "phi2_deg", "phi3_deg")}


class PriorError(ValueError):
    """A prior that cannot be used for this bench; the message names the file and the field."""


def _effects(data: dict, source: str) -> dict:
    if not isinstance(data, dict):
        raise PriorError(f"{source}: not a fit.json object")
    steps = data.get("steps")
    if not isinstance(steps, list) or not steps:
        raise PriorError(f"{source}: steps: missing or empty (a fit.json from 'triplanar fit' has them)")
    effects = steps[-1].get("effects") if isinstance(steps[-1], dict) else None
    if not isinstance(effects, dict):
        raise PriorError(f"{source}: steps[-1].effects: missing (the fitted parameters)")
    return effects


# The geometry that makes a specimen this bench's (its friction, mass and mass centre are what a fit may change).
GEOMETRY = ("contact_points_m", "load_point_A_m", "load_point_B_m")


def drawing_record(specimen: Specimen, foundation: Foundation) -> dict:
    """What ``triplanar fit`` records in ``fit.json`` of the drawing it fitted on (``"drawing"``): the specimen's
    geometry and the foundation planes' normals, so that a fit is refused as the prior of another bench."""
    return {"specimen": {name: np.asarray(getattr(specimen, name), dtype=float).tolist() for name in GEOMETRY},
            "foundation_normals": [np.asarray(p.normal, dtype=float).tolist() for p in foundation.planes]}


def _same(given: object, expected: np.ndarray) -> bool:
    try:
        array = np.asarray(given, dtype=float)
    except (TypeError, ValueError):
        return False
    return array.shape == expected.shape and bool(np.allclose(array, expected, atol=1e-9))


def _check_drawing(data: dict, source: str, specimen: Specimen, foundation: Foundation) -> None:
    drawing = data.get("drawing")
    if not isinstance(drawing, dict) or not isinstance(drawing.get("specimen"), dict):
        raise PriorError(f"{source}: drawing: missing (triplanar fit records the specimen geometry and foundation it "
                         "fitted on; a fit.json without them cannot be checked against this bench: fit again)")
    for name in GEOMETRY:
        if not _same(drawing["specimen"].get(name), np.asarray(getattr(specimen, name), dtype=float)):
            raise PriorError(f"{source}: drawing.specimen.{name}: fitted on another specimen than the bench's")
    normals = drawing.get("foundation_normals")
    if not isinstance(normals, list) or len(normals) != len(foundation.planes):
        raise PriorError(f"{source}: drawing.foundation_normals: missing or not {len(foundation.planes)} planes")
    for i, (given, plane) in enumerate(zip(normals, foundation.planes)):
        if not _same(given, np.asarray(plane.normal, dtype=float)):
            raise PriorError(f"{source}: drawing.foundation_normals[{i}]: fitted on another foundation than the "
                             "bench's")


def specimen_from_fit(path: str | Path, specimen: Specimen, foundation: Foundation) -> Specimen:
    """``specimen`` (the drawing the fit started from) with the fitted specimen parameters of ``path``; refused
    (naming the field) when the fit was made on another specimen geometry or foundation."""
    source = str(path)
    try:
        data = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError) as exc:
        raise PriorError(f"{source}: cannot read a fit.json ({exc})") from exc
    effects = _effects(data, source)
    _check_drawing(data, source, specimen, foundation)
    tip, friction = float(specimen.tip_friction_deg), list(np.asarray(specimen.friction_deg, dtype=float))
    for name, params in effects.items():
        if name not in SPECIMEN_EFFECTS:
            raise PriorError(f"{source}: steps[-1].effects.{name}: not a specimen property (a prior takes "
                             f"{', '.join(sorted(SPECIMEN_EFFECTS))})")
        for key in SPECIMEN_EFFECTS[name]:
            value = params.get(key) if isinstance(params, dict) else None
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0.0 <= value < 45.0:
                raise PriorError(f"{source}: steps[-1].effects.{name}.{key}: expected a friction angle in [0, 45) "
                                 f"deg, got {value!r}")
        if name == "end_friction":
            tip = float(params["phi_deg"])
        else:
            friction = [float(params[k]) for k in SPECIMEN_EFFECTS[name]]
    return replace(specimen, tip_friction_deg=tip, friction_deg=tuple(friction),
                   name=f"{specimen.name} (fitted: {Path(path).name})")


def load_prior(path: str | Path, specimen: Specimen, foundation: Foundation) -> Specimen:
    """The prior specimen of ``path`` (``.json``: a fit; ``.toml``: a specimen) for a bench of ``specimen`` on
    ``foundation``; :class:`PriorError` names the field that does not fit."""
    path = Path(path)
    if path.suffix == ".json":
        return specimen_from_fit(path, specimen, foundation)
    if path.suffix != ".toml":
        raise PriorError(f"{path}: a prior is a fit.json or a specimen .toml")
    given, given_foundation = load_toml(path)
    for i, (a, b) in enumerate(zip(given_foundation.planes, foundation.planes)):
        if not np.allclose(a.normal, b.normal, atol=1e-12):
            raise PriorError(f"{path}: foundation.planes[{i}]: not the bench's plane ({a} against {b})")
    for name in GEOMETRY:
        if not np.allclose(getattr(given, name), getattr(specimen, name), atol=1e-9):
            raise PriorError(f"{path}: specimen.{name}: another specimen than the bench's")
    return given


def fitted_intervals(path: str | Path) -> dict[str, tuple[float, float]]:
    """The 95 % intervals a ``fit.json`` gives for the specimen fields it fits (``param_ci95`` of its last step):
    ``tip_friction_deg`` and ``friction1_deg``..``friction3_deg``; empty for a TOML, and without a field whose
    interval is missing (``null``: not fitted, or at a bound)."""
    path = Path(path)
    if path.suffix != ".json":
        return {}
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError) as exc:
        raise PriorError(f"{path}: cannot read a fit.json ({exc})") from exc
    _effects(data, str(path))
    ci = data["steps"][-1].get("param_ci95") or {}
    if not isinstance(ci, dict):
        raise PriorError(f"{path}: steps[-1].param_ci95: expected an object of intervals, got {ci!r:.60}")
    names = {("end_friction", "phi_deg"): "tip_friction_deg"}
    names.update({("contact_friction", f"phi{i}_deg"): f"friction{i}_deg" for i in (1, 2, 3)})
    out: dict[str, tuple[float, float]] = {}
    for (effect, key), name in names.items():
        per_effect = ci.get(effect) or {}
        if not isinstance(per_effect, dict):
            raise PriorError(f"{path}: steps[-1].param_ci95.{effect}: expected an object, got {per_effect!r:.60}")
        pair = per_effect.get(key)
        if pair is None:
            continue  # not fitted, or at a bound
        if not (isinstance(pair, list) and len(pair) == 2 and all(
                not isinstance(v, bool) and isinstance(v, (int, float)) and math.isfinite(v) for v in pair)
                and pair[0] <= pair[1]):
            raise PriorError(f"{path}: steps[-1].param_ci95.{effect}.{key}: expected [low, high] finite numbers "
                             f"(deg), got {pair!r:.60}")
        out[name] = (float(pair[0]), float(pair[1]))
    return out


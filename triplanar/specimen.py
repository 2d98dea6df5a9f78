"""Specimen (the top block) and foundation (three planes): data, validation, TOML files, scaling.

Frame and conventions (``docs/specimen-format.md``): ``e1`` forward (push
direction), ``e2`` up, ``e3 = e1 x e2`` lateral (right when facing ``e1``); the three foundation planes
contain the origin. Units are SI inside; angles are degrees only in these dataclasses' ``*_deg`` fields.

Names follow the paper (Galic, Glaser & Goodman 2008): the body frame ``g1, g2, g3`` (section 3.1), the
mass centre ``C`` relative to CP1 in that frame (eq. 24), and the load point ``P_CL = P1 + A g2 - B g3``
(eq. 27).
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, replace
from functools import cached_property, lru_cache
from importlib import resources
from pathlib import Path

import numpy as np

GRAVITY = 9.81  # m/s^2 along -e2; 5.4 kg then weighs 52.97 N, the paper's "53 N".
PLANE_TOLERANCE_M = 1e-9  # a contact point this close to its plane counts as on it


class SpecimenError(ValueError):
    """A specimen or foundation value that cannot describe a physical test; names the field."""

    def __init__(self, field_name: str, problem: str, source: str | None = None):
        self.field = field_name
        where = f"{source}: " if source else ""
        super().__init__(f"{where}{field_name}: {problem}")


@dataclass(frozen=True)
class Plane:
    """A foundation plane through the origin, given by dip and dip direction (degrees).

    ``dip_direction_deg`` is the downhill direction seen from above, clockwise from ``e1``: the
    horizontal unit vector ``cos(a) e1 + sin(a) e3``.
    """

    dip_deg: float
    dip_direction_deg: float = 0.0

    @cached_property
    def normal(self) -> np.ndarray:
        """Upward unit normal ``(sin d cos a, cos d, sin d sin a)`` (computed once; read-only)."""
        d, a = math.radians(self.dip_deg), math.radians(self.dip_direction_deg)
        normal = np.array([math.sin(d) * math.cos(a), math.cos(d), math.sin(d) * math.sin(a)])
        normal.setflags(write=False)
        return normal

    def height(self, x1: np.ndarray | float, x3: np.ndarray | float) -> np.ndarray | float:
        """Elevation ``x2`` of the plane above the horizontal point ``(x1, x3)``."""
        n = self.normal
        return -(n[0] * np.asarray(x1) + n[2] * np.asarray(x3)) / n[1]


@dataclass(frozen=True)
class Foundation:
    """The three foundation planes FP1, FP2, FP3; contact point CPi slides on FPi."""

    planes: tuple[Plane, Plane, Plane]

    @cached_property
    def normals(self) -> np.ndarray:
        """(3, 3) array whose row i is the upward unit normal of FP(i+1) (computed once; read-only)."""
        normals = np.array([p.normal for p in self.planes])
        normals.setflags(write=False)
        return normals

    def validate(self, source: str | None = None) -> None:
        if len(self.planes) != 3:
            raise SpecimenError("foundation.planes", f"needs exactly 3 planes, got {len(self.planes)}", source)
        for i, p in enumerate(self.planes):
            for name in ("dip_deg", "dip_direction_deg"):
                value = getattr(p, name)
                if not math.isfinite(value):
                    raise SpecimenError(f"foundation.planes[{i}].{name}", f"must be finite, got {value}", source)
            if not 0.0 <= p.dip_deg < 90.0:
                raise SpecimenError(f"foundation.planes[{i}].dip_deg", f"must lie in [0, 90), got {p.dip_deg}", source)


#: how many passed partners a specimen or a foundation remembers (:meth:`Specimen.validate`)
_PASSED_KEPT = 256
_FRICTION_FIELDS = ("friction_deg", "tip_friction_deg")   # checked on every validation (Specimen.validate)


@dataclass(frozen=True)
class Specimen:
    """The top block, as the paper's model needs it.

    Attributes (paper names in brackets):
        contact_points_m: rest positions of CP1, CP2, CP3 in the foundation frame, shape (3, 3).
        mass_kg: block mass; its weight ``W = mass_kg * GRAVITY`` acts at the mass centre.
        mass_centre_m: mass centre relative to CP1 in the body frame (g1, g2, g3) [C, eq. 24].
        inertia_kg_m2: inertia tensor about the mass centre, axes (g1, g2, g3) [I, enters M_jl].
        load_point_A_m, load_point_B_m: aft-face load point ``P_CL = P1 + A g2 - B g3`` [eq. 27].
        friction_deg: residual friction angle at CP1/FP1, CP2/FP2, CP3/FP3 [phi_a, eq. 19].
        tip_friction_deg: friction angle between load tip and aft face [phi_EF, eq. 32].
    """

    contact_points_m: np.ndarray
    mass_kg: float
    mass_centre_m: np.ndarray
    inertia_kg_m2: np.ndarray
    load_point_A_m: float
    load_point_B_m: float
    friction_deg: tuple[float, float, float]
    tip_friction_deg: float
    name: str = "custom"

    def __post_init__(self) -> None:
        # Freeze array copies so a Specimen is a value: nobody can mutate one another holds.
        for name in ("contact_points_m", "mass_centre_m", "inertia_kg_m2"):
            arr = np.array(getattr(self, name), dtype=float)
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        object.__setattr__(self, "friction_deg", tuple(float(x) for x in self.friction_deg))

    # -- derived geometry -------------------------------------------------------------------
    @cached_property
    def body_axes(self) -> np.ndarray:
        """Rest body frame as columns ``[g1 g2 g3]`` (paper section 3.1), world coordinates."""
        p1, p2, p3 = self.contact_points_m
        g1 = (p2 - p1) / np.linalg.norm(p2 - p1)
        g2 = cross3(p2 - p1, p3 - p1)
        g2 /= np.linalg.norm(g2)
        return np.column_stack([g1, g2, cross3(g1, g2)])

    @cached_property
    def mass_centre_world(self) -> np.ndarray:
        """Mass centre at rest, foundation frame."""
        return self.contact_points_m[0] + self.body_axes @ self.mass_centre_m

    @cached_property
    def load_point_world(self) -> np.ndarray:
        """``P0_CL``: the aft-face load point at rest, foundation frame (eq. 27)."""
        g = self.body_axes
        return self.contact_points_m[0] + self.load_point_A_m * g[:, 1] - self.load_point_B_m * g[:, 2]

    @property
    def weight_N(self) -> float:
        return self.mass_kg * GRAVITY

    # -- validation -------------------------------------------------------------------------
    def validate(self, foundation: Foundation, source: str | None = None,
                 plane_tolerance_m: float = PLANE_TOLERANCE_M) -> None:
        """Raise :class:`SpecimenError` naming the first field that cannot be right. Specimens and foundations are
        immutable: a block that passed on these planes with this tolerance is not checked again (the workbench
        builds thousands of models, each a new specimen or foundation differing in one number)."""
        # A fit makes a new model for every value it tries: a new specimen for a friction angle (the same block by
        # every other number), a new foundation for a plane's dip. Each remembers what it passed with (the other
        # side by the block's numbers but its friction angles, which are checked every time: cheap, and the
        # numbers a friction fit changes), so the same pair is checked once. (Frozen dataclasses: the memories go in
        # __dict__, as cached_property puts its values.)
        mine = self.__dict__.setdefault("_passed_on", {})            # foundations' planes this block passed on
        theirs = foundation.__dict__.setdefault("_passed_blocks", {})  # blocks' numbers that passed on these planes
        planes_key = (foundation.planes, plane_tolerance_m)
        if planes_key in mine:
            return
        block_key = (self._block_values(), plane_tolerance_m)
        if block_key in theirs:
            self._check_finite(source, _FRICTION_FIELDS)   # what _validate checks of them, in its order
            self._check_friction_ranges(source)
        else:
            self._validate(foundation, source, plane_tolerance_m)
        for memory, key in ((mine, planes_key), (theirs, block_key)):
            if len(memory) >= _PASSED_KEPT:
                memory.clear()
            memory[key] = True

    def _block_values(self) -> tuple:
        """Every number :meth:`_validate` reads but the friction angles, as a hashable value (arrays by their bytes
        and shape)."""
        arrays = tuple((a.shape, a.tobytes()) for a in (self.contact_points_m, self.mass_centre_m, self.inertia_kg_m2))
        return arrays + (self.mass_kg, self.load_point_A_m, self.load_point_B_m)

    def _validate(self, foundation: Foundation, source: str | None, plane_tolerance_m: float) -> None:
        self._check_finite(source)
        foundation.validate(source)
        if self.contact_points_m.shape != (3, 3):
            raise SpecimenError("contact_points_m", f"must be 3 points of 3 coordinates, got shape "
                                f"{self.contact_points_m.shape}", source)
        if self.mass_kg <= 0:
            raise SpecimenError("mass_kg", f"must be positive, got {self.mass_kg}", source)
        self._check_inertia(source)
        self._check_friction_ranges(source)
        p = self.contact_points_m
        if np.linalg.norm(cross3(p[1] - p[0], p[2] - p[0])) < 1e-9:
            raise SpecimenError("contact_points_m", "the three contact points are collinear", source)
        for i, (n, point) in enumerate(zip(foundation.normals, p)):
            off = float(n @ point)
            if abs(off) > plane_tolerance_m:
                raise SpecimenError(f"contact_points_m[{i}]", f"CP{i + 1} lies {off:.3e} m off its plane FP{i + 1}"
                                    f" (must be within {plane_tolerance_m:g} m)", source)
        bary = barycentric_horizontal(self.mass_centre_world, p)
        if bary.min() <= 0.0:
            raise SpecimenError("mass_centre_m", "the mass centre does not project inside the contact triangle "
                                f"(barycentric coordinates {np.round(bary, 4).tolist()})", source)

    def _check_friction_ranges(self, source: str | None) -> None:
        for i, phi in enumerate(self.friction_deg):
            if not 0.0 <= phi < 45.0:
                raise SpecimenError(f"friction_deg[{i}]", f"must lie in [0, 45), got {phi}", source)
        if not 0.0 <= self.tip_friction_deg < 45.0:
            raise SpecimenError("tip_friction_deg", f"must lie in [0, 45), got {self.tip_friction_deg}", source)

    def _check_finite(self, source: str | None, names: tuple[str, ...] | None = None) -> None:
        """Refuse a NaN or infinity in the fields ``names`` (default: every numeric field), in the fields' order."""
        values = {"contact_points_m": self.contact_points_m, "mass_kg": self.mass_kg,
                  "mass_centre_m": self.mass_centre_m, "inertia_kg_m2": self.inertia_kg_m2,
                  "load_point_A_m": self.load_point_A_m, "load_point_B_m": self.load_point_B_m,
                  "friction_deg": self.friction_deg, "tip_friction_deg": self.tip_friction_deg}
        for name, value in values.items():
            if names is not None and name not in names:
                continue
            finite = math.isfinite(value) if isinstance(value, float) else \
                bool(np.isfinite(np.asarray(value, dtype=float)).all())
            if not finite:
                raise SpecimenError(name, "contains NaN or infinity", source)

    def _check_inertia(self, source: str | None) -> None:
        inertia = self.inertia_kg_m2
        if inertia.shape != (3, 3):
            raise SpecimenError("inertia_kg_m2", f"must be 3x3, got shape {inertia.shape}", source)
        if not np.abs(inertia - inertia.T).max() <= 1e-12 * max(1.0, np.abs(inertia).max()):  # (np.allclose, rtol 0)
            raise SpecimenError("inertia_kg_m2", "must be symmetric", source)
        principal = np.linalg.eigvalsh(inertia)
        if principal.min() <= 0:
            raise SpecimenError("inertia_kg_m2", f"must be positive definite (principal moments "
                                f"{principal.tolist()})", source)
        a, b, c = principal
        if a + b < c * (1 - 1e-12):
            raise SpecimenError("inertia_kg_m2", f"principal moments {principal.tolist()} violate the triangle "
                                "inequality I1 + I2 >= I3 (no real mass distribution has them)", source)


def cross3(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``np.cross`` of two 3-vectors, the same operations in the same order (so the same bits), without
    ``np.cross``'s general-shape machinery (tens of microseconds per call)."""
    a0, a1, a2 = float(a[0]), float(a[1]), float(a[2])
    b0, b1, b2 = float(b[0]), float(b[1]), float(b[2])
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


def barycentric_horizontal(point: np.ndarray, triangle: np.ndarray) -> np.ndarray:
    """Barycentric coordinates of ``point``'s overhead projection in the overhead triangle (x1, x3)."""
    a, b, c = (np.array([v[0], v[2]]) for v in triangle)
    x = np.array([point[0], point[2]])
    m = np.column_stack([b - a, c - a])
    l1, l2 = np.linalg.solve(m, x - a)
    return np.array([1.0 - l1 - l2, l1, l2])


# -- files ------------------------------------------------------------------------------------

@lru_cache(maxsize=1)
def reference() -> tuple[Specimen, Foundation]:
    """The reference specimen and foundation (``docs/specimen-format.md``; read once from the shipped TOML;
    both are immutable values)."""
    text = resources.files("triplanar").joinpath("data/reference.toml").read_text(encoding="utf-8")
    return parse_toml(tomllib.loads(text), source="triplanar/data/reference.toml")


def load_toml(path: str | Path, allow_large: bool = False) -> tuple[Specimen, Foundation]:
    """Read a specimen/foundation TOML file (format: ``docs/specimen-format.md``) and validate it strictly:
    a :class:`SpecimenError` names the file and the key of the first problem."""
    path = Path(path)
    raw = path.read_bytes()
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as err:
        raise SpecimenError("(file)", f"not UTF-8 text (byte {err.start}: {raw[err.start:err.start + 1]!r}); "
                            "save the file as UTF-8", str(path)) from None
    text = text.removeprefix("\ufeff")  # a byte-order mark, as spreadsheet editors write (CSV accepts one too)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise SpecimenError("(file)", f"not valid TOML: {err}", str(path)) from None
    return parse_toml(data, source=str(path), allow_large=allow_large)


_SPECIMEN_KEYS = {"name", "mass_kg", "contact_points_m", "mass_centre_m", "inertia_kg_m2", "load_point_A_m",
                  "load_point_B_m", "friction_deg", "tip_friction_deg"}
_SHAPES = {"mass_kg": (), "contact_points_m": (3, 3), "mass_centre_m": (3,), "inertia_kg_m2": (3, 3),
           "load_point_A_m": (), "load_point_B_m": (), "friction_deg": (3,), "tip_friction_deg": ()}
_TOP_KEYS = {"specimen", "foundation"}
_PLANE_KEYS = {"dip_deg", "dip_direction_deg"}
#: Lengths (contact-point spread, mass centre, load point) above this are refused unless ``allow_large``:
#: the laboratory blocks the model describes are decimetres; metres-sized values usually are millimetres.
MAX_LENGTH_M = 5.0
#: ... and a block smaller than this (contact-point spread) is refused: lengths given in kilometres?
MIN_SPREAD_M = 1e-3


def _number(value, where: str, source: str | None) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise SpecimenError(where, f"must be a number, got {type(value).__name__} {value!r}", source)
    try:
        return float(value)
    except OverflowError:
        raise SpecimenError(where, f"number too large: {value!r}", source) from None


def _array(value, shape: tuple[int, ...], where: str, source: str | None):
    if not shape:
        return _number(value, where, source)
    if not isinstance(value, list) or len(value) != shape[0]:
        raise SpecimenError(where, f"must be an array of shape {shape}, got {value!r}", source)
    return [_array(v, shape[1:], f"{where}[{i}]", source) for i, v in enumerate(value)]


def _table(value, where: str, source: str | None, hint: str) -> dict:
    if not isinstance(value, dict):
        raise SpecimenError(where, f"must be a table ({hint}), got {type(value).__name__} {value!r}", source)
    return value


def _refuse_unknown(table: dict, known: set[str], prefix: str, source: str | None) -> None:
    unknown = sorted(set(table) - known)
    if unknown:
        raise SpecimenError(f"{prefix}{unknown[0]}", f"unknown key (known: {', '.join(sorted(known))})", source)


def parse_toml(data: dict, source: str | None = None, allow_large: bool = False) -> tuple[Specimen, Foundation]:
    """Build and validate (specimen, foundation) from parsed TOML. Strict: unknown keys are refused at every
    level, numbers must be TOML numbers (not strings or booleans), arrays must have their shape, and lengths
    must be plausible for a laboratory block (``allow_large`` or ``allow_large = true`` in ``[specimen]``
    lifts the size limit). See ``docs/specimen-format.md``."""
    _table(data, "(file)", source, "[specimen] and [foundation]")
    _refuse_unknown(data, _TOP_KEYS, "", source)
    for key in sorted(_TOP_KEYS - set(data)):
        raise SpecimenError(key, f"missing table [{key}]", source)
    spec_table = dict(_table(data["specimen"], "specimen", source, "write [specimen], once"))
    if "allow_large" in spec_table:
        flag = spec_table.pop("allow_large")
        if not isinstance(flag, bool):
            raise SpecimenError("specimen.allow_large", f"must be true or false, got {flag!r}", source)
        allow_large = allow_large or flag
    allow_small_angles = False
    if "allow_small_angles" in spec_table:
        allow_small_angles = spec_table.pop("allow_small_angles")
        if not isinstance(allow_small_angles, bool):
            raise SpecimenError("specimen.allow_small_angles", f"must be true or false, got {allow_small_angles!r}",
                                source)
    _refuse_unknown(spec_table, _SPECIMEN_KEYS, "specimen.", source)
    missing = sorted(_SPECIMEN_KEYS - {"name"} - set(spec_table))
    if missing:
        raise SpecimenError(f"specimen.{missing[0]}", f"missing (required: {', '.join(sorted(_SHAPES))})", source)
    kwargs = {}
    if "name" in spec_table:
        if not isinstance(spec_table["name"], str):
            raise SpecimenError("specimen.name", f"must be a string, got {spec_table['name']!r}", source)
        kwargs["name"] = spec_table["name"]
    for key, shape in _SHAPES.items():
        value = _array(spec_table[key], shape, f"specimen.{key}", source)
        kwargs[key] = value if not shape else np.array(value, dtype=float)
    specimen = Specimen(**kwargs)
    found_table = _table(data["foundation"], "foundation", source, "write [foundation] with planes = [...]")
    _refuse_unknown(found_table, {"planes"}, "foundation.", source)
    planes_data = found_table.get("planes")
    if planes_data is None:
        raise SpecimenError("foundation.planes", "missing: give the three planes' dip_deg and dip_direction_deg", source)
    if not isinstance(planes_data, list):
        raise SpecimenError("foundation.planes", f"must be an array of 3 tables {{ dip_deg = ..., "
                            f"dip_direction_deg = ... }}, got {planes_data!r}", source)
    if len(planes_data) != 3:
        raise SpecimenError("foundation.planes", f"needs exactly 3 planes, got {len(planes_data)}", source)
    planes = []
    for i, entry in enumerate(planes_data):
        where = f"foundation.planes[{i}]"
        _table(entry, where, source, "{ dip_deg = ..., dip_direction_deg = ... }")
        _refuse_unknown(entry, _PLANE_KEYS, f"{where}.", source)
        if "dip_deg" not in entry:
            raise SpecimenError(f"{where}.dip_deg", "missing", source)
        planes.append(Plane(_number(entry["dip_deg"], f"{where}.dip_deg", source),
                            _number(entry.get("dip_direction_deg", 0.0), f"{where}.dip_direction_deg", source)))
    foundation = Foundation(tuple(planes))
    specimen._check_finite(source)
    if not allow_large:
        _check_size(specimen, source)
    if not allow_small_angles:
        _check_angles(specimen, foundation, source)
    specimen.validate(foundation, source)
    return specimen, foundation


#: Friction angles and plane dips all below this (degrees) look like radians: rock joints and the laboratory's
#: planes have angles of degrees to tens of degrees, while 0.3 rad is 17 deg.
RADIAN_LIKE_DEG = 1.0


def looks_like_radians(values: list[float]) -> bool:
    """Whether angles given in degrees are more likely radians: the nonzero ones all below ``RADIAN_LIKE_DEG`` (and
    at least one nonzero)."""
    nonzero = [abs(v) for v in values if v != 0.0]
    return bool(nonzero) and max(nonzero) < RADIAN_LIKE_DEG


def _check_angles(specimen: Specimen, foundation: Foundation, source: str | None) -> None:
    """Refuse angle fields whose values all look like radians (like millimetres for metres), with the override.
    Each field on its own: a file copied from the reference keeps its tip friction in degrees while the contact
    angles were typed in radians."""
    groups = {"specimen.friction_deg": list(specimen.friction_deg),
              "specimen.tip_friction_deg": [specimen.tip_friction_deg],
              "foundation.planes[*].dip_deg": [p.dip_deg for p in foundation.planes]}
    for where, values in groups.items():
        if looks_like_radians(values):
            shown = ", ".join(f"{v:g}" for v in values)
            as_deg = ", ".join(f"{math.degrees(v):.3g}" for v in values)
            raise SpecimenError(where, f"angles {shown} all look like radians ({as_deg} deg); angles are in "
                                "degrees. If they really are below 1 degree, set allow_small_angles = true in "
                                "[specimen]", source)


def _check_size(specimen: Specimen, source: str | None) -> None:
    """Refuse lengths no laboratory block has (the usual cause: millimetres where metres are expected)."""
    p = specimen.contact_points_m
    spread = float(max(np.linalg.norm(p[i] - p[j]) for i in range(3) for j in range(i)))
    lengths = {"contact_points_m": spread, "mass_centre_m": float(np.linalg.norm(specimen.mass_centre_m)),
               "load_point_A_m": abs(specimen.load_point_A_m), "load_point_B_m": abs(specimen.load_point_B_m)}
    for key, length in lengths.items():
        if length > MAX_LENGTH_M:
            raise SpecimenError(f"specimen.{key}", f"describes a block {length:.4g} m across; lengths are in "
                                f"metres (millimetres given?). A block larger than {MAX_LENGTH_M:g} m is refused "
                                "unless [specimen] sets allow_large = true", source)
    if spread < MIN_SPREAD_M:
        raise SpecimenError("specimen.contact_points_m", f"the contact points are only {spread:.3g} m apart; "
                            "lengths are in metres", source)


def to_toml(specimen: Specimen, foundation: Foundation) -> str:
    """TOML text that :func:`load_toml` reads back to the same specimen and foundation."""
    def arr(a: np.ndarray) -> str:
        return repr(np.asarray(a).tolist())
    planes = ",\n".join(f"    {{ dip_deg = {p.dip_deg!r}, dip_direction_deg = {p.dip_direction_deg!r} }}"
                        for p in foundation.planes)
    large = "allow_large = true\n" if _too_large(specimen) else ""
    return (f"[specimen]\n{large}name = {_toml_string(specimen.name)}\nmass_kg = {specimen.mass_kg!r}\n"
            f"contact_points_m = {arr(specimen.contact_points_m)}\nmass_centre_m = {arr(specimen.mass_centre_m)}\n"
            f"inertia_kg_m2 = {arr(specimen.inertia_kg_m2)}\nload_point_A_m = {specimen.load_point_A_m!r}\n"
            f"load_point_B_m = {specimen.load_point_B_m!r}\nfriction_deg = {list(specimen.friction_deg)!r}\n"
            f"tip_friction_deg = {specimen.tip_friction_deg!r}\n\n[foundation]\nplanes = [\n{planes},\n]\n")


def _too_large(specimen: Specimen) -> bool:
    try:
        _check_size(specimen, None)
    except SpecimenError as err:
        return "allow_large" in str(err)
    return False


def _toml_string(text: str) -> str:
    """A TOML basic string (Python's repr is not TOML for every string)."""
    import json  # a JSON string is a valid TOML basic string once control characters are escaped
    return json.dumps(text, ensure_ascii=False)


def mirrored(specimen: Specimen, foundation: Foundation) -> tuple[Specimen, Foundation]:
    """The mirror image in x3 (x3 -> -x3) of specimen and foundation, for symmetry checks.

    Mirroring flips the handedness of the contact triangle, so the paper's g2 = (P2-P1)x(P3-P1)/|...| points
    down and g3 = g1 x g2 flips too: in that frame the mass centre is (C1, -C2, C3) and the load point has
    A -> -A (A and B are coordinates along g2 and -g3, not lengths). Dip directions a -> -a.
    """
    flip = np.array([1.0, 1.0, -1.0])
    frame = np.array([1.0, -1.0, -1.0])  # the mirrored block's (g1, g2, g3) in the original's terms
    planes = tuple(Plane(p.dip_deg, (-p.dip_direction_deg) % 360.0) for p in foundation.planes)
    return replace(specimen, contact_points_m=specimen.contact_points_m * flip,
                   mass_centre_m=specimen.mass_centre_m * np.array([1.0, -1.0, 1.0]),
                   inertia_kg_m2=frame[:, None] * specimen.inertia_kg_m2 * frame[None, :],
                   load_point_A_m=-specimen.load_point_A_m, name=f"{specimen.name}, mirrored"), Foundation(planes)


# -- scaling (paper cases D, E, F) --------------------------------------------------------------

def scale_size(specimen: Specimen, c: float) -> Specimen:
    """Case D: every length x c at the same mass, so the inertia scales by c**2 (paper section 5.4)."""
    return _scaled(specimen, length=c, mass=1.0, inertia=c ** 2, label=f"size x{c:g}")


def scale_mass(specimen: Specimen, d: float) -> Specimen:
    """Case E: mass x d at the same size, so the inertia scales by d (paper section 5.4)."""
    return _scaled(specimen, length=1.0, mass=d, inertia=d, label=f"mass x{d:g}")


def scale_uniform(specimen: Specimen, c: float) -> Specimen:
    """Case F: lengths x c at equal density: mass x c**3, inertia x c**5 (paper section 5.5)."""
    return _scaled(specimen, length=c, mass=c ** 3, inertia=c ** 5, label=f"uniform x{c:g}")


def _scaled(s: Specimen, *, length: float, mass: float, inertia: float, label: str) -> Specimen:
    for name, value in (("length", length), ("mass", mass)):
        if not (math.isfinite(value) and value > 0):
            raise SpecimenError(f"scale ({name})", f"must be a positive finite factor, got {value}")
    return replace(s, contact_points_m=s.contact_points_m * length, mass_centre_m=s.mass_centre_m * length,
                   load_point_A_m=s.load_point_A_m * length, load_point_B_m=s.load_point_B_m * length,
                   mass_kg=s.mass_kg * mass, inertia_kg_m2=s.inertia_kg_m2 * inertia, name=f"{s.name}, {label}")

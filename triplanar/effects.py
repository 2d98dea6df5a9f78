"""Physical effects as composable parts: a small class with named, bounded parameters.

An effect changes the model in one of two ways:

* ``apply(model) -> model`` returns a changed copy of the model (specimen, foundation, loading or friction
  law). The built-in effects all work this way, so they run in the compiled fast path.
* ``wrench(t, state) -> (force, moment)`` adds a force at the mass centre and a moment about it (world
  axes, SI) at every evaluation of the right-hand side. Any Python code may go here; it runs slower
  (the compiled kernel calls back into Python) but through the same right-hand side.

Writing one (``docs/adding-an-effect.md`` has the full tutorial)::

    @register
    class ViscousDrag(Effect):
        name = "viscous_drag"
        parameters = {"c_N_s_m": Parameter(0.0, 0.0, 50.0, "N s/m", "drag per unit speed")}

        def wrench(self, t, state):
            return -self["c_N_s_m"] * state.velocity, np.zeros(3)

Built-in names are part of the interface: ``end_friction``, ``rate_friction``, ``tip_offset``,
``actuator_rise``, ``contact_friction``, ``plane_tilt``, ``cohesion``; instrument effects (``acts_on =
"instrument"``: they change what is recorded, ``read``/``unread``, or the force the load cell sets):
``load_cell_gain``, ``rangefinder_gain``, ``rangefinder_offset``, ``rangefinder_drift``, ``time_offset``,
``time_base``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from .specimen import Foundation, Plane

if TYPE_CHECKING:
    from .model import BlockState, Model
    from .specimen import Specimen


class EffectError(ValueError):
    """An unknown effect or parameter, or a value outside its bounds."""


@dataclass(frozen=True)
class Parameter:
    """One named parameter of an effect: its default, physical bounds, unit and meaning, and how a fit treats
    it. A default of NaN means "unset": the effect then leaves the model's own value.

    Fit metadata (the workbench builds an effect's fitting recipe from it, ``triplanar/workbench/candidates.py``):

    * ``neutral``: the value at which the effect does nothing (``None``: the default). A fit starts there
      (:meth:`Effect.fit_start`), never at the value a dataset was made with.
    * ``fit``: the plausible range a fit may move it over (``None``: the physical bounds; a fitted value at an
      end of it is reported implausible). ``fit_span``: instead, the start +- this, within the bounds (for a
      parameter whose neutral value is the model's own, e.g. a friction angle).
    * ``free``: whether a fit moves it (``False``: held at its default).
    * ``grid``: the coarse scan before polishing when it is the effect's only free parameter: a number of
      evenly spaced points over the fit range, or the values themselves (``None``: 7).
    * ``snap``: a fitted value closer than this to the start is set to the start (unresolvable small values).
    * ``start``: where a fit starts instead of ``neutral`` (``None``: the neutral value). For a parameter at
      whose neutral value the fit cannot see a gradient: an oscillating force's amplitude of 0 makes its
      frequency and phase invisible, and with them the amplitude's own direction of descent.
    * ``per_test``: the parameter takes its own value in every test (fitted for each test; the effect's other
      parameters are shared by all tests), e.g. the phase of a ripple that is not locked to the actuator's
      start. A fit profiles it: for given shared values each test's own values are fitted alone (a scan of
      ``grid``, default 12 points, then polishing), ``triplanar/workbench/pertest.py``.
    * ``period``: the effect repeats itself when the parameter changes by this much (a phase: 2 pi). A per-test
      fit then moves it freely and wraps it into the period centred on its fit range (no bound to get stuck at).
    * ``limit_ends``: the ends of ``fit`` (``"lower"``, ``"upper"``) that are physical limits, past which the model
      cannot go (not edges of plausibility): a fitted value resting there is reported, not read as implausible.
    """

    default: float
    lower: float
    upper: float
    unit: str
    doc: str
    neutral: float | None = None
    fit: tuple[float, float] | None = None
    fit_span: float | None = None
    free: bool = True
    grid: int | tuple[float, ...] | None = None
    snap: float = 0.0
    start: float | None = None
    per_test: bool = False
    period: float | None = None
    limit_ends: tuple[str, ...] = ()

    @property
    def neutral_value(self) -> float:
        return self.default if self.neutral is None else self.neutral

    @property
    def start_value(self) -> float:
        """Where a fit starts: ``start`` if given, else the neutral value."""
        return self.neutral_value if self.start is None else self.start

    def at_physical_limit(self, value: float, near: float) -> bool:
        """Whether ``value`` rests (within ``near`` x the range) at an end of ``fit`` that ``limit_ends`` declares a
        physical limit: a fit resting there says the value is at or near that limit, not implausible. The one test
        of it (the fits' ``at_bound`` and the calibration benchmark's re-reading of kept fits)."""
        if self.fit is None or not self.limit_ends:
            return False
        lo, hi = self.fit
        return ("lower" in self.limit_ends and value - lo <= near * (hi - lo)) or (
            "upper" in self.limit_ends and hi - value <= near * (hi - lo))

    def fit_range(self, start: float) -> tuple[float, float]:
        """The range a fit starting at ``start`` may move this parameter over."""
        if self.fit is not None:
            return self.fit
        if self.fit_span is not None:
            return max(self.lower, start - self.fit_span), min(self.upper, start + self.fit_span)
        return self.lower, self.upper


class Effect:
    """Base class: set ``name`` and ``parameters``; override what the effect changes.

    * ``apply(model)``: the model's data (specimen, foundation, loading); compiled fast path.
    * ``kernel_settings()``: named constants of the kernel's friction law (``triplanar.kernel.KERNEL_SETTINGS``);
      the model collects them in ``Model.kernel_settings``. With them goes ``contact_strength``, the same law
      in plain Python, which the independent reference (``triplanar/natural_coordinates.py``) evaluates.
    * ``wrench(t, state)``: an extra force and moment; slow path (a Python callback), any code.

    Class attributes besides ``name`` and ``parameters``: ``plane_tolerance_m`` (how far the effect may move
    the planes off the drawn contact points; the block is re-seated) and ``scenario`` (the parameter values of
    the workbench's hidden-effect check, ``triplanar/workbench/scenarios.py``; ``None``: not checked).
    """

    name: ClassVar[str] = ""
    parameters: ClassVar[dict[str, Parameter]] = {}
    plane_tolerance_m: ClassVar[float | None] = None
    #: how far (m, along the contact points' paths) two faithful implementations of the effect's equations may
    #: differ where the paper leaves a choice open; a fitted parameter's interval admits the change that moves the
    #: traces this much (``triplanar/workbench/intervals.py``). 0: the equations fix the motion.
    form_tolerance_m: ClassVar[float] = 0.0
    scenario: ClassVar[dict[str, float] | None] = None
    #: what the effect acts on: ``"physics"`` (the block's motion) or ``"instrument"`` (what is recorded of it:
    #: ``read``/``unread``, or the force the load cell sets); the workbench's verdict says which is missing
    acts_on: ClassVar[str] = "physics"
    #: whether ``diagnose`` tries the effect when no candidates are named (``False``: only when named, e.g.
    #: ``Diagnoser(candidates=[..., name])`` or ``fit --add NAME``)
    screened: ClassVar[bool] = True

    def __init__(self, **values: float):
        unknown = set(values) - set(self.parameters)
        if unknown:
            raise EffectError(f"effect {self.name!r} has no parameter {sorted(unknown)[0]!r} "
                              f"(its parameters: {', '.join(self.parameters) or 'none'})")
        self.values: dict[str, float] = {}
        for key, spec in self.parameters.items():
            value = float(values.get(key, spec.default))
            if math.isnan(value) and math.isnan(spec.default):
                self.values[key] = value  # unset: the effect leaves the model's own value
                continue
            if not math.isfinite(value) or not spec.lower <= value <= spec.upper:
                raise EffectError(f"effect {self.name!r}: {key} = {value} is outside [{spec.lower}, {spec.upper}] "
                                  f"{spec.unit}")
            self.values[key] = value

    def __getitem__(self, key: str) -> float:
        return self.values[key]

    def __repr__(self) -> str:
        """The specification that reads back as this effect (``make_effect(repr(e)) == e``): each value in 6
        significant digits where that is exact, else in full."""
        return self._spec(lambda v: f"{v:g}" if float(f"{v:g}") == v else repr(float(v)))

    def label(self) -> str:
        """The specification for people: each value in 6 significant digits (a model's description)."""
        return self._spec(lambda v: f"{v:g}")

    def _spec(self, number) -> str:
        inner = ",".join(f"{k}={number(v)}" for k, v in self.values.items() if not math.isnan(v))
        return f"{self.name}:{inner}" if inner else self.name

    def _identity(self) -> tuple:
        """Class and exact parameter values (an unset value, NaN, equals another unset one)."""
        return type(self), tuple((k, None if math.isnan(v) else v) for k, v in self.values.items())

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Effect) and self._identity() == other._identity()

    def __hash__(self) -> int:
        return hash(self._identity())

    def apply(self, model: Model) -> Model:
        """The model with this effect's parameter changes. Default: unchanged."""
        return model

    def kernel_settings(self) -> dict[str, float]:
        """Kernel-level constants this effect sets, by name (``triplanar.kernel.KERNEL_SETTINGS``). Default: none."""
        return {}

    def contact_strength(self, mu: float, c: float, speed: float) -> tuple[float, float]:
        """The contact friction law as this effect changes it: a sliding contact resists with ``mu N + c``
        (``mu``: friction coefficient, ``c``: a constant shear force, N) at slip speed ``speed`` (m/s); given
        the law so far, return the changed ``(mu, c)``. Default: unchanged. Must agree with what
        ``kernel_settings`` makes the compiled kernel do (the tests compare the two)."""
        return mu, c

    @classmethod
    def fit_start(cls, specimen: Specimen) -> dict[str, float]:
        """Where a fit of this effect starts for ``specimen``: each parameter's ``start``, else its neutral value."""
        return {k: p.start_value for k, p in cls.parameters.items()}

    def wrench(self, t: float, state: BlockState) -> tuple[np.ndarray, np.ndarray]:
        """Extra (force at the mass centre, moment about it), world axes. Default: none."""
        raise NotImplementedError

    def read(self, t_s: np.ndarray | None, positions: np.ndarray,
             rest: np.ndarray) -> tuple[np.ndarray | None, np.ndarray]:
        """What the instruments record of the true trace: ``(t_s, positions)`` with ``positions`` (n, 3, 3), m,
        and ``rest`` the (3, 3) contact points at rest. The laboratory generator applies it. Default: as is."""
        return t_s, positions

    def unread(self, t_s: np.ndarray | None, positions: np.ndarray,
               rest: np.ndarray) -> tuple[np.ndarray | None, np.ndarray]:
        """The inverse of :meth:`read`: the true trace from the record (the workbench corrects measured tests
        with it before comparing them with the model). Default: as is."""
        return t_s, positions

    @property
    def reads(self) -> bool:
        """Whether the effect changes what is recorded (overrides :meth:`read`)."""
        return type(self).read is not Effect.read

    @property
    def has_wrench(self) -> bool:
        return type(self).wrench is not Effect.wrench


REGISTRY: dict[str, type[Effect]] = {}


def register(cls: type[Effect]) -> type[Effect]:
    """Class decorator: make an effect available by name (CLI ``--effect NAME:...``, the workbench)."""
    if not cls.name:
        raise EffectError(f"{cls.__name__} needs a class attribute 'name'")
    REGISTRY[cls.name] = cls
    return cls


def make_effect(spec: str) -> Effect:
    """Build an effect from ``NAME[:PARAM=VALUE[,PARAM=VALUE...]]`` (the CLI's ``--effect`` syntax)."""
    if not isinstance(spec, str):
        raise EffectError(f"effect specification must be a string NAME[:PARAM=VALUE,...], got {spec!r}")
    name, _, rest = spec.partition(":")
    name = name.strip()
    if name not in REGISTRY:
        raise EffectError(f"unknown effect {name!r}; known effects: {', '.join(sorted(REGISTRY))}")
    values: dict[str, float] = {}
    explicit: set[str] = set()        # angles written with a "deg" suffix: meant in degrees, however small
    for item in filter(None, (part.strip() for part in rest.split(","))):
        key, eq, value = item.partition("=")
        key = key.strip()
        if not eq or not key:
            raise EffectError(f"effect {name!r}: expected PARAM=VALUE, got {item!r}")
        if key in values:
            raise EffectError(f"effect {name!r}: parameter {key} given twice ({spec!r})")
        text = value.strip()
        if key.endswith("_deg") and text.endswith("deg"):
            text = text[:-3].strip()
            explicit.add(key)
        try:
            if not text.isascii() or "_" in text:  # float() reads '1_0' and non-ASCII digits
                raise ValueError
            values[key] = float(text)
        except ValueError:
            raise EffectError(f"effect {name!r}: {key} = {value!r} is not a number") from None
    _refuse_radians(name, {k: v for k, v in values.items() if k not in explicit})
    return REGISTRY[name](**values)


def _refuse_radians(name: str, values: dict[str, float]) -> None:
    """``*_deg`` parameters that all look like radians (nonzero, below 1, while the parameter's range reaches past
    10 deg, so that the value read as radians would be a plausible angle) are refused with a hint; ``=0.5deg``
    says that a small angle is meant."""
    params = REGISTRY[name].parameters
    angles = {k: v for k, v in values.items() if k.endswith("_deg") and k in params and params[k].upper > 10.0}
    nonzero = {k: v for k, v in angles.items() if v != 0.0}
    if nonzero and all(abs(v) < 1.0 and params[k].lower <= math.degrees(v) <= params[k].upper
                       for k, v in nonzero.items()):
        k, v = next(iter(nonzero.items()))
        raise EffectError(f"effect {name!r}: {k} = {v:g} looks like radians ({math.degrees(v):.3g} deg); angles "
                          f"are in degrees. For a true angle below 1 degree write {k}={v:g}deg")


# -- the built-in library ------------------------------------------------------------------------

@register
class EndFriction(Effect):
    """Friction between the load tip and the aft face (paper eq. 32-33): turns case B into case A.

    Magnitude ``F_T (e1.g1) tan(phi_EF)``, opposing the slip of the aft face relative to the tip.
    Signature: suppresses CP1's lateral dilation and reverses the block's rotation (paper section 5.2).
    """

    name = "end_friction"
    parameters = {"phi_deg": Parameter(8.0, 0.0, 40.0, "deg", "tip/aft-face friction angle phi_EF", neutral=0.0,
                                       fit=(0.0, 30.0))}
    scenario = {"phi_deg": 8.0}

    def apply(self, model: Model) -> Model:
        return replace(model, specimen=replace(model.specimen, tip_friction_deg=self["phi_deg"]),
                       loading=replace(model.loading, end_friction=True))


@register
class RateFriction(Effect):
    """Rate-dependent contact friction: ``mu = tan(phi) (1 + a ln(1 + |v|/v0))`` at every contact.

    ``a > 0`` strengthens with speed, ``a < 0`` weakens (the paper's section 5.1 suspects rate effects
    near 1 m/s). Signature: grows with speed, so it bends fast (high-load) traces more than slow ones and
    delays arrival.
    """

    name = "rate_friction"
    # v0 is not fitted: a and v0 trade off over the 0.1-1 m/s of a test.
    parameters = {"a": Parameter(0.0, -0.3, 1.0, "-", "rate sensitivity"),
                  "v0_m_s": Parameter(0.05, 1e-4, 10.0, "m/s", "reference slip speed", free=False)}
    scenario = {"a": 0.3}

    def kernel_settings(self) -> dict[str, float]:
        return {"rate_a": self["a"], "rate_v0_m_s": self["v0_m_s"]}

    def contact_strength(self, mu: float, c: float, speed: float) -> tuple[float, float]:
        return mu * (1.0 + self["a"] * math.log1p(speed / self["v0_m_s"])), c


@register
class TipOffset(Effect):
    """The load tip's line lies ``offset_m`` off the aft-face centreline, along +e3 (misalignment).

    Signature: a moment about the vertical from the first instant, so the block turns and CP paths bend
    even at high load.
    """

    name = "tip_offset"
    parameters = {"offset_m": Parameter(0.0, -0.05, 0.05, "m", "lateral offset of the tip line (+e3)",
                                        fit=(-0.02, 0.02), grid=9)}
    scenario = {"offset_m": -0.005}

    def apply(self, model: Model) -> Model:
        return replace(model, loading=replace(model.loading, tip_offset_m=self["offset_m"]))


@register
class ActuatorRise(Effect):
    """The actuator force rises to its command as ``1 - exp(-t/tau)`` instead of stepping.

    Signature: mainly in time (late arrival at each travel), slightly in path at low load.
    """

    name = "actuator_rise"
    # Below 2 ms the fit reads 0: one sample at 200 Hz is 5 ms, a faster rise is not resolved by the data
    # (and a rise of microseconds is integrated badly).
    parameters = {"tau_s": Parameter(0.0, 0.0, 2.0, "s", "first-order rise time constant", fit=(0.0, 0.3),
                                     grid=(0.0, 0.01, 0.03, 0.08, 0.2), snap=0.002)}
    # The force rises from the sliding threshold, where the slip directions are undefined (docs/physics.md, "Slip
    # onset"): the kernel blends them below 1e-5 m/s; an implementation that does not (the natural-coordinates
    # reference, benchmarks/independent_lab.py) differs by 0.57 mm by 6 cm at a 1 ms step.
    form_tolerance_m = 6e-4
    scenario = {"tau_s": 0.05}

    def apply(self, model: Model) -> Model:
        return replace(model, loading=replace(model.loading, rise_time_s=self["tau_s"]))


@register
class ContactFriction(Effect):
    """The three contact friction angles differ from the specimen's values.

    Signature: changes how the three points share resistance, so the block turns differently; affects
    every load level.
    """

    name = "contact_friction"
    parameters = {f"phi{i}_deg": Parameter(math.nan, 0.0, 44.0, "deg", f"friction angle CP{i}/FP{i} (unset: the "
                                           "specimen's)", fit_span=8.0) for i in (1, 2, 3)}
    scenario = {"phi1_deg": 15.0, "phi2_deg": 17.0, "phi3_deg": 10.0}

    @classmethod
    def fit_start(cls, specimen: Specimen) -> dict[str, float]:
        """The specimen's own angles (where the effect does nothing)."""
        return {f"phi{i}_deg": float(specimen.friction_deg[i - 1]) for i in (1, 2, 3)}

    def apply(self, model: Model) -> Model:
        phis = tuple(model.specimen.friction_deg[i - 1] if math.isnan(self[f"phi{i}_deg"]) else self[f"phi{i}_deg"]
                     for i in (1, 2, 3))
        return replace(model, specimen=replace(model.specimen, friction_deg=phis))


@register
class PlaneTilt(Effect):
    """A foundation plane's dip or dip direction differs from the drawing (machining error).

    FP1 (dip 0 on the drawing) tilts any way: ``dip1_e1_deg`` and ``dip1_e3_deg`` are its apparent dips along
    e1 and e3 (downhill toward +e1, +e3 positive: ``tan`` of each is the plane's downward slope along that axis,
    so the two together are the tilt of its normal, with no singular direction at zero dip); a fit moves these
    two. ``dip1_deg`` toward ``dip_dir1_deg`` says the same as a dip and its direction, and adds to them (the
    slopes add). For FP2 and FP3 the parameters are changes added to the drawing's dip and dip direction. The
    block is re-seated on the actual planes (the smallest rigid motion that puts each contact point back on its
    plane). Signature: steady lateral drift of the contact point on the tilted plane, at every load.
    """

    name = "plane_tilt"
    # Bounds keep the re-seating of the reference block under 5 mm (the measurement format's tolerance):
    # only FP1's dip and FP1/FP2's dip directions move a resting contact point (CP3 sits at the origin,
    # CP2 on FP2's strike line); FP1 dipping 1 deg toward +e3 re-seats CP1 4.2 mm.
    # Fits of FP1's two components: along e1 within (-1, 0.5) deg: a forward dip of more than 0.58 deg (toward e1)
    # puts CP2 under FP2's extension more than 0.1 mm at rest, where the core ends the run at t = 0
    # (``left_plane``), a cliff in the objective; along e3 within (-0.02, 1) deg: dipping toward -e3 by 0.03 deg
    # puts CP2 under FP1 the same way (measured on the reference block at 40 N), so that range ends just below the
    # drawing: a fit of data without a sideways dip may stop at that end (-0.019 on the hidden plane_tilt test's
    # data); that end is a physical limit (``limit_ends``), so resting there reads "no sideways dip", not an
    # implausible value. A range past the step (-0.2) let the fit cross it and end
    # worse (1.30 mm against 1.16); snapping values under 0.03 deg to 0 trapped a 0.5 deg sideways dip in the
    # backward-tilt minimum. Dip directions of FP2/FP3 are not fitted (a change of a few degrees moves CP2 off its
    # plane).
    parameters = {"dip1_e1_deg": Parameter(0.0, -1.0, 1.0, "deg", "FP1's apparent dip along e1 (downhill toward "
                                           "+e1 positive; drawing: 0)", fit=(-1.0, 0.5)),
                  "dip1_e3_deg": Parameter(0.0, -1.0, 1.0, "deg", "FP1's apparent dip along e3 (downhill toward "
                                           "+e3 positive; drawing: 0)", fit=(-0.02, 1.0), limit_ends=("lower",)),
                  "dip1_deg": Parameter(0.0, -1.0, 1.0, "deg", "change of FP1's dip toward dip_dir1_deg (drawing: "
                                        "0; a fit moves the two components instead)", free=False),
                  "dip2_deg": Parameter(0.0, -3.0, 3.0, "deg", "change of FP2's dip"),
                  "dip3_deg": Parameter(0.0, -3.0, 3.0, "deg", "change of FP3's dip"),
                  "dip_dir1_deg": Parameter(0.0, -180.0, 180.0, "deg", "direction FP1 tilts toward (with dip1)",
                                            free=False),
                  "dip_dir2_deg": Parameter(0.0, -5.0, 5.0, "deg", "change of FP2's dip direction", free=False),
                  "dip_dir3_deg": Parameter(0.0, -30.0, 30.0, "deg", "change of FP3's dip direction", free=False)}
    plane_tolerance_m = 0.005  # the re-seated block may start this far from the drawing
    scenario = {"dip2_deg": 2.5}

    def apply(self, model: Model) -> Model:
        planes = []
        for i, plane in enumerate(model.foundation.planes, start=1):
            dip = plane.dip_deg + self[f"dip{i}_deg"]
            direction = plane.dip_direction_deg + self[f"dip_dir{i}_deg"]
            if dip < 0:  # a negative dip is the same plane dipping the other way
                dip, direction = -dip, direction + 180.0
            if i == 1 and (self["dip1_e1_deg"] or self["dip1_e3_deg"]):
                dip, direction = _add_slopes(dip, direction, self["dip1_e1_deg"], self["dip1_e3_deg"])
            planes.append(Plane(dip, direction))
        return replace(model, foundation=Foundation(tuple(planes)))


def _add_slopes(dip_deg: float, direction_deg: float, along_e1_deg: float, along_e3_deg: float) -> tuple[float, float]:
    """The plane of dip ``dip_deg`` toward ``direction_deg`` with the downward slopes ``tan(along_e1_deg)`` along
    e1 and ``tan(along_e3_deg)`` along e3 added: its dip and dip direction, degrees (:class:`Plane`: downhill
    direction ``cos(a) e1 + sin(a) e3``, so the slope along e1 is ``tan(dip) cos(a)``, along e3 ``tan(dip) sin(a)``)."""
    d, a = math.radians(dip_deg), math.radians(direction_deg)
    s1 = math.tan(d) * math.cos(a) + math.tan(math.radians(along_e1_deg))
    s3 = math.tan(d) * math.sin(a) + math.tan(math.radians(along_e3_deg))
    return math.degrees(math.atan(math.hypot(s1, s3))), math.degrees(math.atan2(s3, s1))


@register
class Cohesion(Effect):
    """Mohr-Coulomb cohesion at the three contacts: the shear strength is ``N_i tan(phi_i) + c``.

    A sliding contact resists with ``S_i = -(mu_i N_i + c) v_i/|v_i|`` (the paper's eq. 21 plus a constant
    part, opposing the slip with the kernel's low-speed direction blending); a stuck contact holds while
    ``|S_i| <= mu_i N_i + c``; the static-equilibrium check's friction cones widen by ``c``
    (``triplanar/equilibrium.py``). The power ``c |v_i|`` is booked in the contact's dissipation.
    Signature: a resistance independent of load and speed: it raises the sliding threshold by about ``3 c``
    and slows every test by the same force, so it weighs most at low load.
    """

    name = "cohesion"
    # Fit range: each newton per contact raises the reference block's sliding threshold by about 3.6 N (25.6 N
    # in case A without it), so beyond 1.5 N the paper's lowest loads would not slide; a coarser grid jumps
    # from "no effect" to "held".
    parameters = {"c_N": Parameter(0.0, 0.0, 50.0, "N", "cohesion: shear strength at each contact at zero "
                                   "normal force", fit=(0.0, 1.5))}
    scenario = {"c_N": 0.4}

    def kernel_settings(self) -> dict[str, float]:
        return {"cohesion_N": self["c_N"]}

    def contact_strength(self, mu: float, c: float, speed: float) -> tuple[float, float]:
        return mu, c + self["c_N"]


# -- instrument effects: they act on the measurement, not on the block ------------------------------------

@register
class LoadCellGain(Effect):
    """The load cell reads ``gain`` x the true force, and the actuator is servoed to its reading: the block is
    pushed with ``F / gain`` where the file says ``F``.

    Signature: like a changed load everywhere (faster or slower tests, the paths of another load level)."""

    name = "load_cell_gain"
    acts_on = "instrument"
    parameters = {"gain": Parameter(1.0, 0.5, 1.5, "-", "load-cell reading / true force", fit=(0.8, 1.2))}
    scenario = {"gain": 0.9}

    def apply(self, model: Model) -> Model:
        return replace(model, loading=replace(model.loading, force_N=model.loading.force_N / self["gain"]))


def _axes(effect: Effect, stem: str) -> np.ndarray:
    return np.array([effect[f"{stem}{a}"] for a in ("x1", "x2", "x3")])


@register
class RangefinderGain(Effect):
    """Each rangefinder axis reads ``gain`` x the true displacement from the rest position (a calibration
    error); per axis, the same for the three contact points. The vertical (x2) gain is held (files often lack x2).

    Signature: every displacement along an axis in proportion, in every test alike."""

    name = "rangefinder_gain"
    acts_on = "instrument"
    parameters = {f"gain_{a}": Parameter(1.0, 0.5, 1.5, "-", f"reading / true displacement along {a}",
                                         fit=(0.7, 1.3), free=a != "x2") for a in ("x1", "x2", "x3")}
    scenario = {"gain_x3": 1.2}

    def read(self, t_s, positions, rest):
        return t_s, rest + (positions - rest) * _axes(self, "gain_")

    def unread(self, t_s, positions, rest):
        return t_s, rest + (positions - rest) / _axes(self, "gain_")


@register
class RangefinderOffset(Effect):
    """Each rangefinder axis reads ``offset`` too much (a zero error), the same for the three contact points;
    the vertical (x2) offset is held.

    Signature: a constant shift of every path, in every test alike, from the first sample."""

    name = "rangefinder_offset"
    acts_on = "instrument"
    parameters = {f"offset_{a}_m": Parameter(0.0, -0.02, 0.02, "m", f"zero error along {a}", fit=(-0.005, 0.005),
                                             free=a != "x2") for a in ("x1", "x2", "x3")}
    scenario = {"offset_x3_m": 0.0015}

    def read(self, t_s, positions, rest):
        return t_s, positions + np.array([self["offset_x1_m"], self["offset_x2_m"], self["offset_x3_m"]])

    def unread(self, t_s, positions, rest):
        return t_s, positions - np.array([self["offset_x1_m"], self["offset_x2_m"], self["offset_x3_m"]])


@register
class RangefinderDrift(Effect):
    """The rangefinders' zero drifts at a constant rate during a test (warming electronics), along x1 and x3.

    Signature: an error growing linearly in time, the same in every test; without ``t_s`` in the file it is
    invisible (nothing is changed)."""

    name = "rangefinder_drift"
    acts_on = "instrument"
    parameters = {f"drift_{a}_m_s": Parameter(0.0, -0.05, 0.05, "m/s", f"zero drift along {a}", fit=(-0.01, 0.01))
                  for a in ("x1", "x3")}
    scenario = {"drift_x3_m_s": 0.004}

    def _shift(self, t_s: np.ndarray | None) -> np.ndarray:
        if t_s is None:
            return np.zeros(3)
        return np.asarray(t_s)[:, None, None] * np.array([self["drift_x1_m_s"], 0.0, self["drift_x3_m_s"]])

    def read(self, t_s, positions, rest):
        return t_s, positions + self._shift(t_s)

    def unread(self, t_s, positions, rest):
        return t_s, positions - self._shift(t_s)


@register
class TimeOffset(Effect):
    """The recorded clock is ``dt_s`` ahead of the start of sliding (a trigger delay): ``t_s = t + dt``.

    Signature: only in time (every test early or late by the same amount); without ``t_s`` invisible."""

    name = "time_offset"
    acts_on = "instrument"
    parameters = {"dt_s": Parameter(0.0, -0.2, 0.2, "s", "recorded minus true time", fit=(-0.05, 0.05))}
    scenario = {"dt_s": 0.03}

    def read(self, t_s, positions, rest):
        return (None if t_s is None else t_s + self["dt_s"]), positions

    def unread(self, t_s, positions, rest):
        return (None if t_s is None else t_s - self["dt_s"]), positions


@register
class TimeBase(Effect):
    """The logger's clock runs ``rate`` x true time (a crystal off its frequency, a sampling rate set wrong in the
    logger): ``t_s = rate * t``, about the trigger.

    Signature: only in time, in proportion to it (each test's late samples early or late by more than its early
    ones, unlike ``time_offset``'s constant shift); along a test whose travel grows steadily with time, like a gain
    of the travel's rangefinder; without ``t_s`` invisible.

    Not screened by ``diagnose`` unless named: among the default candidates it took causes outside the library for
    a clock (on the workbench calibration's tuning part, seeds 1000-7065: four of the six quadratic drags that were
    rightly ``outside_library`` named ``time_base``, low; two rangefinder gains named ``high`` lowered to ``low``; no
    verdict made right), while a clock 2-5 % off in the independent laboratory's data showed in one of three
    datasets (its D 1.19; the other two below detectability), named a rangefinder gain. ``docs/workbench.md``. Its
    rate is audited instead as a given number of the instruments (``time_base_rate``,
    :mod:`triplanar.instrument_numbers`): said beside the verdict, never named in its place."""

    name = "time_base"
    acts_on = "instrument"
    screened = False
    parameters = {"rate": Parameter(1.0, 0.5, 1.5, "-", "recorded / true elapsed time", fit=(0.8, 1.2))}
    scenario = {"rate": 1.08}

    def read(self, t_s, positions, rest):
        return (None if t_s is None else t_s * self["rate"]), positions

    def unread(self, t_s, positions, rest):
        return (None if t_s is None else t_s / self["rate"]), positions


BUILTIN: tuple[str, ...] = tuple(REGISTRY)  # the built-in library above, in registration order

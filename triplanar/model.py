"""A complete model: specimen + foundation + loading + friction law + effects, packed for the kernel.

Paper cases (section 4): ``A`` actuator with end friction, ``B`` actuator without it, ``C`` hydrostatic
(frictionless, along g1 at the body-fixed ``P_CL``). Cases D-F are A/B with a scaled specimen
(:mod:`triplanar.specimen`'s ``scale_size``, ``scale_mass``, ``scale_uniform``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from functools import cached_property
from typing import Iterable, Literal

import numpy as np

from . import kernel as K
from .effects import Effect
from .specimen import GRAVITY, PLANE_TOLERANCE_M, Foundation, Specimen, SpecimenError, cross3, reference

PAPER_CASES = ("A", "B", "C")
SEAT_TOLERANCE_M = 1e-4  # how far a re-seated contact point may start across a line where planes meet


@dataclass(frozen=True)
class Loading:
    """How the block is pushed.

    Attributes (paper names in brackets):
        force_N: commanded thrust [F_T].
        kind: ``"actuator"`` - force ``F_T e1`` at the instantaneous load point ``P_L`` where the space-fixed
            tip line meets the aft face (eq. 27-30); ``"hydrostatic"`` - force ``F_T g1`` at ``P_CL`` (case C).
        end_friction: whether the tip rubs on the aft face with the specimen's ``tip_friction_deg``
            [F_EF, eq. 32-33]; only meaningful for the actuator.
        tip_offset_m: lateral (+e3) offset of the tip line from the aft-face centreline at rest.
        rise_time_s: actuator force time constant (0: the force is the command from the start).
    """

    force_N: float
    kind: Literal["actuator", "hydrostatic"] = "actuator"
    end_friction: bool = True
    tip_offset_m: float = 0.0
    rise_time_s: float = 0.0


class BlockState:
    """What a user effect's ``wrench`` sees: the block's kinematics at one instant (world frame, SI; read-only).

    ``t`` is the time since the actuator began pushing (t = 0: the commanded thrust is switched on, at the
    rest position; ``time_since_actuator_s`` is the same number under a self-explaining name). ``thrust_N``
    is F_T at that instant; ``thrust_direction`` the unit vector it acts along (e1 for the actuator, g1 for
    case C's hydrostatic load); ``load_point`` the point it acts at (P_L of eq. 27-28, or P_CL for case C);
    ``specimen`` the block and its contacts (mass, inertia, friction angles, drawing). ``position`` is the mass
    centre, ``rotation`` (3, 3) has columns g1, g2, g3, ``velocity`` is the mass centre's, ``omega`` the angular
    velocity, ``contact_points`` and ``contact_velocities`` are (3, 3), CP1..CP3 by row.

    Nothing is decoded before it is read: a ``wrench`` runs at every right-hand-side evaluation and most read one or
    two attributes (a viscous drag reads ``velocity`` only), and decoding all of them every time cost more than the
    rest of the callback. ``position``, ``velocity`` and ``omega`` are copied from the state at each read; the
    rotation, contact points and velocities and load point are decoded together (one compiled call) at the first
    read of any of them and kept, as is ``thrust_direction``. The values are the same either way.
    """

    __slots__ = ("t", "_y", "_model", "_kinematics", "_direction")

    def __init__(self, t: float, y: np.ndarray, model: Model):
        self.t = t
        self._y = y.copy()      # (the kernel reuses its state's memory after the callback returns)
        self._model = model
        self._kinematics: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = None
        self._direction: np.ndarray | None = None

    def __repr__(self) -> str:
        return f"BlockState(t={self.t!r}, position={self.position!r}, velocity={self.velocity!r})"

    @property
    def time_since_actuator_s(self) -> float:
        return self.t

    @property
    def position(self) -> np.ndarray:
        return self._y[K.S_R:K.S_R + 3].copy()

    @property
    def velocity(self) -> np.ndarray:
        return self._y[K.S_V:K.S_V + 3].copy()

    @property
    def omega(self) -> np.ndarray:
        return self._y[K.S_W:K.S_W + 3].copy()

    @property
    def thrust_N(self) -> float:
        loading = self._model.loading
        return loading.force_N if loading.rise_time_s <= 0 else float(self._y[K.S_F])

    @property
    def specimen(self) -> Specimen:
        return self._model.specimen

    def _decoded(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Rotation, contact points, their velocities and the load point, from one compiled call (each numba call
        from Python costs ~5 us), made the first time one of them is read."""
        if self._kinematics is None:
            rot, cps, cpv, load_point = np.empty((3, 3)), np.empty((3, 3)), np.empty((3, 3)), np.empty(3)
            K.block_kinematics(self._y, self._model._writable_params, rot, cps, cpv, load_point)
            self._kinematics = rot, cps, cpv, load_point
        return self._kinematics

    @property
    def rotation(self) -> np.ndarray:
        return self._decoded()[0]

    @property
    def contact_points(self) -> np.ndarray:
        return self._decoded()[1]

    @property
    def contact_velocities(self) -> np.ndarray:
        return self._decoded()[2]

    @property
    def load_point(self) -> np.ndarray:
        return self._decoded()[3]

    @property
    def thrust_direction(self) -> np.ndarray:
        if self._direction is None:
            self._direction = (np.array([1.0, 0.0, 0.0]) if self._model.loading.kind == "actuator"
                               else self.rotation[:, 0].copy())
        return self._direction

    def moment_of(self, force: np.ndarray, at: np.ndarray) -> np.ndarray:
        """The moment about the mass centre of ``force`` acting at the point ``at`` (world axes): (at - position) x
        force, the same bits as ``np.cross`` at a tenth of its cost (``np.cross`` takes tens of microseconds, and a
        ``wrench`` runs at every right-hand-side evaluation)."""
        return cross3(np.asarray(at, dtype=float) - self._y[K.S_R:K.S_R + 3], np.asarray(force, dtype=float))


@dataclass(frozen=True)
class Model:
    """Everything a simulation needs. Build with :func:`paper_model` or directly; add effects with
    :meth:`with_effects`.

    ``kernel_settings``: constants of the kernel's friction law that effects set (``Effect.kernel_settings``),
    as sorted (name, value) pairs; an unset name takes its default from ``kernel.KERNEL_SETTINGS``.
    """

    loading: Loading
    specimen: Specimen = field(default_factory=lambda: reference()[0])
    foundation: Foundation = field(default_factory=lambda: reference()[1])
    kernel_settings: tuple[tuple[str, float], ...] = ()  # (name, value) pairs, ``kernel.KERNEL_SETTINGS``
    effects: tuple[Effect, ...] = ()

    def with_force(self, force_N: float) -> Model:
        """The same model at another commanded force."""
        return replace(self, loading=replace(self.loading, force_N=float(force_N)))

    def with_effects(self, effects: Iterable[Effect]) -> Model:
        """This model with each effect applied in turn (and recorded in ``effects``)."""
        model = self
        for effect in effects:
            changed = effect.apply(model)
            settings = {**dict(changed.kernel_settings), **effect.kernel_settings()}
            model = replace(changed, effects=model.effects + (effect,),
                            kernel_settings=tuple(sorted((k, float(v)) for k, v in settings.items())))
        return model

    def setting(self, name: str) -> float:
        """A kernel-level setting's value: what an effect set, or its default."""
        if name not in K.KERNEL_SETTINGS:
            raise KeyError(f"no kernel setting {name!r} (known: {', '.join(K.KERNEL_SETTINGS)})")
        return dict(self.kernel_settings).get(name, K.KERNEL_SETTINGS[name][1])

    @cached_property
    def force_effects(self) -> tuple[Effect, ...]:
        return tuple(e for e in self.effects if e.has_wrench)

    @property
    def tan_phi_EF(self) -> float:
        """End friction coefficient in use (0 when off or for the hydrostatic load)."""
        if self.loading.kind != "actuator" or not self.loading.end_friction:
            return 0.0
        return math.tan(math.radians(self.specimen.tip_friction_deg))

    def validate(self) -> None:
        """Raise :class:`SpecimenError` naming the first field that cannot be right. A model is immutable, so a
        model that passed is not checked again (``simulate`` validates the model that ``paper_model`` or the
        workbench already validated: the check was a sixth of a workbench fit's time)."""
        if self.__dict__.get("_validated"):
            return
        self._validate()
        self.__dict__["_validated"] = True  # (frozen dataclass: set like functools.cached_property does)

    def _validate(self) -> None:
        s, load = self.specimen, self.loading
        if not (math.isfinite(load.force_N) and load.force_N >= 0):
            raise SpecimenError("loading.force_N", f"must be finite and non-negative, got {load.force_N}")
        if load.kind not in ("actuator", "hydrostatic"):
            raise SpecimenError("loading.kind", f"must be 'actuator' or 'hydrostatic', got {load.kind!r}")
        if not (math.isfinite(load.rise_time_s) and load.rise_time_s >= 0):
            raise SpecimenError("loading.rise_time_s", f"must be >= 0, got {load.rise_time_s}")
        if not math.isfinite(load.tip_offset_m):
            raise SpecimenError("loading.tip_offset_m", "must be finite")
        for name, value in self.kernel_settings:
            if name not in K.KERNEL_SETTINGS:
                raise SpecimenError(f"kernel_settings.{name}", f"unknown (known: {', '.join(K.KERNEL_SETTINGS)})")
            _, _, lower, upper = K.KERNEL_SETTINGS[name]
            if not lower <= value <= upper:
                raise SpecimenError(f"kernel_settings.{name}", f"must lie in [{lower}, {upper}], got {value}")
        # An effect that moves the planes off the drawn contact points (tilted planes) says how far: the block
        # is re-seated by initial_state(), so only then is more than the drawing's tolerance allowed.
        tolerance = max([PLANE_TOLERANCE_M] + [e.plane_tolerance_m for e in self.effects
                                               if e.plane_tolerance_m is not None])
        s.validate(self.foundation, plane_tolerance_m=tolerance)

    # -- packing for the kernel --------------------------------------------------------------
    def kernel_params(self) -> np.ndarray:
        """The kernel's parameter vector (layout: ``kernel.P_*``)."""
        s = self.specimen
        p = np.zeros(K.N_PARAM)
        g = s.body_axes                      # rest body frame, columns g1 g2 g3
        com = s.mass_centre_world
        p[K.P_MASS] = s.mass_kg
        p[K.P_G] = GRAVITY
        p[K.P_IB:K.P_IB + 9] = s.inertia_kg_m2.ravel()
        p[K.P_IBINV:K.P_IBINV + 9] = np.linalg.inv(s.inertia_kg_m2).ravel()
        p[K.P_C:K.P_C + 9] = ((s.contact_points_m - com) @ g).ravel()
        p[K.P_N:K.P_N + 9] = self.foundation.normals.ravel()
        p[K.P_TANPHI:K.P_TANPHI + 3] = np.tan(np.radians(s.friction_deg))
        p[K.P_TANEF] = self.tan_phi_EF
        p[K.P_CASE] = 0.0 if self.loading.kind == "actuator" else 1.0
        p[K.P_FCMD] = self.loading.force_N
        p[K.P_TAU] = self.loading.rise_time_s
        p[K.P_PCL:K.P_PCL + 3] = (s.load_point_world - com) @ g
        p[K.P_TIP0:K.P_TIP0 + 3] = s.load_point_world
        for name, (slot, _, _, _) in K.KERNEL_SETTINGS.items():
            p[slot] = self.setting(name)
        p[K.P_USER] = 0.0  # (no user force function: a run passes its own, kernel.user_force)
        # Re-seated on tilted planes, a contact point that rests on a line where two planes meet may start
        # a hair across it; the plane-crossing events count only what lies beyond that start, up to
        # SEAT_TOLERANCE_M. Deeper than that the tilted planes put the point under another plane (it would
        # rest on that one): the run ends at t = 0 with ``left_plane``, honestly.
        y = self._unseated_state(self.loading.force_N)
        # (the *_ws functions, called with a workspace: their wrappers without one would be compiled too, each with
        # all it calls built in again)
        ws = K.new_workspace()  # (all contacts sliding: a new workspace's modes)
        if K.project_ws(y, p, ws):
            aux, events = np.empty(K.N_AUX), np.empty(K.N_EVENTS)
            K.dynamics_ws(0.0, y, p, np.empty(K.N_STATE), aux, ws)
            K.event_values_ws(y, p, aux, 0.0, 0.0, events, ws)
            crossed = events[K.EV_LEFT_PLANE:K.EV_LEFT_PLANE + 6]
            p[K.P_LEFT0:K.P_LEFT0 + 6] = np.clip(crossed + K.LEFT_PLANE_TOL, 0.0, SEAT_TOLERANCE_M)
        return p

    def _unseated_state(self, thrust_N: float) -> np.ndarray:
        s = self.specimen
        y = np.zeros(K.N_STATE)
        y[K.S_R:K.S_R + 3] = s.mass_centre_world
        y[K.S_Q:K.S_Q + 4] = self._rest_quaternion
        y[K.S_F] = thrust_N
        y[K.S_U] = self.loading.tip_offset_m
        return y

    def initial_state(self, thrust_N: float | None = None) -> np.ndarray:
        """The block at rest, seated on the planes; actuator force ``thrust_N`` (default: the command)."""
        y = self._unseated_state(self.loading.force_N if thrust_N is None else thrust_N)
        p = self.kernel_params_cached.copy()  # (writable, as everywhere: numba compiles a version per array flag)
        if not K.project_ws(y, p, K.new_workspace()):
            raise SpecimenError("foundation.planes", "the block cannot be seated on these planes")
        return y

    def block_state(self, t: float, y: np.ndarray) -> BlockState:
        """Decode a kernel state for user code (each attribute when it is first read: :class:`BlockState`)."""
        return BlockState(t, y, self)

    @cached_property
    def _writable_params(self) -> np.ndarray:
        """A writable copy of the kernel parameters for :meth:`block_state`, made once per model (numba compiles
        another version for a read-only array; the functions it goes to only read it)."""
        return self.kernel_params_cached.copy()

    def user_wrench(self, t: float, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The user effects' force at the mass centre and moment about it (world axes) at kernel state ``y``: what
        the kernel adds through its callback while a run goes on, and the statics at rest."""
        state = self.block_state(t, y)
        force, moment = np.zeros(3), np.zeros(3)
        for effect in self.force_effects:
            f, m = effect.wrench(t, state)
            force += f      # (numpy converts a list or tuple; np.asarray first cost 0.5 us a callback)
            moment += m
        return force, moment

    @cached_property
    def _rest_quaternion(self) -> np.ndarray:
        """The specimen's rest orientation as a quaternion (computed once per model)."""
        return quaternion_from_matrix(self.specimen.body_axes)

    @cached_property
    def seated_contact_points(self) -> np.ndarray:
        """(3, 3) CP1..CP3 of the block at rest, seated on this model's planes (:meth:`initial_state`; a simulated
        run's first row): the origin of every path compared with this model (:mod:`triplanar.paths`). On the
        drawing's planes it is the drawing (:attr:`Specimen.contact_points_m`); on tilted planes the block sits
        elsewhere. Read-only."""
        y = self.initial_state()
        cps = np.empty((3, 3))
        K.contact_points(y, self.kernel_params_cached.copy(), cps)
        cps.setflags(write=False)
        return cps

    @cached_property
    def kernel_params_cached(self) -> np.ndarray:
        """:meth:`kernel_params`, computed once; read-only (copy it before changing anything)."""
        params = self.kernel_params()
        params.setflags(write=False)
        return params


def paper_model(case: str, force_N: float, specimen: Specimen | None = None, foundation: Foundation | None = None,
                effects: Iterable[Effect] = ()) -> Model:
    """The paper's case ``A`` (end friction), ``B`` (none) or ``C`` (hydrostatic) at ``force_N``."""
    case = case.upper()
    if case not in PAPER_CASES:
        raise SpecimenError("case", f"must be one of {PAPER_CASES} (D-F are A/B with a scaled specimen), got {case!r}")
    ref_specimen, ref_foundation = reference()
    loading = Loading(force_N=float(force_N), kind="hydrostatic" if case == "C" else "actuator",
                      end_friction=(case == "A"))
    model = Model(loading, specimen or ref_specimen, foundation or ref_foundation)
    model = model.with_effects(effects)
    model.validate()
    return model


def quaternion_from_matrix(m: np.ndarray) -> np.ndarray:
    """Unit quaternion (w, x, y, z) of a rotation matrix (Shepperd's method)."""
    tr = np.trace(m)
    if tr > 0:
        s = 2.0 * math.sqrt(tr + 1.0)
        q = [0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s]
    else:
        i = int(np.argmax(np.diag(m)))
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2.0 * math.sqrt(1.0 + m[i, i] - m[j, j] - m[k, k])
        q = [0.0] * 4
        q[0] = (m[k, j] - m[j, k]) / s
        q[1 + i] = 0.25 * s
        q[1 + j] = (m[j, i] + m[i, j]) / s
        q[1 + k] = (m[k, i] + m[i, k]) / s
    q = np.array(q)
    return q / np.linalg.norm(q)

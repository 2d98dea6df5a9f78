"""The result of one simulated test: what happened, the trajectory, the forces and the energy budget."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import NamedTuple

import numpy as np
from numba import njit

from . import kernel as K
from .interpolate import CubicHermite, distinct_times, linear
from .measurement import MeasuredTest, write_measurements
from .model import Model
from .outcome import Outcome, event_name
from .paths import travel as path_travel


class Event(NamedTuple):
    """One event of a run, in order: the time, the kernel's event index (-1 for a decision of the statics,
    such as an arrest) and the outcome it caused (``STOPPED`` and ``RELEASED`` are stick/slip changes that the
    run goes on after; ``SLOW`` is a check of the statics, after which the block restarts or is ``ARRESTED``)."""

    t: float
    event: int
    outcome: Outcome

    @property
    def name(self) -> str:
        return event_name(self.event) if self.event >= 0 else self.outcome.label


@njit(cache=True, error_model="numpy")
def block_paths(y: np.ndarray, body_cps: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every row's rotation (n, 3, 3), contact points and contact velocities (n, 3, 3 each) from kernel states ``y``
    (n, N_STATE) and the contact points in the body frame about the mass centre ``body_cps`` (3, 3).

    The quaternion (w, x, y, z) is normalised and turned into the rotation matrix (columns g1, g2, g3), the contact
    points are the mass centre plus R times the body-frame point, their velocities the mass centre's plus
    omega x (point - mass centre). One compiled pass over the rows (a workbench evaluation did this with some twenty
    numpy calls); the operations and their order are those of the numpy expressions it replaced, so the bits are
    the same (``tests/triplanar/test_block_paths.py``)."""
    n = y.shape[0]
    rot, cps, vel = np.empty((n, 3, 3)), np.empty((n, 3, 3)), np.empty((n, 3, 3))
    for k in range(n):
        q0, q1, q2, q3 = y[k, K.S_Q], y[k, K.S_Q + 1], y[k, K.S_Q + 2], y[k, K.S_Q + 3]
        norm = math.sqrt(((q0 * q0 + q1 * q1) + q2 * q2) + q3 * q3)
        w, x, yy, z = q0 / norm, q1 / norm, q2 / norm, q3 / norm
        r = rot[k]
        r[0, 0], r[0, 1], r[0, 2] = 1 - 2 * (yy * yy + z * z), 2 * (x * yy - w * z), 2 * (x * z + w * yy)
        r[1, 0], r[1, 1], r[1, 2] = 2 * (x * yy + w * z), 1 - 2 * (x * x + z * z), 2 * (yy * z - w * x)
        r[2, 0], r[2, 1], r[2, 2] = 2 * (x * z - w * yy), 2 * (yy * z + w * x), 1 - 2 * (x * x + yy * yy)
        w0, w1, w2 = y[k, K.S_W], y[k, K.S_W + 1], y[k, K.S_W + 2]
        for c in range(3):
            for i in range(3):   # (the terms in numpy's einsum order: the first and third, then the second)
                turned = (r[i, 0] * body_cps[c, 0] + r[i, 2] * body_cps[c, 2]) + r[i, 1] * body_cps[c, 1]
                cps[k, c, i] = y[k, K.S_R + i] + turned
            a0, a1, a2 = (cps[k, c, 0] - y[k, K.S_R], cps[k, c, 1] - y[k, K.S_R + 1], cps[k, c, 2] - y[k, K.S_R + 2])
            vel[k, c, 0] = y[k, K.S_V] + (w1 * a2 - w2 * a1)
            vel[k, c, 1] = y[k, K.S_V + 1] + (w2 * a0 - w0 * a2)
            vel[k, c, 2] = y[k, K.S_V + 2] + (w0 * a1 - w1 * a0)
    return rot, cps, vel


@dataclass(frozen=True)
class SimulationResult:
    """A simulated test, ``solve_ivp``-style: ``status``, ``message``, ``success`` and the trajectory.

    Rows are the integrator's accepted steps; ``t`` is time since the start of sliding (``t_start_s`` is
    when sliding started after the actuator began to push: 0 unless the force rises). The last row is the
    final state itself (for ``status is Outcome.TRAVEL``, at exactly the travel target). ``status`` is an
    :class:`~triplanar.outcome.Outcome` (printed as its label, ``"travel"``).

    As ``solve_ivp``'s result counts its work: ``events`` lists what happened in order (stick/slip changes,
    checks of the statics, the ending; the first 10,000), ``nfev`` the right-hand-side evaluations, ``n_steps``
    the accepted and ``n_rejected`` the rejected steps, ``n_statics`` the static-equilibrium checks and
    ``n_starts`` the starts from rest (mode searches).
    """

    t: np.ndarray
    y: np.ndarray
    dydt: np.ndarray
    aux: np.ndarray
    status: Outcome
    message: str
    model: Model
    method: str
    t_start_s: float
    travel_target_m: float
    incipient_converged: bool
    incipient_consistency: float
    events: tuple[Event, ...] = ()
    nfev: int = 0
    n_steps: int = 0
    n_rejected: int = 0
    n_statics: int = 0
    n_starts: int = 0

    @property
    def success(self) -> bool:
        """False only when the integration itself failed; every physical ending is a success."""
        return self.status is not Outcome.FAILED

    # -- kinematics ------------------------------------------------------------------------
    @cached_property
    def _kinematics(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(rotation, contact points, contact velocities) of every row, in one compiled pass (:func:`block_paths`)."""
        body = self.model.kernel_params_cached[K.P_C:K.P_C + 9].reshape(3, 3).copy()  # (writable: one compiled version)
        return block_paths(np.ascontiguousarray(self.y), body)

    @property
    def rotation(self) -> np.ndarray:
        """(n, 3, 3) body frame [g1 g2 g3] in world coordinates."""
        return self._kinematics[0]

    @property
    def mass_centre(self) -> np.ndarray:
        return self.y[:, K.S_R:K.S_R + 3]

    @property
    def contact_points(self) -> np.ndarray:
        """(n, 3, 3): sample, CP1..CP3, coordinate x1..x3 (the paper's q1..q9)."""
        return self._kinematics[1]

    @property
    def contact_velocities(self) -> np.ndarray:
        """(n, 3, 3): sample, CP1..CP3, velocity (m/s): the mass centre's velocity plus omega x (CP - mass centre)."""
        return self._kinematics[2]

    @property
    def normal_reactions(self) -> np.ndarray:
        """(n, 3) normal reactions N1..N3 (N), the paper's lambda_1..3."""
        return self.aux[:, K.A_N:K.A_N + 3]

    @property
    def load_point(self) -> np.ndarray:
        """(n, 3) instantaneous load point P_L (world); P_CL for the hydrostatic load."""
        return self.aux[:, K.A_PL:K.A_PL + 3]

    @cached_property
    def load_point_on_face(self) -> np.ndarray:
        """(n, 2) where the load acts on the aft face: (height along g2, lateral along g3) from CP1.

        At rest this is (A, -B); the paper's k2, k3 (eq. 28) are the change from there.
        """
        rel = self.load_point - self.contact_points[:, 0, :]
        return np.stack([np.einsum("ni,ni->n", rel, self.rotation[:, :, 1]),
                         np.einsum("ni,ni->n", rel, self.rotation[:, :, 2])], axis=1)

    @property
    def thrust(self) -> np.ndarray:
        return self.aux[:, K.A_FT]

    @property
    def travel(self) -> np.ndarray:
        """CP1's displacement along e1 since rest (m): the paper's Delta q1."""
        return path_travel(self.contact_points, self.contact_points[0])  # a simulated path: from its first row

    @cached_property
    def rotation_deg(self) -> np.ndarray:
        """Turn of the block about the vertical, degrees, positive counter-clockwise in the paper's overhead
        plots (x1 right, x3 up): positive when the front drifts toward +e3 faster than the rear."""
        g1 = self.rotation[:, :, 0]
        g1_0 = self.rotation[0, :, 0]
        return np.degrees(np.arctan2(g1[:, 2], g1[:, 0]) - np.arctan2(g1_0[2], g1_0[0]))

    # -- energy ----------------------------------------------------------------------------
    @cached_property
    def energy(self) -> dict[str, np.ndarray]:
        """Energy terms (J) since rest. Balance: ``work_load + work_other = kinetic + potential +
        dissipated_contacts.sum(1) + dissipated_tip``; ``residual`` is the difference."""
        m = self.model.specimen.mass_kg
        v = self.y[:, K.S_V:K.S_V + 3]
        omega = self.y[:, K.S_W:K.S_W + 3]
        inertia = self.model.specimen.inertia_kg_m2
        w_body = np.einsum("nji,nj->ni", self.rotation, omega)
        kinetic = 0.5 * m * np.einsum("ni,ni->n", v, v) + 0.5 * np.einsum("ni,ij,nj->n", w_body, inertia, w_body)
        potential = m * self.model.kernel_params_cached[K.P_G] * (self.mass_centre[:, 1] - self.mass_centre[0, 1])
        out = {"work_load": self.y[:, K.S_WLOAD], "work_other": self.y[:, K.S_WOTHER], "kinetic": kinetic,
               "potential": potential, "dissipated_contacts": self.y[:, K.S_DC:K.S_DC + 3],
               "dissipated_tip": self.y[:, K.S_DTIP]}
        out["residual"] = out["work_load"] + out["work_other"] - kinetic - potential \
            - out["dissipated_contacts"].sum(axis=1) - out["dissipated_tip"]
        return out

    # -- dense output --------------------------------------------------------------------------
    @cached_property
    def _rows(self) -> np.ndarray:
        """Rows the interpolants use: all, except that a repeated time keeps only its last row."""
        return distinct_times(self.t)

    @cached_property
    def sol(self) -> CubicHermite:
        """Dense output, like ``solve_ivp(..., dense_output=True).sol``: ``sol(t)`` is the state (kernel
        layout, ``N_STATE``) at time ``t`` (scalar -> (N_STATE,), array (m,) -> (m, N_STATE), rows first),
        by cubic Hermite interpolation of the rows and :attr:`dydt`, the right-hand side the integrator
        evaluated at each row (with the stick/slip modes in force there). Exact at the rows; between them
        accurate to about the integrator's tolerance. The quaternion is interpolated component-wise:
        normalise it before use. Times outside ``[t[0], t[-1]]`` are clamped."""
        k = self._rows
        return CubicHermite(self.t[k], self.y[k], self.dydt[k])

    @cached_property
    def _contact_path(self) -> CubicHermite:
        k = self._rows
        return CubicHermite(self.t[k], self.contact_points[k], self.contact_velocities[k])

    @cached_property
    def _travel_path(self) -> CubicHermite:
        k = self._rows
        return CubicHermite(self.t[k], self.travel[k], self.contact_velocities[k, 0, 0])

    def contact_points_at(self, t: np.ndarray) -> np.ndarray:
        """(m, 3, 3) contact points at times ``t`` (s since sliding began), cubic Hermite in time from the
        rows' positions and velocities (exact derivatives, whatever the stick/slip mode)."""
        return self._contact_path(np.asarray(t, dtype=float))

    def travel_at_time(self, t: np.ndarray) -> np.ndarray:
        """CP1's travel (m) at times ``t`` within the run, cubic Hermite in time."""
        return self._travel_path(np.asarray(t, dtype=float))

    # -- paths by distance -----------------------------------------------------------------
    def time_at_travel(self, travel: np.ndarray) -> np.ndarray:
        """Times at which CP1 has travelled ``travel`` (m): cubic Hermite in time, Newton-refined."""
        travel = np.asarray(travel, dtype=float)
        s = self.travel
        if travel.size and (travel.min() < 0 or travel.max() > s[-1] + 1e-12):
            raise ValueError(f"travel must lie within [0, {s[-1]:.6g}] m, the simulated range")
        start = linear(travel, s, self.t)      # the start of the Newton refinement on the cubic
        t = self._travel_path.inverse(travel, start, 3)
        return t[()] if travel.ndim == 0 else t

    def resample_by_travel(self, travel: np.ndarray) -> np.ndarray:
        """(m, 3, 3) contact-point positions where CP1 has travelled ``travel`` (m)."""
        return self.contact_points_at(self.time_at_travel(travel))

    # -- reporting -------------------------------------------------------------------------
    def summary(self) -> dict[str, object]:
        """The figures a laboratory reads off a test."""
        cps = self.contact_points
        speeds = np.linalg.norm(self.contact_velocities, axis=2)
        return {"status": self.status.label, "message": self.message, "force_N": self.model.loading.force_N,
                "duration_s": float(self.t[-1]), "travel_m": float(self.travel[-1]),
                "peak_speed_m_s": float(speeds.max()),
                "lateral_dilation_m": (cps[-1, :, 2] - cps[0, :, 2]).tolist(),
                "rotation_deg": float(self.rotation_deg[-1]),
                "max_constraint_residual_m": float(np.abs(np.einsum(
                    "ci,nci->nc", self.model.foundation.normals, cps)).max())}

    def to_measured(self, test_id: str) -> MeasuredTest:
        """This trajectory as a measured test (every accepted step a sample, time since sliding began)."""
        return MeasuredTest(test_id=test_id, shear_force_N=self.model.loading.force_N,
                            positions=self.contact_points.copy(), t_s=self.t.copy())

    def write_csv(self, path: str | Path, test_id: str = "model") -> None:
        """Write the trace in the measurement format (``docs/measurement-format.md``)."""
        write_measurements(path, [self.to_measured(test_id)])

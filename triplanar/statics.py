"""Starting and stopping: does friction hold the block, and which way does it start to move?

Coulomb friction at rest is a range, not a value, so neither question is answered by the right-hand
side alone:

* :func:`holds` asks whether *some* static equilibrium exists: normal reactions ``N_i >= 0`` and friction
  forces inside their cones (``|S_i| <= N_i tan(phi_i) + c`` at each contact, ``c`` the cohesion of the
  ``cohesion`` effect, 0 by default; ``|F_EF| <= F_T (e1.g1) tan(phi_EF)`` at the tip) that balance the weight and the load, forces and moments. The cones are
  replaced by inscribed 64-gons, a linear program: "holds" is then certain, and a load that the exact
  circles would hold is at most 0.12 % of the friction force away from being called so. The LP is solved
  in compiled code (:mod:`triplanar.equilibrium`: the cones by their generators, a small simplex; tens of
  microseconds), so the env's compiled code can ask it too; here only the user effects' wrench is added in
  Python. :func:`sliding_threshold` maximises the thrust in the same LP.
* :func:`incipient_directions` finds, for a block that cannot hold, the directions in which the contact
  points and the aft face start to slip: friction must oppose the incipient slip accelerations, a fixed
  point of the right-hand side.
"""

from __future__ import annotations

import numpy as np

from . import equilibrium as E
from . import kernel as K
from . import stepping
from .model import Model


def _external_wrench(model: Model, y: np.ndarray, t: float) -> tuple[np.ndarray, np.ndarray]:
    """The user effects' force at the mass centre and moment about it (world axes), seen by a block at rest."""
    if not model.force_effects:
        return np.zeros(3), np.zeros(3)
    rest = y.copy()
    rest[K.S_V:K.S_V + 6] = 0.0
    return model.user_wrench(t, rest)


def _params(model: Model) -> np.ndarray:
    """The model's kernel parameters, writable: numba compiles a second version of everything it calls for a
    read-only array (``Model.kernel_params_cached`` is one)."""
    return model.kernel_params_cached.copy()


def holds(model: Model, y: np.ndarray, thrust_N: float | None = None, t: float = 0.0) -> bool:
    """True when a static equilibrium with friction inside its cones exists at pose ``y``.

    ``y``'s velocities are ignored (the block is taken at rest); ``thrust_N`` defaults to the command.
    """
    thrust = model.loading.force_N if thrust_N is None else float(thrust_N)
    y = np.ascontiguousarray(y, dtype=np.float64)
    extra_f, extra_m = _external_wrench(model, y, t)
    return bool(E.holds(y, _params(model), thrust, extra_f, extra_m))


def sliding_threshold(model: Model, y: np.ndarray | None = None, upper_N: float | None = None,
                      t: float = 0.0) -> float:
    """The largest thrust (N) that friction can hold at pose ``y`` (default: rest): one LP, maximising F_T.

    The set of thrusts that can be held is an interval (the LP's feasible set is convex), so any larger
    thrust slides. Returns ``inf`` if it still holds at ``upper_N`` (default: 5 x the weight), and ``nan``
    if not even zero thrust can be held (the block slides under its own weight).
    """
    y = model.initial_state() if y is None else np.ascontiguousarray(y, dtype=np.float64)
    upper = upper_N if upper_N is not None else 5.0 * model.specimen.weight_N
    extra_f, extra_m = _external_wrench(model, y, t)
    return float(E.max_thrust(y, _params(model), float(upper), extra_f, extra_m))


def incipient_directions(p: np.ndarray, modes: np.ndarray, y: np.ndarray, t: float = 0.0,
                         max_iter: int = 400) -> tuple[bool, float]:
    """Set ``modes[M_D0:]`` (the stick/slip modes, :data:`triplanar.kernel.MODES`) to the directions in which
    resting sliding sites begin to slip (see :func:`triplanar.stepping.incipient_directions`); returns (converged,
    consistency)."""
    converged, consistency = stepping.incipient_directions(t, y, p, modes, max_iter)
    return bool(converged), float(consistency)


def start_motion(p: np.ndarray, modes: np.ndarray, y: np.ndarray, t: float = 0.0) -> tuple[bool, float]:
    """Choose how a block that cannot hold starts to move, and set its stick/slip ``modes`` for it
    (:func:`triplanar.stepping.start_motion_ws`); returns (accepted, consistency)."""
    ws = stepping.new_workspace()
    K.modes_of(ws)[:] = modes
    accepted, consistency = stepping.start_motion_ws(t, y, p, ws)
    modes[:] = K.modes_of(ws)
    return bool(accepted), float(consistency)

"""The compiled static-equilibrium LP (:mod:`triplanar.equilibrium`): its simplex against scipy's HiGHS on
small LPs, and its holds / max_thrust against the face-form LP that ``triplanar.statics`` solved with HiGHS
before (kept here, below, as the reference)."""

from __future__ import annotations

import ast
import math

import numpy as np
import pytest
from scipy.optimize import linprog

from triplanar import Effect, Parameter, make_effect, paper_model
from triplanar import equilibrium as E
from triplanar import kernel as K
from triplanar import statics

ZERO = np.zeros(3)


# -- the reference: the face-form LP, solved by HiGHS (statics' implementation before the compiled one) ------

POLYGON_SIDES = 64
_ANGLES = 2 * math.pi * (np.arange(POLYGON_SIDES) + 0.5) / POLYGON_SIDES
_INSET = math.cos(math.pi / POLYGON_SIDES)


def _reference_lp(y: np.ndarray, p: np.ndarray, extra_f: np.ndarray, extra_m: np.ndarray) -> dict:
    """The static-equilibrium LP at pose ``y`` with the thrust F_T as its last variable.

    Variables: N1..N3, two tangential friction components per contact, two at the tip (if it rubs), F_T.
    Equalities: force and moment balance about the mass centre. Inequalities: inscribed 64-gons of the
    friction cones (faces at (k + 1/2) 2 pi/64, inset cos(pi/64)); the tip's bound F_T (e1.g1) tan(phi_EF).
    """
    rot = np.empty((3, 3))
    K.quat_to_matrix(y[K.S_Q:K.S_Q + 4], rot)
    r = y[K.S_R:K.S_R + 3]
    arm = np.empty(3)
    K.load_arm(y, p, rot, arm)
    load_point = r + arm
    g1 = rot[:, 0]
    force_dir = np.array([1.0, 0.0, 0.0]) if p[K.P_CASE] == 0.0 else g1
    cps = np.empty((3, 3))
    K.contact_points(y, p, cps)
    normals = p[K.P_N:K.P_N + 9].reshape(3, 3)
    tan_phi = p[K.P_TANPHI:K.P_TANPHI + 3]
    tangents = []
    for i in range(3):
        t1, t2 = np.empty(3), np.empty(3)
        K.tangent_basis(p, i, t1, t2)
        tangents.append((t1, t2))
    directions = [*normals, *(t_ for pair in tangents for t_ in pair)]
    points = [*cps, *np.repeat(cps, 2, axis=0)]
    tip_coefficient = p[K.P_TANEF] * g1[0]
    rubs = tip_coefficient > 0
    if rubs:
        directions += [rot[:, 1], rot[:, 2]]
        points += [load_point, load_point]
    directions += [force_dir]
    points += [load_point]
    directions, points = np.array(directions), np.array(points)
    a_eq = np.vstack([directions.T, np.cross(points - r, directions).T])
    weight = np.array([0.0, p[K.P_MASS] * p[K.P_G], 0.0])
    b_eq = -np.concatenate([extra_f - weight, extra_m])
    n_var = len(directions)
    cos_a, sin_a = np.cos(_ANGLES), np.sin(_ANGLES)
    a_ub = np.zeros(((4 if rubs else 3) * POLYGON_SIDES, n_var))
    for i in range(3):
        block = slice(i * POLYGON_SIDES, (i + 1) * POLYGON_SIDES)
        a_ub[block, 3 + 2 * i], a_ub[block, 4 + 2 * i] = cos_a, sin_a
        a_ub[block, i] = -tan_phi[i] * _INSET
    if rubs:
        a_ub[3 * POLYGON_SIDES:, 9], a_ub[3 * POLYGON_SIDES:, 10] = cos_a, sin_a
        a_ub[3 * POLYGON_SIDES:, -1] = -tip_coefficient * _INSET
    bounds = [(0, None)] * 3 + [(None, None)] * (n_var - 4)
    return {"A_eq": a_eq, "b_eq": b_eq, "A_ub": a_ub, "b_ub": np.zeros(len(a_ub)), "bounds": bounds,
            "n_var": n_var}


def reference_holds(y: np.ndarray, p: np.ndarray, thrust: float, extra_f: np.ndarray = ZERO,
                    extra_m: np.ndarray = ZERO) -> bool:
    lp = _reference_lp(y, p, extra_f, extra_m)
    res = linprog(np.zeros(lp["n_var"]), A_ub=lp["A_ub"], b_ub=lp["b_ub"], A_eq=lp["A_eq"], b_eq=lp["b_eq"],
                  bounds=lp["bounds"] + [(thrust, thrust)], method="highs")
    return bool(res.status == 0)


def reference_threshold(y: np.ndarray, p: np.ndarray, upper: float, extra_f: np.ndarray = ZERO,
                        extra_m: np.ndarray = ZERO) -> float:
    lp = _reference_lp(y, p, extra_f, extra_m)
    cost = np.zeros(lp["n_var"])
    cost[-1] = -1.0
    res = linprog(cost, A_ub=lp["A_ub"], b_ub=lp["b_ub"], A_eq=lp["A_eq"], b_eq=lp["b_eq"],
                  bounds=lp["bounds"] + [(0.0, upper)], method="highs")
    if res.status != 0:
        return math.nan
    threshold = float(res.x[-1])
    return math.inf if threshold >= upper * (1 - 1e-12) else threshold


# -- the simplex on small LPs ---------------------------------------------------------------------

def _solve(a, b, c, **kw):
    a, b, c = (np.ascontiguousarray(v, dtype=float) for v in (a, b, c))
    x = np.empty(a.shape[1])
    status, objective = E.simplex(a, b, c, x, kw.get("max_iter", E.MAX_ITER), kw.get("bland_after", E.BLAND_AFTER))
    return status, objective, x


def _with_slacks(a_ub, b_ub, c):
    """``a_ub x <= b_ub`` as equalities with one slack per row."""
    a_ub = np.asarray(a_ub, float)
    m, n = a_ub.shape
    return np.hstack([a_ub, np.eye(m)]), np.asarray(b_ub, float), np.concatenate([np.asarray(c, float), np.zeros(m)])


def _assert_solution(a, b, c, status, objective, x):
    a, b, c = (np.asarray(v, float) for v in (a, b, c))
    assert status == E.OPTIMAL
    assert (x >= 0).all()
    assert np.abs(a @ x - b).max() <= 1e-9 * max(1.0, np.abs(b).max())
    assert objective == pytest.approx(c @ x, rel=1e-12, abs=1e-12)


def test_simplex_textbook_optimum() -> None:
    # Wyndor glass (Hillier & Lieberman): max 3 x1 + 5 x2, x1 <= 4, 2 x2 <= 12, 3 x1 + 2 x2 <= 18 -> 36 at (2, 6)
    a, b, c = _with_slacks([[1, 0], [0, 2], [3, 2]], [4, 12, 18], [-3, -5])
    status, objective, x = _solve(a, b, c)
    _assert_solution(a, b, c, status, objective, x)
    assert objective == pytest.approx(-36.0, abs=1e-12)
    assert x[:2] == pytest.approx([2.0, 6.0], abs=1e-12)


def test_simplex_negative_right_hand_sides_and_equalities() -> None:
    # min x1 + 2 x2 + 3 x3, x1 + x2 + x3 = 6, -x1 + x2 = -2 (a row to flip): x = (4, 2, 0), cost 8
    a, b, c = [[1, 1, 1], [-1, 1, 0]], [6, -2], [1, 2, 3]
    status, objective, x = _solve(a, b, c)
    res = linprog(c, A_eq=a, b_eq=b, method="highs")
    _assert_solution(a, b, c, status, objective, x)
    assert objective == pytest.approx(res.fun, abs=1e-12) and objective == pytest.approx(8.0, abs=1e-12)


def test_simplex_infeasible() -> None:
    status, objective, _ = _solve([[1, 1], [1, 1]], [1, 2], [1, 1])
    assert status == E.INFEASIBLE and math.isnan(objective)
    status, _, _ = _solve([[1, 1]], [-1], [0, 0])  # x >= 0 cannot sum to -1
    assert status == E.INFEASIBLE
    status, _, _ = _solve([[0, 0], [1, 0]], [1, 1], [0, 0])  # an empty row with b != 0
    assert status == E.INFEASIBLE


def test_simplex_unbounded() -> None:
    status, objective, _ = _solve([[1, -1]], [1], [-1, 0])
    assert status == E.UNBOUNDED and objective == -math.inf
    assert _solve([[1, -1]], [1], [1, 0])[0] == E.OPTIMAL  # the same set, bounded direction


def test_simplex_redundant_rows_are_dropped() -> None:
    a = [[1, 1, 1], [2, 2, 2], [1, -1, 0]]
    b, c = [3, 6, 1], [1, 2, 0.5]
    status, objective, x = _solve(a, b, c)
    _assert_solution(a, b, c, status, objective, x)
    assert objective == pytest.approx(linprog(c, A_eq=a, b_eq=b, method="highs").fun, abs=1e-12)


@pytest.mark.parametrize("bland_after", [0, 1, E.BLAND_AFTER, 10**9])
def test_simplex_degenerate_beale_example(bland_after: int) -> None:
    """Beale's example (degenerate at the origin; Dantzig's rule cycles on it from the slack basis): every
    pivot rule here (always Bland, Bland after 1 or 20 degenerate pivots, Dantzig only) reaches -5/4."""
    a_ub = [[0.25, -8, -1, 9], [0.5, -12, -0.5, 3], [0, 0, 1, 0]]
    a, b, c = _with_slacks(a_ub, [0, 0, 1], [-0.75, 20, -0.5, 6])
    status, objective, x = _solve(a, b, c, bland_after=bland_after)
    _assert_solution(a, b, c, status, objective, x)
    assert objective == pytest.approx(linprog(c, A_eq=a, b_eq=b, method="highs").fun, abs=1e-12)
    assert objective == pytest.approx(-1.25, abs=1e-12)


@pytest.mark.parametrize("n", [3, 5, 7])
def test_simplex_klee_minty(n: int) -> None:
    """Klee-Minty cube: Dantzig's rule visits every vertex from the origin; the optimum is 5^n."""
    a_ub = np.zeros((n, n))
    for i in range(n):
        a_ub[i, :i] = 2.0 ** (np.arange(i, 0, -1) + 1)
        a_ub[i, i] = 1.0
    b_ub = 5.0 ** np.arange(1, n + 1)
    c = -(2.0 ** np.arange(n - 1, -1, -1))
    a, b, cc = _with_slacks(a_ub, b_ub, c)
    status, objective, x = _solve(a, b, cc)
    _assert_solution(a, b, cc, status, objective, x)
    assert objective == pytest.approx(-(5.0 ** n), rel=1e-12)


def test_simplex_iteration_limit_is_its_own_status() -> None:
    a, b, c = _with_slacks([[1, 0], [0, 2], [3, 2]], [4, 12, 18], [-3, -5])
    status, objective, _ = _solve(a, b, c, max_iter=1)
    assert status == E.ITERATION_LIMIT and math.isnan(objective)
    assert _solve(a, b, c, max_iter=50)[0] == E.OPTIMAL


def _random_lps(seed: int, count: int):
    rng = np.random.default_rng(seed)
    for k in range(count):
        m = int(rng.integers(1, 7))
        n = int(rng.integers(m + 1, 14))
        kind = k % 4
        if kind == 0:  # generic, feasible by construction; bounded or not
            a = rng.normal(size=(m, n))
            b = a @ rng.uniform(0, 2, n)
            c = rng.normal(size=n)
        elif kind == 1:  # feasible and bounded: the cost is non-negative on x >= 0 plus a dual-feasible part
            a = rng.normal(size=(m, n))
            b = a @ rng.uniform(0, 2, n)
            c = rng.uniform(0.1, 2, n) + a.T @ rng.normal(size=m) * 0.3
        elif kind == 2:  # random right-hand side: often infeasible
            a = rng.normal(size=(m, n))
            b = rng.normal(size=m) * 3
            c = rng.normal(size=n)
        else:  # small integers and a sparse integer point: degenerate vertices, ties in the ratio test
            a = rng.integers(-3, 4, size=(m, n)).astype(float)
            x0 = rng.integers(0, 3, size=n) * (rng.random(n) < 0.3)
            b = a @ x0
            c = rng.integers(-2, 4, size=n).astype(float)
        yield a, b, c


_SCIPY_STATUS = {0: E.OPTIMAL, 2: E.INFEASIBLE, 3: E.UNBOUNDED}


@pytest.mark.parametrize("seed", [1, 2])
def test_simplex_agrees_with_highs_on_random_lps(seed: int) -> None:
    seen = set()
    for a, b, c in _random_lps(seed, 200):
        res = linprog(c, A_eq=a, b_eq=b, method="highs")
        assert res.status in _SCIPY_STATUS, res.message
        expected = _SCIPY_STATUS[res.status]
        if expected != E.OPTIMAL:  # HiGHS may say "infeasible" for "infeasible or unbounded": decide feasibility
            feasible = linprog(np.zeros_like(c), A_eq=a, b_eq=b, method="highs").status == 0
            expected = E.UNBOUNDED if feasible else E.INFEASIBLE
        for bland_after in (E.BLAND_AFTER, 0):
            status, objective, x = _solve(a, b, c, bland_after=bland_after)
            assert status == expected, (a, b, c, bland_after)
            if status == E.OPTIMAL:
                _assert_solution(a, b, c, status, objective, x)
                assert objective == pytest.approx(res.fun, rel=1e-8, abs=1e-8)
        seen.add(expected)
    assert seen == {E.OPTIMAL, E.INFEASIBLE, E.UNBOUNDED}  # the sample exercises all three answers


# -- the static-equilibrium LP against the reference ------------------------------------------------

def _params(model) -> np.ndarray:
    """The model's kernel parameters, writable as the library passes them (:mod:`triplanar.statics`): numba compiles
    a version per array flag, and the read-only ``kernel_params_cached`` would compile the LP once more (15 s of CPU
    in each test process)."""
    return model.kernel_params_cached.copy()


def _upper(p: np.ndarray) -> float:
    return 5.0 * p[K.P_MASS] * p[K.P_G]


def _compare(y: np.ndarray, p: np.ndarray, extra_f: np.ndarray = ZERO, extra_m: np.ndarray = ZERO,
             loads=(5.0, 15.0, 20.0, 25.0, 30.0, 45.0, 60.0)) -> float:
    """Assert that threshold and holds agree with the reference; returns the threshold."""
    y = np.ascontiguousarray(y)
    upper = _upper(p)
    expected = reference_threshold(y, p, upper, extra_f, extra_m)
    got = E.max_thrust(y, p, upper, extra_f, extra_m)
    if math.isfinite(expected):
        assert got == pytest.approx(expected, rel=1e-6)
    else:
        assert math.isnan(got) == math.isnan(expected) and math.isinf(got) == math.isinf(expected)
    for load in (*loads, *(expected * np.array([0.5, 0.99, 1.01, 1.5]) if math.isfinite(expected) else ())):
        if math.isfinite(expected) and abs(load - expected) <= 1e-6 * expected:
            continue
        assert E.holds(y, p, load, extra_f, extra_m) == reference_holds(y, p, load, extra_f, extra_m), load
    if math.isfinite(got) and got > 0:  # the compiled answers are consistent with each other at the threshold
        assert E.holds(y, p, got * (1 - 1e-6), extra_f, extra_m)
        assert not E.holds(y, p, got * (1 + 1e-6), extra_f, extra_m)
    return got


@pytest.mark.parametrize("case, threshold", [("A", 25.58), ("B", 21.88), ("C", 21.88)])
def test_paper_thresholds_at_rest(case: str, threshold: float) -> None:
    model = paper_model(case, 30.0)
    got = _compare(model.initial_state(), _params(model))
    assert got == pytest.approx(threshold, abs=0.005)
    assert statics.sliding_threshold(model) == got


@pytest.mark.parametrize("case", ["A", "B", "C"])
def test_holds_matches_the_reference_over_loads(case: str) -> None:
    for load in np.linspace(5.0, 60.0, 23):
        model = paper_model(case, load)
        y = model.initial_state()
        expected = reference_holds(y, _params(model), load)
        assert statics.holds(model, y) == expected
        assert E.holds(y, _params(model), load, ZERO, ZERO) == expected


def _rotated(q: np.ndarray, axis: np.ndarray, angle: float) -> np.ndarray:
    """``q`` turned by ``angle`` about the world ``axis`` (Hamilton product, w first)."""
    axis = axis / np.linalg.norm(axis)
    w0, v0 = math.cos(angle / 2), math.sin(angle / 2) * axis
    w1, v1 = q[0], q[1:]
    out = np.concatenate([[w0 * w1 - v0 @ v1], w0 * v1 + w1 * v0 + np.cross(v0, v1)])
    return out / np.linalg.norm(out)


@pytest.mark.parametrize("case", ["A", "B", "C"])
def test_perturbed_poses(case: str) -> None:
    rng = np.random.default_rng({"A": 11, "B": 12, "C": 13}[case])
    model = paper_model(case, 30.0)
    p = _params(model)
    thresholds = []
    for _ in range(12):
        y = model.initial_state()
        y[K.S_R:K.S_R + 3] += rng.uniform(-0.003, 0.003, 3)
        y[K.S_Q:K.S_Q + 4] = _rotated(y[K.S_Q:K.S_Q + 4], rng.normal(size=3), math.radians(rng.uniform(0, 4)))
        y[K.S_U] = rng.uniform(-0.02, 0.02)
        y[K.S_V:K.S_V + 6] = rng.normal(size=6)  # ignored: the block is taken at rest
        thresholds.append(_compare(y, p))
    assert len({round(t, 6) for t in thresholds if math.isfinite(t)}) > 6  # the poses do change the answer


@pytest.mark.parametrize("phi_ef", [0.0, 2.0, 8.0, 20.0, 40.0])
def test_tip_friction_angles(phi_ef: float) -> None:
    model = paper_model("B", 30.0, effects=[make_effect(f"end_friction:phi_deg={phi_ef}")])
    assert model.kernel_params_cached[K.P_TANEF] == pytest.approx(math.tan(math.radians(phi_ef)))
    _compare(model.initial_state(), _params(model))


def test_contact_friction_and_plane_tilts() -> None:
    rng = np.random.default_rng(5)
    for k in range(10):
        phis = rng.uniform(5.0, 40.0, 3)
        spec = "contact_friction:" + ",".join(f"phi{i + 1}_deg={phi:.3f}" for i, phi in enumerate(phis))
        effects = [make_effect(spec)]
        if k % 2:
            dips = rng.uniform(-3, 3, 2)
            effects.append(make_effect(f"plane_tilt:dip2_deg={dips[0]:.3f},dip3_deg={dips[1]:.3f}"))
        model = paper_model("ABC"[k % 3], 30.0, effects=effects)
        _compare(model.initial_state(), _params(model))


def test_edited_parameter_copies() -> None:
    """Directly edited packed parameters, including a block that slides under its own weight (nan)."""
    model = paper_model("A", 30.0)
    y = model.initial_state()
    p = model.kernel_params_cached.copy()
    p[K.P_TANPHI:K.P_TANPHI + 3] = [0.3, 0.5, 0.7]
    p[K.P_TANEF] = 0.25
    _compare(y, p)
    p[K.P_TANPHI:K.P_TANPHI + 3] = 0.0
    p[K.P_TANEF] = 0.0
    assert math.isnan(_compare(y, p))
    assert not E.holds(y, p, 0.0, ZERO, ZERO)


def test_upper_bound_semantics() -> None:
    model = paper_model("A", 30.0)
    y, p = model.initial_state(), _params(model)
    assert E.max_thrust(y, p, 10.0, ZERO, ZERO) == math.inf == reference_threshold(y, p, 10.0)
    assert E.max_thrust(y, p, math.inf, ZERO, ZERO) == pytest.approx(25.578, abs=1e-3)  # no bound row
    assert math.isnan(E.max_thrust(y, p, -1.0, ZERO, ZERO))
    assert not E.holds(y, p, -1.0, ZERO, ZERO)  # a pull is never held


class _ConstantWrench(Effect):
    """Test-only: a constant force at the mass centre and moment about it."""
    name = "constant_wrench_for_test"
    parameters = {key: Parameter(0.0, -50.0, 50.0, unit, "") for key, unit in
                  (("fx", "N"), ("fy", "N"), ("fz", "N"), ("mx", "N m"), ("my", "N m"), ("mz", "N m"))}

    def wrench(self, t, state):
        return (np.array([self["fx"], self["fy"], self["fz"]]), np.array([self["mx"], self["my"], self["mz"]]))


@pytest.mark.parametrize("case, values", [
    ("A", dict(fx=5.0)), ("A", dict(fx=-8.0, mz=0.5)), ("B", dict(fz=4.0, my=-0.3)),
    ("C", dict(fy=-20.0)), ("B", dict(fy=15.0, mx=0.4)), ("A", dict(fz=-6.0, fx=3.0, my=0.6))])
def test_external_force_effect(case: str, values: dict) -> None:
    model = paper_model(case, 30.0, effects=[_ConstantWrench(**values)])
    y = model.initial_state()
    f = np.array([values.get(key, 0.0) for key in ("fx", "fy", "fz")])  # the effect's constant wrench
    m = np.array([values.get(key, 0.0) for key in ("mx", "my", "mz")])
    assert np.abs(f).max() + np.abs(m).max() > 0
    threshold = _compare(y, _params(model), f, m)
    base = paper_model(case, 30.0)
    assert threshold != pytest.approx(statics.sliding_threshold(base), rel=1e-6)  # the wrench matters
    assert statics.sliding_threshold(model) == threshold
    for load in (10.0, 20.0, 30.0):
        if math.isfinite(threshold) and abs(load - threshold) <= 1e-6 * threshold:
            continue
        assert statics.holds(model, y, load) == reference_holds(y, _params(model), load, f, m)


def test_statics_and_equilibrium_do_not_import_scipy() -> None:
    for module in (statics, E):
        tree = ast.parse(open(module.__file__).read())
        names = [alias.name for node in ast.walk(tree) if isinstance(node, ast.Import) for alias in node.names]
        names += [node.module or "" for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)]
        assert names and not any(name.split(".")[0] == "scipy" for name in names), module.__name__

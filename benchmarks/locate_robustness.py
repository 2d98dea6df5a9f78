"""What the naming order of :func:`triplanar.workbench.locate.locate` costs on causes the calibration does not hold:
forces at a contact, and a vertical one, made by the project's own generator with plugin effects (the calibration's
outside causes all act at the mass centre in the horizontal plane, where the order favours them). ::

    PYTHONPATH=. python benchmarks/locate_robustness.py [--seeds 1-4]

Per dataset (4 loads x 2 repeats, 0.3 mm noise): the term named, and the one with the least held-out error (what the
located force was before the order, and what the outside-force rule compares; none when only weak); then the rate of
each with the point (or one with the same moment about the vertical) and the direction right, Wilson 95 %.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from triplanar.effects import Effect, Parameter


class DragAtCP3(Effect):
    """A viscous film under CP3: ``-c |v_CP3|`` along -e1 at CP3."""

    name = "robust_drag_cp3"
    parameters = {"c": Parameter(0.0, 0.0, 50.0, "N s/m", "drag per unit slip speed of CP3")}

    def wrench(self, t, s):
        f = np.array([-self["c"] * float(np.linalg.norm(s.contact_velocities[2])), 0.0, 0.0])
        return f, s.moment_of(f, s.contact_points[2])


class PullAtCP2(Effect):
    """A constant sideways pull at CP2."""

    name = "robust_pull_cp2"
    parameters = {"f": Parameter(0.0, -10.0, 10.0, "N", "force along e3")}

    def wrench(self, t, s):
        f = np.array([0.0, 0.0, self["f"]])
        return f, s.moment_of(f, s.contact_points[1])


class PadAtCP1(Effect):
    """A constant resistance at CP1 (a pad rubbing there)."""

    name = "robust_pad_cp1"
    parameters = {"f": Parameter(0.0, 0.0, 10.0, "N", "force along -e1")}

    def wrench(self, t, s):
        f = np.array([-self["f"], 0.0, 0.0])
        return f, s.moment_of(f, s.contact_points[0])


class Weight(Effect):
    """A constant downward force at the mass centre (a hose hanging from the block)."""

    name = "robust_weight"
    parameters = {"f": Parameter(0.0, 0.0, 20.0, "N", "force along -e2")}

    def wrench(self, t, s):
        return np.array([0.0, -self["f"], 0.0]), np.zeros(3)


class TravelAtCP1(Effect):
    """A resistance at CP1 growing with the mass centre's travel since rest (``x0``: its x1 at rest)."""

    name = "robust_travel_cp1"
    parameters = {"b": Parameter(0.0, 0.0, 500.0, "N/m", "resistance per metre slid"),
                  "x0": Parameter(0.0, -1.0, 1.0, "m", "the mass centre's x1 at rest", free=False)}

    def wrench(self, t, s):
        f = np.array([-self["b"] * max(0.0, float(s.position[0]) - self["x0"]), 0.0, 0.0])
        return f, s.moment_of(f, s.contact_points[0])


def kinds(x0_m: float) -> dict:
    """Each kind: (a plugin drawn from a generator, the point, the directions counted right, what it follows)."""
    sign = {True: "+e3", False: "-e3"}
    return {"drag at CP3": (lambda r: DragAtCP3(c=r.uniform(6, 12)), "CP3", lambda e: ("-e1",), "slip speed"),
            "pull at CP2": (lambda r: PullAtCP2(f=r.choice([-1, 1]) * r.uniform(1.0, 2.0)), "CP2",
                            lambda e: (sign[e["f"] > 0],), "constant"),
            "pad at CP1": (lambda r: PadAtCP1(f=r.uniform(0.5, 1.5)), "CP1", lambda e: ("-e1",), "constant"),
            "weight at the mass centre": (lambda r: Weight(f=r.uniform(3.0, 8.0)), "mass centre", lambda e: ("-e2",),
                                          "constant"),
            "travel at CP1": (lambda r: TravelAtCP1(b=r.uniform(60, 120), x0=x0_m), "CP1", lambda e: ("-e1",),
                              "travel")}


def right(term, point: str, directions: tuple[str, ...]) -> bool:
    return term is not None and (term.point == point or point in term.same_moment) and term.direction in directions


def main() -> None:
    from benchmarks.locate_rates import wilson
    from triplanar.labdata import generate_lab_data
    from triplanar.workbench import ModelSpec
    from triplanar.workbench.locate import locate
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", default="1-4", help="LOW-HIGH")
    args = parser.parse_args()
    lo, _, hi = args.seeds.partition("-")
    x0 = float(ModelSpec().build(40.0).initial_state()[0])
    named_right = compared_right = n = 0
    for seed in range(int(lo), int(hi or lo) + 1):
        for i, (kind, (make, point, directions, _)) in enumerate(kinds(x0).items()):
            effect = make(np.random.default_rng(seed * 100 + i))
            tests, _ = generate_lab_data(loads=(32.5, 40.0, 47.5, 55.6), repeats=2, seed=seed, effects=[effect],
                                         noise_m=3e-4)
            found = locate(tests, ModelSpec(), folds=[[32.5, 47.5], [40.0, 55.6]], executor="serial")
            ok = right(found.term, point, directions(effect))
            ok_before = right(found.compared, point, directions(effect))
            named_right, compared_right, n = named_right + ok, compared_right + ok_before, n + 1
            print(f"s{seed} {kind:26s} named {found.term.label if found.term else 'none':58s} {'Y' if ok else 'n'}"
                  f"{' (weak)' if found.weak else ''}; least held-out error "
                  f"{found.compared.label if found.compared else 'none':58s} {'Y' if ok_before else 'n'}", flush=True)
    for what, k in (("named", named_right), ("least held-out error (weak: none)", compared_right)):
        a, b = wilson(k, n)
        print(f"{what}: point and direction right {k}/{n} [{a:.2f}, {b:.2f}]")


if __name__ == "__main__":
    main()

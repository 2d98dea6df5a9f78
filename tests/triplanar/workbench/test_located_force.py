"""A cause outside the library located: a user's plugin force at a known contact, along a known direction, is found
there by :func:`triplanar.workbench.locate.locate`; diagnose attaches it as evidence when its verdict is
``outside_library`` (the verdict the same without it) or ``high`` naming more than one parameter
(``rules._outside_force`` reads it then)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from triplanar import EFFECTS, plain_data
from triplanar.effects import Effect, Parameter
from triplanar.labdata import generate_lab_data
from triplanar.workbench import ModelSpec
from triplanar.workbench.locate import LocatedResult, locate


class DragAtCP3(Effect):
    """The user's plugin: a viscous film under CP3, ``-c |v_CP3|`` along -e1 at CP3 (docs/adding-an-effect.md)."""

    name = "user_drag_at_cp3"
    parameters = {"c_N_s_m": Parameter(0.0, 0.0, 50.0, "N s/m", "drag per unit slip speed of CP3")}

    def wrench(self, t, state):
        force = np.array([-self["c_N_s_m"] * float(np.linalg.norm(state.contact_velocities[2])), 0.0, 0.0])
        return force, state.moment_of(force, state.contact_points[2])


class SidePull(Effect):
    """A constant sideways pull at the mass centre (a cable of the instrumentation)."""

    name = "user_side_pull"
    parameters = {"force_N": Parameter(0.0, -10.0, 10.0, "N", "force along e3")}

    def wrench(self, t, state):
        return np.array([0.0, 0.0, self["force_N"]]), np.zeros(3)


@pytest.fixture
def plugins():
    before = dict(EFFECTS)
    EFFECTS.update({DragAtCP3.name: DragAtCP3, SidePull.name: SidePull})
    yield
    EFFECTS.clear()
    EFFECTS.update(before)


LOADS = (32.5, 40.0, 47.5, 55.6)


@pytest.mark.slow      # a Python-callback effect in every simulation: a few CPU s
def test_a_drag_at_cp3_is_located_at_cp3_along_minus_e1_following_slip_speed(plugins) -> None:
    tests, _ = generate_lab_data(loads=LOADS, repeats=2, seed=8, effects=[DragAtCP3(c_N_s_m=8.0)], noise_m=3e-4)
    found = locate(tests, ModelSpec(), folds=[[32.5, 47.5], [40.0, 55.6]], executor="serial")
    term = found.term
    assert term is not None, found.sentence
    assert (term.point, term.direction, term.follows) == ("CP3", "-e1", "slip speed"), found.sentence
    assert term.ci95[0] <= 8.0 <= term.ci95[1], term
    assert found.share_removed > 0.8 and found.error_after_mm < found.error_mm
    assert "at the CP3 along -e1 that grows with slip speed: like a viscous drag" in found.sentence
    # kept results stay plain data
    assert isinstance(found.as_json()["term"]["ci95"], list)


@pytest.mark.slow      # a diagnosis and a location: about 5 CPU s
def test_diagnose_locates_an_outside_cause_beside_an_unchanged_verdict(plugins, tmp_path) -> None:
    from triplanar.workbench import Diagnoser, rules
    from triplanar.workbench.results import DiagnosisResult
    tests, _ = generate_lab_data(loads=LOADS, repeats=2, seed=11, effects=[SidePull(force_N=1.5)], noise_m=3e-4)
    del EFFECTS[SidePull.name]          # outside the library now: neither a candidate nor an alternative
    diag = Diagnoser(["end_friction"], folds=2, progress=False, model_form=False, audit=False, combine=False,
                     executor="serial").fit(tests)
    assert diag.verdict_ == "outside_library", diag.reason_
    field = diag.report_["located"]
    assert field["term"]["point"] == "mass centre" and field["term"]["direction"] == "+e3", field["sentence"]
    assert "located outside the library: an extra force at the mass centre along +e3" in \
        DiagnosisResult.of(diag).report()
    # evidence only: the verdict's rules make the same verdict without it
    assert rules.decide(replace(diag.evidence_, located=None)) == diag.decision_
    # and a kept Evidence holding it reads back
    plain_data.save(tmp_path / "ev.npz", diag.evidence_)
    assert isinstance(plain_data.load(tmp_path / "ev.npz").located, LocatedResult)


@pytest.mark.slow      # a diagnosis: about 3 CPU s
def test_nothing_is_located_when_a_library_effect_explains() -> None:
    from triplanar import make_effect
    from triplanar.workbench import Diagnoser
    tests, _ = generate_lab_data(loads=LOADS, repeats=2, seed=12, effects=[make_effect("end_friction:phi_deg=8")])
    diag = Diagnoser(["end_friction"], folds=2, progress=False, model_form=False, audit=False, combine=False,
                     executor="serial").fit(tests)
    assert diag.verdict_ == "library_effect"
    # one parameter named: no force is simpler, so nothing is located (the outside-force rule reads it only for a
    # high verdict naming more), and the report's field stays empty
    assert diag.evidence_.located is None and diag.report_["located"] is None


def test_locate_refuses_no_tests() -> None:
    with pytest.raises(ValueError, match="at least one measured test"):
        locate([])


def test_the_probes_lean_callback_is_its_wrench() -> None:
    """The probes' callback reads the kernel state directly; it gives what the effect's ``wrench`` gives through the
    general path (the block's kinematics decoded into a BlockState)."""
    from triplanar.kernel import S_V, S_W
    from triplanar.workbench.locate import PROFILES, _Probe
    model = ModelSpec().build(40.0)
    y = model.initial_state()
    y[S_V:S_V + 3] = (0.3, 0.01, -0.02)
    y[S_W:S_W + 3] = (0.02, 0.5, 0.1)
    for profile in PROFILES:
        probe = _Probe(profile, (0.5, 0.1, -0.3), (0.01, 0.02, 0.0), (0.1, -0.02, 0.1), -0.05, 7.0, 0.3)
        general = model.with_effects([probe]).user_wrench(0.05, y)
        lean = probe.wrench_at(0.05, y)
        for a, b in zip(general, lean):
            np.testing.assert_allclose(b, a, rtol=1e-12, atol=1e-15, err_msg=profile)
        assert np.abs(general[1]).max() > 0


def test_a_vertical_force_is_likened_by_what_it_follows() -> None:
    """A vertical force that grows with slip speed acts on the motion through the contacts' friction: the sentence says
    so, not "a lift or an extra weight" (a drag was located as -e2 following slip speed, its -e1 form a look-alike)."""
    from triplanar.workbench.locate import LocatedTerm, _likeness

    def term(direction: str, follows: str) -> LocatedTerm:
        return LocatedTerm("mass centre", direction, follows, 1.0, (0.5, 1.5), "N", 0.5, 1.0)
    assert "its friction then resists like a drag" in _likeness(term("-e2", "slip speed"))
    assert "lift growing with speed" in _likeness(term("+e2", "slip speed squared"))
    assert _likeness(term("-e2", "constant")) == "like an extra weight"
    assert _likeness(term("+e2", "travel")) == "like a lift"


def _group(*specs: tuple[str, str, str]) -> list[tuple]:
    """Look-alikes as :func:`locate` ranks them (least held-out error first), by (point, direction, follows)."""
    from triplanar.workbench.locate import LocatedTerm
    return [(LocatedTerm(p, d, f, 1.0, (0.5, 1.5), "N", 0.5, 1.0 + 0.01 * i), np.ones(4)) for i, (p, d, f)
            in enumerate(specs)]


def _named(group: list[tuple]) -> tuple[str, str, str]:
    from triplanar.workbench.locate import _named as named
    term = named(group)
    return term.point, term.direction, term.follows


def test_the_named_look_alike_is_horizontal_through_the_mass_centre_and_constant_before_load() -> None:
    """Among terms the held-out loads cannot tell apart (locate._named): a drag read as a vertical force in proportion
    to the load is named as the drag; a pull at the mass centre as constant rather than in proportion to the load;
    a force through the mass centre before the same force at a contact."""
    drag = _group(("mass centre", "-e2", "load"), ("mass centre", "-e1", "slip speed"))
    assert _named(drag) == ("mass centre", "-e1", "slip speed")
    pull = _group(("mass centre", "-e3", "load"), ("CP2", "-e3", "constant"), ("mass centre", "-e3", "constant"))
    assert _named(pull) == ("mass centre", "-e3", "constant")
    # in proportion to the load stays named when no constant force at its point and direction is a look-alike
    assert _named(_group(("mass centre", "-e1", "load"), ("mass centre", "-e1", "travel"))) == \
        ("mass centre", "-e1", "load")
    # a vertical force alone is named: the order chooses among look-alikes, it adds none
    assert _named(_group(("CP1", "-e2", "constant"))) == ("CP1", "-e2", "constant")


def test_the_rule_compares_the_least_held_out_error_and_never_a_weak_term() -> None:
    from triplanar.workbench.locate import LocatedTerm
    named = LocatedTerm("mass centre", "-e3", "constant", 1.0, (0.8, 1.2), "N", 0.5, 1.1)
    least = LocatedTerm("mass centre", "-e3", "load", 0.02, (0.01, 0.03), "N/N", 0.5, 1.0)
    found = LocatedResult(named, (least.label,), 2.0, 1.0, 0.7, 90, 400, 8, "", {"t0": 1.0}, False, least)
    assert found.compared is least
    assert LocatedResult(named, (), 2.0, 1.0, 0.7, 90, 400, 8, "").compared is named
    assert LocatedResult(named, (), 2.0, 1.5, 0.4, 90, 400, 8, "", {}, True).compared is None
    assert found.as_json()["least_held_out"] == least.label and found.as_json()["weak"] is False

"""Tests of the paper reproduction (triplanar/paper/) and ``triplanar paper``.

One test per numbered claim of ``docs/paper-reproduction.md`` ("Claim by claim"), each computing its figure from the
model directly (simulate + resample) and asserting it. Where our model does not bear a claim out, the
failing part is a strict xfail carrying the number: it fails loudly if the physics changes so that the
claim starts to hold, which is the moment docs/paper-reproduction.md must change too.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from triplanar import PAPER_LOADS_N, paper_model, read_measurements, reference, scale_mass, scale_size, \
    scale_uniform, simulate
from triplanar.cli import main
from triplanar.labdata import generate_lab_data, write_lab_data
from triplanar.paper import CLAIMS, default_data_path, figure_specs, reproduce
from triplanar.paper.figures import build_figure, render

ROOT = Path(__file__).resolve().parents[2]
SPECIMEN, FOUNDATION = reference()
REST = SPECIMEN.contact_points_m
LOADS = tuple(PAPER_LOADS_N)


def _sim(case: str, force: float, specimen=None, travel: float = 0.08):
    return simulate(paper_model(case, force, specimen=specimen), travel_m=travel)


@pytest.fixture(scope="module")
def runs() -> dict[str, list]:
    return {case: [_sim(case, f) for f in LOADS] for case in "ABC"}


@pytest.fixture(scope="module")
def data() -> dict[float, list]:
    out: dict[float, list] = {}
    for test in read_measurements(default_data_path(), rest_positions=REST):
        out.setdefault(test.shear_force_N, []).append(test)
    return out


def _hdist(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.hypot(a[..., 0] - b[..., 0], a[..., 2] - b[..., 2])


def _data_distance(tests, result) -> np.ndarray:
    """(samples, 3) horizontal distance from measured samples to the model at the same CP1 travel."""
    out = []
    for t in tests:
        s = np.clip(t.positions[:, 0, 0] - REST[0, 0], 0.0, result.travel[-1])
        out.append(_hdist(t.positions, result.resample_by_travel(s)))
    return np.concatenate(out)


def _ab_mean(a, b, n: int = 161) -> np.ndarray:
    grid = np.linspace(0.0, min(a.travel[-1], b.travel[-1]), n)
    return _hdist(a.resample_by_travel(grid), b.resample_by_travel(grid)).mean(axis=0)


def _similar(case: str, force1: float, spec1, c1: float, force2: float, spec2, c2: float) -> float:
    """Largest difference of the contact points at reference size (positions / c), at reference travels 2, 5
    and 8 cm, each a simulation stopped exactly there (no interpolation between different adaptive steps)."""
    gap = 0.0
    for s in (0.02, 0.05, 0.08):
        r1, r2 = _sim(case, force1, spec1, s * c1), _sim(case, force2, spec2, s * c2)
        assert r1.status.label == r2.status.label == "travel"
        gap = max(gap, float(np.abs(r1.contact_points[-1] / c1 - r2.contact_points[-1] / c2).max()))
    return gap


# -- claims -------------------------------------------------------------------------------------------

def test_claim1_case_A_matches_the_laboratory_at_all_loads(runs, data):
    """Mean mismatch under 1 mm at every load and contact point; B several times farther.
    (The dataset is made from case A physics plus scatter and noise, so this checks consistency.)"""
    for f, a, b in zip(LOADS, runs["A"], runs["B"]):
        da, db = _data_distance(data[f], a), _data_distance(data[f], b)
        assert np.all(da.mean(axis=0) < 1e-3), f
        assert db.mean() > 3 * da.mean(), f


@pytest.mark.xfail(strict=True, reason="at 27.8 N one repeat (F27.8N-r3, CP3 friction drawn +0.32 deg) "
                   "ends 5.4 mm from the model at CP3 (5.2 mm without noise): near the sliding threshold the "
                   "0.2 deg repeat scatter of friction moves the path by millimetres")
def test_claim1_no_sample_farther_than_3_mm(runs, data):
    for f, a in zip(LOADS, runs["A"]):
        assert _data_distance(data[f], a).max() < 3e-3, f


def test_claim2_cp1_lateral_dilation_much_larger_without_end_friction(runs):
    for a, b in zip(runs["A"], runs["B"]):
        dil_a = a.contact_points[-1, 0, 2] - REST[0, 2]
        dil_b = b.contact_points[-1, 0, 2] - REST[0, 2]
        assert dil_b > 3 * dil_a > 0
    assert runs["B"][0].contact_points[-1, 0, 2] - REST[0, 2] > 0.03  # 27.8 N: over 3 cm without end friction


def test_claim3_opposite_rotation_senses_up_to_45N(runs):
    for f, a, b in zip(LOADS, runs["A"], runs["B"]):
        assert b.rotation_deg[-1] < -4.0, f  # B clockwise at every load
        if f <= 45.0:
            assert a.rotation_deg[-1] > 0.0, f


@pytest.mark.xfail(strict=True, reason="case A turns slightly clockwise at 8 cm from 47.5 N up "
                   "(-0.01, -0.09, -0.15, -0.26 deg at 47.5, 49.6, 51.6, 55.6 N)")
def test_claim3_case_A_counter_clockwise_at_every_load(runs):
    assert all(a.rotation_deg[-1] > 0 for a in runs["A"])


def test_claim4_velocity_shielding(runs):
    d = np.array([_ab_mean(a, b) for a, b in zip(runs["A"], runs["B"])])
    assert np.all(np.diff(d[:, 2]) < 0)                  # CP3 falls at every load step
    assert np.all(np.diff(d[:4, 1]) < 0)                 # CP2 falls from 27.8 to 35 N ...
    assert (d[-1] / d[0])[1:].max() < (d[-1] / d[0])[0]  # CP2, CP3 shrink by a larger factor than CP1
    assert d[-1, 0] > 5e-3                               # CP1 still differs by over 5 mm at 55.6 N


@pytest.mark.xfail(strict=True, reason="CP2's A/B distance bottoms out at 0.9 mm at 35 N and rises again to "
                   "2.0 mm at 55.6 N")
def test_claim4_cp2_falls_at_every_load(runs):
    d = np.array([_ab_mean(a, b)[1] for a, b in zip(runs["A"], runs["B"])])
    assert np.all(np.diff(d) < 0)


def test_claim5_case_C_differs_more_at_CP3_and_at_low_loads(runs, data):
    for f, b, c in zip(LOADS, runs["B"], runs["C"]):
        db, dc = _data_distance(data[f], b).mean(axis=0), _data_distance(data[f], c).mean(axis=0)
        assert dc[2] > db[2], f
    # the leftward (-e3) CP2 trace the paper describes for case C at low load
    assert runs["C"][0].contact_points[-1, 1, 2] - REST[1, 2] < -0.005


@pytest.mark.xfail(strict=True, reason="averaged over CP1-3, case C is farther from the dataset than case B at "
                   "7 of 12 loads only (C is closer at CP1 at every load; from 40 N B and C differ by < 0.05 mm)")
def test_claim5_case_C_farther_than_B_at_every_load(runs, data):
    for f, b, c in zip(LOADS, runs["B"], runs["C"]):
        assert _data_distance(data[f], c).mean() > _data_distance(data[f], b).mean(), f


@pytest.mark.parametrize("force", [26.7, 53.4])
@pytest.mark.parametrize("case", ["A", "B"])
def test_claim6_case_D_geometrically_similar(case, force):
    half, double = scale_size(SPECIMEN, 0.5), scale_size(SPECIMEN, 2.0)
    assert _similar(case, force, half, 0.5, force, double, 2.0) < 1e-6
    # ... and not trivially: the two sizes' paths differ by centimetres in absolute terms
    assert np.abs(_sim(case, force, double, 0.16).contact_points[-1]
                  - _sim(case, force, half, 0.04).contact_points[-1]).max() > 0.05


@pytest.mark.parametrize("force", [26.7, 40.0, 53.4])
@pytest.mark.parametrize("case", ["A", "B"])
def test_claim7_case_E_identical_paths(case, force):
    light, heavy = scale_mass(SPECIMEN, 0.5), scale_mass(SPECIMEN, 2.0)
    assert _similar(case, force * 0.5, light, 1.0, force * 2.0, heavy, 1.0) < 1e-9


def test_claim8_case_F_similar_and_end_effect_scale_free():
    specs = {c: scale_uniform(SPECIMEN, c) for c in (0.5, 1.0, 2.0)}
    ab = {}
    for c, spec in specs.items():
        a, b = (_sim(case, spec.weight_N / 2, spec, 0.08 * c) for case in "AB")
        ab[c] = _ab_mean(a, b) / c
    for c in (0.5, 2.0):
        for case in "AB":
            assert _similar(case, specs[c].weight_N / 2, specs[c], c, specs[1.0].weight_N / 2, specs[1.0], 1.0) < 1e-6
        np.testing.assert_allclose(ab[c], ab[1.0], rtol=1e-3)
    assert ab[1.0][0] > 5e-3  # the end effect is there (CP1 over 5 mm apart), at every scale


def test_claim9_peak_speed_near_1_m_per_s(runs):
    peak = np.linalg.norm(runs["A"][-1].contact_velocities, axis=2).max()
    assert 0.8 <= peak <= 1.2


def test_rotation_from_contact_points_agrees_with_the_core(runs):
    from triplanar.paper.metrics import rotation_deg
    for result in (runs["A"][0], runs["B"][-1], runs["C"][3]):
        np.testing.assert_allclose(rotation_deg(result.contact_points, REST), result.rotation_deg, atol=1e-9)


# -- the reproduction, figures, report ---------------------------------------------------------------

@pytest.fixture(scope="module")
def rep():
    return reproduce(progress=False)


def test_reproduction_verdicts_match_the_documented_ones(rep):
    verdicts = {c.number: c.verdict for c in rep.claims}
    assert sorted(verdicts) == sorted(CLAIMS)
    doc = (ROOT / "docs" / "paper-reproduction.md").read_text(encoding="utf-8")
    documented = {int(m.group(1)): m.group(2) for m in
                  re.finditer(r"^\| (\d) \|.*\| \*\*(holds|holds partly|does not hold)\*\* \|$", doc, re.M)}
    assert documented == verdicts


@pytest.mark.slow
def test_figures_have_the_expected_panels(rep):
    specs = {s.name: s for s in figure_specs(rep)}
    expected = {"fig06_traces.png": 1, "fig11_case_A.png": 12, "fig12_case_B.png": 12, "fig13_case_C.png": 12,
                "fig14_case_D.png": 6, "fig15_case_E.png": 6, "fig16_case_F.png": 3}
    assert {name: len(s.panels) for name, s in specs.items()} == expected
    import matplotlib.pyplot as plt
    for name, n in expected.items():
        fig = build_figure(specs[name])
        visible = [ax for ax in fig.axes if ax.get_visible()]
        assert len(visible) == n, name
        for ax in visible:
            # every trace: 3 contact-point lines + 3 start markers
            n_traces = len(specs[name].panels[0].traces)
            assert len(ax.get_lines()) >= 6 * n_traces
        plt.close(fig)
    assert len(specs["fig11_case_A.png"].panels[0].traces) == 1 + 4  # model + four repeats


def test_render_writes_a_png(rep, tmp_path):
    spec = figure_specs(rep)[0]
    path = render(spec, tmp_path)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.slow
def test_outputs_for_a_small_dataset(tmp_path):
    tests, truth = generate_lab_data(loads=(30.3, 45.0), repeats=2, seed=5)
    write_lab_data(tmp_path / "lab.csv", tests, truth)
    assert main(["paper", "--out", str(tmp_path / "out"), "--data", str(tmp_path / "lab.csv"), "--no-progress"]) == 0
    out = tmp_path / "out"
    names = sorted(p.name for p in out.iterdir())
    assert [n for n in names if n.endswith(".png")] == ["fig06_traces.png", "fig11_case_A.png", "fig12_case_B.png",
                                                        "fig13_case_C.png", "fig14_case_D.png", "fig15_case_E.png",
                                                        "fig16_case_F.png"]
    report = (out / "report.md").read_text()
    assert report.count("\n| ") > 9 and "30.3" in report
    assert not [n for n in names if n.startswith(".")]  # no temporaries left

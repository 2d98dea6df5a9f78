"""No pattern described below the noise floor: an error that the traces' own noise (or, noise-free, the
integrator's tolerance) explains is reported as such, with no location, trend or frequency; an error above it
still is described."""

from __future__ import annotations

import re

import pytest

from triplanar import make_effect
from triplanar.labdata import generate_lab_data
from triplanar.workbench import ModelSpec, compare
from triplanar.workbench.evidence import instrument_noise_mm

pytestmark = pytest.mark.slow  # four small datasets: about 3 s

EXACT = [make_effect("end_friction:phi_deg=8"), make_effect("rate_friction:a=0.3")]
DESCRIBED = re.compile(r"CP\d|Hz|load|travel lag|turns|dilates")


def _data(noise_m: float, seed: int):
    return generate_lab_data(loads=(30.3, 40.0, 50.0), repeats=2, effects=EXACT, noise_m=noise_m,
                             scatter_deg=0.0, stop_range_m=(0.03, 0.035), seed=seed, case="B")[0]


def test_noise_free_exact_model_is_within_the_integrators_tolerance():
    tests = _data(0.0, 5)
    # smooth motion is not noise: the estimate stays far below any rangefinder's (second differences read 3-5 um)
    assert instrument_noise_mm(tests) < 1e-3
    text = compare(tests, ModelSpec.from_effects(EXACT)).pattern()
    assert text.startswith("within the noise") and "integrator" in text, text
    assert not DESCRIBED.search(text), text


def test_noisy_exact_model_is_within_the_noise():
    tests = _data(2e-4, 6)
    assert 0.18 < instrument_noise_mm(tests) < 0.22
    text = compare(tests, ModelSpec.from_effects(EXACT)).pattern()
    assert text.startswith("within the noise") and "integrator" not in text, text
    assert not DESCRIBED.search(text), text


@pytest.mark.parametrize("noise_m", [0.0, 2e-4])
def test_an_error_above_the_floor_is_still_described(noise_m):
    """A model lacking the rate friction (noise-free: any error above 1e-4 mm; noisy: more than the noise)."""
    tests = _data(noise_m, 7)
    cmp = compare(tests, ModelSpec.from_effects(EXACT[:1]))
    text = cmp.pattern()
    assert not text.startswith("within the noise"), (cmp.error_mm, text)
    assert re.search(r"CP\d", text), text

"""``--driver`` is read into a controller spec when the settings are made: a string that names no controller is
refused before any label is written, naming the field; a good one is recorded as given (its canonical string)."""

from __future__ import annotations

import pytest

from experiments import distill_labels as dl


@pytest.mark.parametrize("driver", ["ppo:", "no_such_controller", "sac:/run"])
def test_a_bad_driver_is_refused_naming_the_field(driver):
    with pytest.raises(ValueError, match="^driver: "):
        dl.LabelSettings(round=1, driver=driver)


@pytest.mark.parametrize("driver", ["student:/s/round0", "ppo_recurrent:/r/seed_1", "shipped:ppo_robust", "mpc"])
def test_a_good_driver_is_recorded_as_given(driver):
    assert dl.settings_record(dl.LabelSettings(round=1, driver=driver))["driver"] == driver

"""Layouts defined once: offsets follow from sizes, every field is covered once, and modules own their scratch."""

from __future__ import annotations

import numpy as np
import pytest

from envs import core as S
from triplanar import driver, kernel as K, stepping
from triplanar.layout import Layout


def test_offsets_follow_sizes() -> None:
    layout = Layout("X_", "N_X", [("A", 3, "a"), ("B", 1, "b"), ("C", 2, "c")], start=5)
    assert layout.constants() == {"X_A": 5, "X_B": 8, "X_C": 9, "N_X": 11}
    assert layout.describe(np.arange(11.0)) == {"A": [5.0, 6.0, 7.0], "B": 8.0, "C": [9.0, 10.0]}
    with pytest.raises(ValueError, match="twice"):
        Layout("Y_", "N_Y", [("A", 1, ""), ("A", 1, "")])


def test_explicit_names_are_checked_against_the_layout() -> None:
    layout = Layout("X_", "N_X", [("A", 3, "a"), ("B", 1, "b"), ("C", 2, "c")], start=5)
    X_A, X_B, X_C, N_X = layout.offsets()
    assert (X_A, X_B, X_C, N_X) == (5, 8, 9, 11)
    assert layout.named_in({"X_A": X_A, "X_B": X_B, "X_C": X_C, "N_X": N_X})
    assert not layout.named_in({"X_A": X_A, "X_B": X_C, "X_C": X_B, "N_X": N_X})  # two names swapped
    assert not layout.named_in({"X_A": X_A, "X_B": X_B, "X_C": X_C})  # the size missing


@pytest.mark.parametrize("module, layout", [(K, K.STATE), (K, K.PARAMS), (K, K.MODES), (K, K.AUX), (K, K.EVENTS),
                                            (K, K.WORKSPACE), (stepping, stepping.WORKSPACE),
                                            (driver, driver.WORKSPACE)])
def test_compiled_modules_name_every_offset(module: object, layout: Layout) -> None:
    assert layout.named_in(vars(module))


def test_workspace_layers_have_their_own_prefixes() -> None:
    prefixes = [K.WORKSPACE.prefix, stepping.WORKSPACE.prefix, driver.WORKSPACE.prefix]
    assert len(set(prefixes)) == len(prefixes), prefixes


@pytest.mark.parametrize("layout", [K.STATE, K.PARAMS, K.AUX, K.EVENTS, K.WORKSPACE, stepping.WORKSPACE,
                                    S.BOOKKEEPING, S.CONFIG, S.INFO, S.OBSERVATION, S.WORKSPACE])
def test_fields_tile_the_array(layout: Layout) -> None:
    covered = np.zeros(layout.size, int)
    for field in layout.fields.values():
        covered[field.offset:field.offset + field.size] += 1
    first = min(f.offset for f in layout.fields.values())
    assert (covered[first:] == 1).all()


def test_each_module_extends_the_workspace_of_the_one_below() -> None:
    assert stepping.WORKSPACE.fields["STAGES"].offset == K.N_KERNEL_WS_ROWS
    assert driver.WORKSPACE.fields["Y0"].offset == stepping.N_WS_ROWS
    assert S.WORKSPACE.fields["R"].offset == driver.N_WS_ROWS
    assert stepping.new_workspace().shape == (stepping.N_WS_ROWS, K.WS_WIDTH)
    assert driver.new_workspace().shape == (driver.N_WS_ROWS, K.WS_WIDTH)
    ws = S.new_workspace()
    assert (ws[K.W_COUNT] == 0.0).all()
    assert (K.modes_of(ws) == K.sliding_modes()).all()  # a new workspace holds all-sliding modes
    assert S.OBS_HIGH.shape == (S.OBS_DIM,) and len(S.INFO_KEYS) == len(S.INFO_SLOTS)

"""The post-start loss weight of :mod:`experiments.train_student` (``--post-start-weight``): the decisions just
after the opening excitation count ``W`` times in the loss, the start's own not at all, and a weight of 1 trains
exactly as before (earlier runs resume bitwise)."""

from __future__ import annotations

import numpy as np
import pytest

from experiments import train_student as ts

SMALL = ts.StudentSettings(hidden=(8,), epochs=1, batch=32, val_fraction=0.34, start_periods=2)


def test_the_weights_mark_the_start_the_span_after_it_and_the_rest():
    settings = ts.StudentSettings(start_periods=2, post_start_weight=5.0, post_start_span=3)
    weights = ts.loss_weights(np.arange(8), settings)
    np.testing.assert_array_equal(weights, [0, 0, 5, 5, 5, 1, 1, 1])
    assert weights.dtype == np.float32


@pytest.mark.parametrize("field, value", [("post_start_weight", 0.0), ("post_start_span", -1)])
def test_a_bad_weight_or_span_is_refused_naming_it(field, value):
    with pytest.raises(ValueError, match=field):
        ts.StudentSettings(**{field: value})


def test_the_weighted_loss_weighs_the_post_start_rows(tiny_labels):
    import torch
    settings = ts.StudentSettings(**{**SMALL.record(), "hidden": (8,), "post_start_weight": 3.0})
    data = ts.dataset(ts.label_shards([tiny_labels]), settings)
    rows = data.train
    action = torch.zeros((len(rows), 2))
    error = ((data.y[rows]) ** 2).mean(axis=1)
    w = data.weight[rows]
    assert set(np.unique(w)) == {1.0, 3.0}
    np.testing.assert_allclose(float(ts._weighted_mse(action, data, rows)), (w * error).sum() / w.sum(), rtol=1e-5)


def test_a_weight_of_one_trains_as_before(tiny_labels, tmp_path):
    plain = ts.train([tiny_labels], tmp_path / "plain", SMALL)
    weighted = ts.train([tiny_labels], tmp_path / "w", ts.StudentSettings(**{**SMALL.record(), "hidden": (8,),
                                                                                  "post_start_span": 5}))
    assert plain["weights_sha256"] == weighted["weights_sha256"]     # span without weight: no change

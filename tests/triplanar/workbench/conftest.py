"""Diagnoses that more than one workbench test reads, made once per process.

``test_workbench_hidden.py`` and ``test_workbench_verdicts.py`` both diagnose the same reduced campaign (4 loads x 2
repeats, seed 1, 2 folds, every default candidate) with rate friction hidden in it and with nothing hidden. The tests
that read one of these carry ``xdist_group("default_diagnoses")``, so that one xdist worker runs them all and makes
each diagnosis once.

The diagnoses skip the model-form step (``model_form=False``: the named entry's profile-likelihood interval and its
refits with every one-parameter alternative, 30-65 % of a diagnosis's CPU here). What these tests assert (the ranking,
the named entry and its values, standard errors and curvature intervals, the verdict, its kind, improvement and
confidence being high, low or none) does not depend on it: the step adds the entry's ``param_profile_ci95`` and
``param_model_ci95`` and may lower its confidence from high to low, which they accept alike. Measured on every hidden
scenario and on no hidden effect, with the step and without: the same fields. The step itself is tested in
``test_workbench_profile.py`` and ``test_workbench_user_effect.py``, and runs in every default diagnosis of the
other tests (the tutorial, the command line's).

They run in the test's process (``executor="serial"``), as the other diagnoses of these tests do: a process pool's
workers each simulate and cache on their own, which cost 16 % more CPU on the hidden scenarios (105 vs 125 s), and
``make test`` keeps both cores busy with its xdist workers anyway. The pool is tested where it is the subject
(``test_workbench.py``'s executors, the command line's ``--workers 2``).
"""

from __future__ import annotations

import functools

import pytest

from triplanar import make_effect
from triplanar.labdata import generate_lab_data
from triplanar.workbench import Diagnoser


@functools.lru_cache(maxsize=None)
def _diagnosed(specs: tuple[str, ...], loads: tuple[float, ...], repeats: int, seed: int,
               folds: int) -> tuple[list, Diagnoser]:
    tests, truth = generate_lab_data(loads=loads, repeats=repeats, effects=[make_effect(s) for s in specs], seed=seed)
    assert not truth["skipped"]
    return tests, Diagnoser(folds=folds, progress=False, model_form=False, executor="serial").fit(tests)


@pytest.fixture(scope="session")
def default_diagnosis():
    """``default_diagnosis(specs, loads, repeats, seed, folds) -> (tests, Diagnoser)``: the generator's data made
    with the effects ``specs`` (``--effect`` strings; none: nothing hidden), diagnosed with the default candidates
    against the plain model, without the model-form step (module doc). Cached per process: read it, do not change it."""
    return lambda specs, loads, repeats, seed, folds: _diagnosed(tuple(specs), tuple(loads), repeats, seed, folds)

"""Task checkpoints (``diagnose``'s ``.diagnose-partial``, ``train``'s and the studies' ``tasks/``) are plain data:
results round-trip exactly, and a pickle planted there never runs."""

from __future__ import annotations

import math
import pickle
import sys
from pathlib import Path

import numpy as np

import pytest

from triplanar import plain_data
from triplanar.executor import TaskCheckpoint, run_tasks
from triplanar.workbench.fitbase import FitOutcome


class Payload:
    def __init__(self, marker: Path):
        self.marker = marker

    def __reduce__(self):
        return exec, (f"open({str(self.marker)!r}, 'w').write('ran')",)


def outcome() -> FitOutcome:
    return FitOutcome("all", ("tip_wear",), {"tip_wear": {"k": 0.1 + 0.2}}, {"tip_wear": {"k": math.inf}},
                      (), 0.123456789012345, {"t1": (27.8, 0.5)}, {}, 7, 1.5, "ok", vector=(1e-300, -0.0),
                      bias_ratio=math.nan)


def test_results_round_trip_exactly() -> None:
    value = {"all": outcome(), 3: [np.arange(4.0), np.float32(2.5), None, True], (1, "a"): {"x": -math.inf}}
    back = plain_data.decode(*_through_file(value))
    assert back[3][0].tolist() == [0.0, 1.0, 2.0, 3.0] and back[3][1] == np.float32(2.5) and back[3][2:] == [None, True]
    assert back[(1, "a")]["x"] == -math.inf
    got = back["all"]
    assert isinstance(got, FitOutcome) and math.isnan(got.bias_ratio)
    assert got == outcome().__class__(**{**outcome().__dict__, "bias_ratio": got.bias_ratio})
    assert got.train_errors == {"t1": (27.8, 0.5)} and got.vector == (1e-300, -0.0)


def _through_file(value):
    import io
    import json
    with np.load(io.BytesIO(plain_data.dumps(value)), allow_pickle=False) as npz:
        arrays = {k: npz[k] for k in npz.files}
    return json.loads(arrays.pop("__structure__").tobytes().decode()), arrays


@pytest.mark.parametrize("value", [object(), np.array([object()]), Payload(Path("x")), {"a": lambda: 1}])
def test_what_plain_data_cannot_hold_is_refused(value) -> None:
    with pytest.raises(plain_data.PlainDataError):
        plain_data.dumps(value)


def test_a_file_naming_code_or_an_unknown_class_is_refused(tmp_path) -> None:
    import json
    for name in ("os:system", "subprocess:Popen", "triplanar.plain_data:PlainDataError", "nosuch.module:X"):
        structure = json.dumps({"$dataclass": name, "fields": {}}).encode()
        path = tmp_path / "f.npz"
        np.savez(path, __structure__=np.frombuffer(structure, dtype=np.uint8))
        with pytest.raises(plain_data.PlainDataError, match="f.npz: not a readable results file"):
            plain_data.load(path)


def test_planted_pickles_in_a_task_checkpoint_never_run(tmp_path) -> None:
    """``diagnose``'s default ``out/diagnose/.diagnose-partial``: a pickle under every name a task would use (and
    the old ``.pkl`` names) is ignored or replaced, never unpickled."""
    marker = tmp_path / "marker"
    partial = tmp_path / "out" / "diagnose" / ".diagnose-partial"
    checkpoint = TaskCheckpoint(partial)
    tasks = [1, 2, 3]
    partial.mkdir(parents=True)
    for task in tasks:
        key = checkpoint.key(abs, task)
        for suffix in (".npz", ".pkl"):
            (partial / f"{key}{suffix}").write_bytes(pickle.dumps(Payload(marker)))
    assert run_tasks(abs, tasks, "serial", checkpoint=checkpoint) == [1, 2, 3]
    assert not marker.exists()
    assert run_tasks(abs, tasks, "serial", checkpoint=checkpoint) == [1, 2, 3]   # now read back, as data
    assert not marker.exists()
    torn = partial / f"{checkpoint.key(abs, 2)}.npz"
    torn.write_bytes(torn.read_bytes()[:100])   # a torn write: the task runs again
    assert run_tasks(abs, tasks, "serial", checkpoint=checkpoint) == [1, 2, 3]
    assert checkpoint.load(checkpoint.key(abs, 2)) == (True, 2)   # and its result replaced the torn file


def test_a_checkpoint_file_naming_a_module_not_imported_is_left_in_place(tmp_path, monkeypatch):
    # A reader that has not imported the module of a stored dataclass (a script looking at a study's store) sees
    # the task as not stored; the file stays for the process that can read it.
    checkpoint = TaskCheckpoint(tmp_path)
    key = checkpoint.key(abs, 1)
    checkpoint.save(key, outcome())
    monkeypatch.delitem(sys.modules, FitOutcome.__module__)
    assert checkpoint.load(key) == (False, None)
    assert (tmp_path / f"{key}.npz").exists()
    monkeypatch.undo()
    assert checkpoint.load(key)[0] is True


def test_a_field_added_since_the_file_was_written_reads_as_its_default() -> None:
    """Kept results (the calibration's kept evidence) stay readable when their class gains a field with a default; a
    field the class does not have, or a missing one without a default, is still refused."""
    structure, arrays = _through_file(outcome())
    fields = structure["fields"]
    older = {**structure, "fields": {k: v for k, v in fields.items() if k != "bias_ratio"}}   # bias_ratio has a default
    assert plain_data.decode(older, arrays).bias_ratio == FitOutcome.__dataclass_fields__["bias_ratio"].default
    for broken in ({k: v for k, v in fields.items() if k != "label"}, {**fields, "no_such_field": 1}):
        with pytest.raises(plain_data.PlainDataError, match="the fields do not match"):
            plain_data.decode({**structure, "fields": broken}, arrays)

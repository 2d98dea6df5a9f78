"""Expert-label generation (``experiments.distill_labels``) resumes after an interruption: a run stopped part-way,
run again, ends with the same shards as a run that was never stopped (a scripted stand-in for the expert: the point
here is the bookkeeping, not ``mpc``)."""

from __future__ import annotations

import numpy as np
import pytest

from experiments import distill_labels as dl

SHORT = (("time_limit_s", 0.05),)  # 9 periods an episode


@pytest.mark.slow
def test_an_interrupted_run_resumes_to_the_uninterrupted_shards(tmp_path, fast_expert, read_shards, monkeypatch):
    settings = dl.LabelSettings(env_kwargs=SHORT)
    dl.generate(tmp_path / "whole", settings, 3, 6)
    whole = read_shards(tmp_path / "whole")
    assert len(whole) == 6 and sum(bool(s["started"]) for s in whole.values()) >= 3

    real, ran = dl.rollout, []

    def killed_in_the_third(settings, bench, draw):
        if len(ran) == 2:
            raise KeyboardInterrupt  # the run is stopped while this episode runs
        ran.append(draw)
        return real(settings, bench, draw)
    monkeypatch.setattr(dl, "rollout", killed_in_the_third)
    cut = tmp_path / "cut"
    with pytest.raises(KeyboardInterrupt):
        dl.generate(cut, settings, 3, 6)
    before = read_shards(cut)
    assert 2 <= len(before) < 6
    folder = cut / "shards"
    (folder / ".20020_0000008.999999999.0123456789ab.partial.npz").write_bytes(b"a hard kill's leftover")
    damaged = sorted(before)[0]
    (folder / damaged).write_bytes(b"not a shard")  # (a disk error: atomic writes leave none)

    monkeypatch.setattr(dl, "rollout", real)
    resumed = dl.generate(cut, settings, 3, 6)
    redone = {f"{dl.TUNING_SEED}_{r['draw']:07d}.npz" for r in resumed}
    assert redone == (set(whole) - set(before)) | {damaged}  # complete shards were not run again
    after = read_shards(cut)
    assert sorted(after) == sorted(whole)
    for name in whole:
        assert sorted(after[name]) == sorted(whole[name])
        for key, value in whole[name].items():
            np.testing.assert_array_equal(after[name][key], value, err_msg=f"{name}: {key}")
    assert sorted(p.name for p in folder.iterdir()) == sorted(whole)  # no temporary left behind
    assert dl.generate(cut, settings, 3, 6) == []  # nothing left to run


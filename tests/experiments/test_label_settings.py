"""A resumed label-generation run whose settings differ from the folder's stored ones is refused, naming each field
that differs and running nothing; labels never come from the held-out or stress streams."""

from __future__ import annotations

import json

import pytest

from agents.heldout import HELDOUT_SEED, STRESS_SEED
from experiments import distill_labels as dl

SHORT = (("time_limit_s", 0.05),)


def test_a_resume_with_other_settings_is_refused_naming_them(tmp_path, fast_expert, monkeypatch, capsys):
    dl.generate(tmp_path, dl.LabelSettings(env_kwargs=SHORT), 0, 1)
    stored = sorted((tmp_path / "shards").iterdir())
    other = dl.LabelSettings(expert=(("bank_size", 16),), env_kwargs=(("time_limit_s", 0.1),))
    with pytest.raises(dl.SettingsMismatch) as refused:
        dl.generate(tmp_path, other, 0, 3)
    message = str(refused.value)
    assert "expert.bank_size (stored 32, now 16)" in message
    assert "env_kwargs.time_limit_s (stored 0.05, now 0.1)" in message
    assert sorted((tmp_path / "shards").iterdir()) == stored  # nothing ran

    code = dl.code_version()
    monkeypatch.setattr(dl, "code_version", lambda: {**code, "agents/mpc.py": "0" * 16})
    with pytest.raises(dl.SettingsMismatch, match=r"code_version\.agents/mpc\.py \(stored '[0-9a-f]{16}', now '0{16}'"):
        dl.generate(tmp_path, dl.LabelSettings(env_kwargs=SHORT), 0, 3)

    with pytest.raises(dl.SettingsMismatch, match="expert.bank_size"):  # accepted: a code change, nothing else
        dl.generate(tmp_path, other, 0, 3, accept_code_change=True)
    dl.generate(tmp_path, dl.LabelSettings(env_kwargs=SHORT), 0, 1, accept_code_change=True)
    record = json.loads((tmp_path / "settings.json").read_text())
    assert record["code_version"]["agents/mpc.py"] == "0" * 16
    assert record["accepted_code_changes"][0]["fields"] == ["code_version.agents/mpc.py"]
    dl.generate(tmp_path, dl.LabelSettings(env_kwargs=SHORT), 0, 1)  # the accepted version is now the stored one

    # the command says so and stops with an error status
    assert dl.main(["--out", str(tmp_path), "--n", "3", "--first", "0", "--expert", "bank_size=16"]) == 2
    assert "expert.bank_size (stored 32, now 16)" in capsys.readouterr().err


def test_a_docstring_is_not_a_code_change(tmp_path):
    source = 'def f(x):\n    """Twice x."""\n    return 2 * x  # doubled\n'
    (tmp_path / "a.py").write_text(source)
    (tmp_path / "b.py").write_text(source.replace("Twice x.", "Twice x,\n    reworded.").replace("# doubled", ""))
    (tmp_path / "c.py").write_text(source.replace("2 * x", "3 * x"))
    a, b, c = (dl.source_hash(tmp_path / f"{n}.py") for n in "abc")
    assert a == b != c


@pytest.mark.parametrize("stream", [HELDOUT_SEED, STRESS_SEED])
def test_the_evaluation_streams_are_refused(stream):
    with pytest.raises(ValueError, match=f"stream {stream} is the"):
        dl.LabelSettings(stream=stream)


def test_the_expert_keeps_the_unbounded_estimator_of_the_stored_folders():
    """The label folders were made with ``mpc``'s estimator unbounded (``move_periods`` 0); ``mpc``'s default now
    bounds it, and the expert does not follow the default unless told (``--expert move_periods=N``)."""
    from agents.mpc import MPCController
    assert MPCController().move_periods > 0
    assert dl.expert_settings(dl.LabelSettings())["move_periods"] == 0
    assert dl.make_expert(dl.LabelSettings()).move_periods == 0
    told = dl.LabelSettings(expert=(("move_periods", 15),))
    assert dl.make_expert(told).move_periods == 15 and dl.expert_settings(told)["move_periods"] == 15


def test_the_labels_expert_has_no_work_budget_and_old_folders_resume(tmp_path):
    """mpc's planner has work budgets by default since 2026-11-29; the labels' expert keeps none (pinned), and a
    folder whose settings.json was written before the budgets existed resumes (it holds labels of no budget)."""
    import json
    from agents.mpc import MPCController
    assert MPCController().fev_budget > 0 and MPCController().decision_fev_budget > 0
    expert = dl.make_expert(dl.LabelSettings())
    assert expert.fev_budget == 0.0 and expert.decision_fev_budget == 0.0
    dl.check_settings(tmp_path, dl.LabelSettings())
    path = tmp_path / "settings.json"
    record = json.loads(path.read_text())
    for name in ("fev_budget", "decision_fev_budget"):
        del record["expert"][name]
    path.write_text(json.dumps(record))
    dl.check_settings(tmp_path, dl.LabelSettings())            # accepted: the same expert
    told = dl.LabelSettings(expert=(("fev_budget", 100.0),))
    with pytest.raises(dl.SettingsMismatch, match="fev_budget"):
        dl.check_settings(tmp_path, told)

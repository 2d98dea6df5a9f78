"""Model cards are read strictly: a bad field is refused by name (agents.zoo.cards.parse_card), never a traceback."""

from __future__ import annotations

import json
import re

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from agents import zoo
from agents.zoo.cards import MAX_DEPTH, ShippedAgentError, parse_card


def _card() -> dict:
    return json.loads((zoo.ZOO_DIR / "ppo_robust" / "card.json").read_text())


def test_the_shipped_cards_are_valid():
    for name in zoo.shipped_names():
        assert zoo.read_card(name)["name"] == name


@pytest.mark.parametrize("field, value, named", [
    ("seeds", None, "'seeds'"), ("seeds", [0, 0], "'seeds'"), ("seeds", [True], "'seeds'"), ("seeds", "0", "'seeds'"),
    ("seeds", [-1], "'seeds'"), ("timesteps", "2e6", "'timesteps'"), ("timesteps", 0, "'timesteps'"),
    ("algo", "sac", "'algo'"), ("env_kwargs", [], "'env_kwargs'"), ("env_kwargs", {"latency_s": [1]},
                                                                     "'env_kwargs.latency_s'"),
    ("observation", {"observation_mode": "bench", "fields": [["RANGE", 9]], "frames": "4"}, "'observation.frames'"),
    ("observation", {"observation_mode": "bench", "fields": [["RANGE", -9]], "frames": 4},
     "'observation.fields[0]'"),
    ("figures", {"heldout": {"score": "1.2"}}, "'figures.heldout.score'"), ("files", {"a": "x"}, "'files'"),
    ("name", "../x", "'name'"), ("command", None, "'command'"), ("hyperparameters", None, "'hyperparameters'"),
])
def test_a_bad_field_is_refused_by_name(field, value, named):
    card = _card()
    card[field] = value
    with pytest.raises(ShippedAgentError, match=re.escape(named)):
        parse_card(json.dumps(card), "x/card.json")


def test_missing_keys_deep_nesting_and_non_json_are_refused():
    card = _card()
    del card["seeds"]
    with pytest.raises(ShippedAgentError, match=r"lacks \['seeds'\]"):
        parse_card(json.dumps(card))
    card = _card()
    card["hyperparameters"]["deep"] = json.loads("[" * MAX_DEPTH + "]" * MAX_DEPTH)
    with pytest.raises(ShippedAgentError, match="nested too deep"):
        parse_card(json.dumps(card))
    with pytest.raises(ShippedAgentError, match="nested too deep"):
        parse_card('{"a": ' + "[" * 100_000 + "]" * 100_000 + "}")
    for text in ("", "[1]", "{", b"\xff\xfe"):
        with pytest.raises(ShippedAgentError):
            parse_card(text)


def test_a_bad_policy_argument_is_refused_when_the_policy_is_built():
    from agents.zoo.agent import build_policy
    card = _card()
    card["hyperparameters"]["hyperparams"]["policy_kwargs"]["activation_fn"] = "os.system"
    with pytest.raises(ShippedAgentError, match="policy_kwargs.activation_fn"):
        build_policy(card, {})


_LEAVES = st.one_of(st.none(), st.booleans(), st.integers(-2**40, 2**40), st.floats(allow_nan=True),
                    st.text(max_size=8))
_VALUES = st.recursive(_LEAVES, lambda inner: st.one_of(st.lists(inner, max_size=3),
                                                        st.dictionaries(st.text(max_size=5), inner, max_size=3)),
                       max_leaves=12)


@st.composite
def _mutated(draw):
    card = _card()
    for _ in range(draw(st.integers(1, 3))):
        path = draw(st.sampled_from([("seeds",), ("timesteps",), ("env_kwargs",), ("observation",),
                                     ("observation", "frames"), ("observation", "fields"), ("figures",),
                                     ("figures", "heldout"), ("files",), ("name",), ("algo",), ("date",),
                                     ("hyperparameters",), ("env_id",)]))
        target = card
        for key in path[:-1]:
            target = target[key] if isinstance(target, dict) and isinstance(target.get(key), dict) else {}
        if draw(st.booleans()) and path[-1] in target:
            del target[path[-1]]
        else:
            target[path[-1]] = draw(_VALUES)
    return card


@pytest.mark.slow
@settings(deadline=None, suppress_health_check=list(HealthCheck))   # inputs: the profile (tests/conftest.py)
@given(card=_mutated())
def test_fuzzed_cards_are_a_named_refusal_or_a_valid_card(card):
    try:
        text = json.dumps(card)
    except ValueError:
        return
    try:
        parsed = parse_card(text, "fuzz/card.json")
    except ShippedAgentError as err:
        assert str(err).startswith("fuzz/card.json: ")
        return
    assert isinstance(parsed["seeds"], list) and all(type(s) is int for s in parsed["seeds"])
    assert type(parsed["timesteps"]) is int and parsed["algo"] in ("ppo", "recurrent")

"""Effects as values: equality and hashing."""

from triplanar.effects import REGISTRY


def test_effects_are_equal_only_with_exactly_equal_values():
    end_friction = REGISTRY["end_friction"]
    a, b = end_friction(phi_deg=8.0), end_friction(phi_deg=8.0 + 1e-9)
    assert a.label() == b.label()          # the same to 6 digits when printed for people ...
    assert a != b and len({a, b}) == 2     # ... but different effects
    assert repr(b) == "end_friction:phi_deg=8.000000001"    # (repr reads back: make_effect(repr(e)) == e)
    assert a == end_friction(phi_deg=8.0) and hash(a) == hash(end_friction(phi_deg=8.0))

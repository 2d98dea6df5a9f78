"""Effects as values: equality and hashing."""

from triplanar.effects import REGISTRY


def test_effects_are_equal_only_with_exactly_equal_values():
    end_friction = REGISTRY["end_friction"]
    a, b = end_friction(phi_deg=8.0), end_friction(phi_deg=8.0 + 1e-9)
    assert repr(a) == repr(b)              # the same to 6 digits when printed ...
    assert a != b and len({a, b}) == 2     # ... but different effects
    assert a == end_friction(phi_deg=8.0) and hash(a) == hash(end_friction(phi_deg=8.0))

"""The specimen TOML reader is strict (unknown keys, types, shapes, plausibility) and its every
error names the file and the key; fuzzed: a named error or a valid result, never another exception."""

from __future__ import annotations

import copy
import tomllib
from importlib import resources

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from triplanar.cli import main
from triplanar.specimen import SpecimenError, load_toml, parse_toml, reference, to_toml

REFERENCE_TEXT = resources.files("triplanar").joinpath("data/reference.toml").read_text(encoding="utf-8")
PLANES = REFERENCE_TEXT[REFERENCE_TEXT.index("[foundation]"):]
SPECIMEN = REFERENCE_TEXT[:REFERENCE_TEXT.index("[foundation]")]


def write(tmp_path, text: str | bytes):
    path = tmp_path / "s.toml"
    path.write_bytes(text if isinstance(text, bytes) else text.encode("utf-8"))
    return path


@pytest.mark.parametrize("text, key", [
    ("planes = 5\n" + REFERENCE_TEXT, "planes"),
    (SPECIMEN + "foundation = 5\n", "foundation"),
    ("specimen = 5\n" + PLANES, "specimen"),
    ("[[specimen]]\nmass_kg = 5.4\n" + PLANES, "specimen"),
    (REFERENCE_TEXT.replace("dip_direction_deg = 150.0", "dip_dir_deg = 150.0"), "foundation.planes[2].dip_dir_deg"),
    (REFERENCE_TEXT.replace("planes = [", "extra = 1\nplanes = ["), "foundation.extra"),
    ("colour = 'red'\n" + REFERENCE_TEXT, "colour"),
    (REFERENCE_TEXT.replace("mass_kg = 5.4", "mass_kg = true"), "specimen.mass_kg"),
    (REFERENCE_TEXT.replace("mass_kg = 5.4", 'mass_kg = "5.4"'), "specimen.mass_kg"),
    (REFERENCE_TEXT.replace("friction_deg = [17.0, 14.0, 11.0]", "friction_deg = [true, 14.0, 11.0]"),
     "specimen.friction_deg[0]"),
    (REFERENCE_TEXT.replace("tip_friction_deg = 8.0", "tip_friction_deg = false"), "specimen.tip_friction_deg"),
    (REFERENCE_TEXT.replace("dip_deg = 9.5", "dip_deg = true"), "foundation.planes[1].dip_deg"),
    (REFERENCE_TEXT.replace("mass_kg = 5.4", "mass_kg = [5.4]"), "specimen.mass_kg"),
    (REFERENCE_TEXT.replace("name = ", "name = 3 #"), "specimen.name"),
    (REFERENCE_TEXT.replace("planes = [", "planes = 5 #[").split("{")[0], "foundation.planes"),
])
def test_malformed_specimen_toml_gives_a_named_error(tmp_path, text, key) -> None:
    path = write(tmp_path, text)
    with pytest.raises(SpecimenError) as err:
        load_toml(path)
    assert str(path) in str(err.value) and key in str(err.value)


def test_lengths_in_millimetres_are_refused_with_the_reason_unless_asked(tmp_path) -> None:
    specimen, foundation = reference()
    from triplanar.specimen import scale_size
    big = scale_size(specimen, 1000.0)  # what millimetres in metre fields give: a 280 m block
    text = to_toml(big, foundation)
    assert "allow_large = true" in text
    load_toml(write(tmp_path, text))  # asked for: accepted
    with pytest.raises(SpecimenError, match="millimetres given.*allow_large") as err:
        load_toml(write(tmp_path, text.replace("allow_large = true\n", "")))
    assert "specimen.contact_points_m" in str(err.value)
    s, f = load_toml(write(tmp_path, text.replace("allow_large = true\n", "")), allow_large=True)
    assert s.contact_points_m[0, 0] == pytest.approx(-140.0)


def test_a_bom_is_accepted_and_non_utf8_names_the_file(tmp_path) -> None:
    specimen, foundation = load_toml(write(tmp_path, "\ufeff" + REFERENCE_TEXT))
    assert specimen.mass_kg == reference()[0].mass_kg
    path = write(tmp_path, REFERENCE_TEXT.replace("aluminium", "alumini\u00fcm").encode("latin-1"))
    with pytest.raises(SpecimenError, match="not UTF-8") as err:
        load_toml(path)
    assert str(path) in str(err.value)


def test_reference_round_trips_and_cli_reports_bad_toml_without_traceback(tmp_path, capsys) -> None:
    specimen, foundation = load_toml(write(tmp_path, to_toml(*reference())))
    assert to_toml(specimen, foundation) == to_toml(*reference()) and foundation == reference()[1]
    path = write(tmp_path, REFERENCE_TEXT.replace("mass_kg = 5.4", "mass_kg = true"))
    code = main(["simulate", "--specimen", str(path), "--force", "30"])
    err = capsys.readouterr().err
    assert code == 2 and "specimen.mass_kg" in err and "Traceback" not in err


# -- fuzz --------------------------------------------------------------------------------------------------

REFERENCE_DATA = tomllib.loads(REFERENCE_TEXT)
scalars = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(min_value=-10**400, max_value=10**400),
                    st.booleans(), st.text(max_size=5), st.none())
values = st.recursive(scalars, lambda inner: st.one_of(st.lists(inner, max_size=4),
                                                       st.dictionaries(st.text(max_size=4), inner, max_size=3)),
                      max_leaves=10)
keys = st.sampled_from(sorted(REFERENCE_DATA["specimen"]) + ["dip_deg", "dip_direction_deg", "planes", "allow_large",
                                                               "specimen", "foundation", "typo"])


def paths(data, prefix=()):
    yield prefix
    if isinstance(data, dict):
        for k, v in data.items():
            yield from paths(v, prefix + (k,))
    elif isinstance(data, list):
        for i, v in enumerate(data):
            yield from paths(v, prefix + (i,))


@st.composite
def mutated(draw):
    data = copy.deepcopy(REFERENCE_DATA)
    for _ in range(draw(st.integers(1, 3))):
        where = draw(st.sampled_from(list(paths(data))))
        if not where:
            continue
        node = data
        for step in where[:-1]:
            node = node[step]
        action = draw(st.sampled_from(["replace", "delete", "add", "nudge"]))
        if action == "replace" or (action == "delete" and isinstance(node, list)):
            node[where[-1]] = draw(values)
        elif action == "delete":
            del node[where[-1]]
        elif action == "add" and isinstance(node, dict):
            node[draw(keys)] = draw(values)
        elif isinstance(node[where[-1]], float):
            node[where[-1]] *= draw(st.sampled_from([-1.0, 0.0, 1e-3, 1e3, 1e300]))
    return data


@pytest.mark.slow
@settings(deadline=None, suppress_health_check=list(HealthCheck))  # inputs: the profile (tests/conftest.py)
@given(data=mutated())
def test_fuzz_parse_toml_gives_a_named_error_or_a_valid_specimen(data) -> None:
    try:
        specimen, foundation = parse_toml(data, source="fuzz.toml")
    except SpecimenError as err:
        assert str(err).startswith("fuzz.toml: ")
        return
    specimen.validate(foundation)


@pytest.mark.slow
@settings(deadline=None, suppress_health_check=list(HealthCheck))  # inputs: the profile (tests/conftest.py)
@given(text=st.one_of(st.text(max_size=200), st.binary(max_size=200),
                      st.builds(lambda a, b, c: REFERENCE_TEXT[:a] + c + REFERENCE_TEXT[b:],
                                st.integers(0, len(REFERENCE_TEXT)), st.integers(0, len(REFERENCE_TEXT)),
                                st.text(max_size=20))))
def test_fuzz_load_toml_text_gives_a_named_error_or_a_valid_specimen(tmp_path_factory, text) -> None:
    path = tmp_path_factory.mktemp("fuzz", numbered=True) / "f.toml"
    path.write_bytes(text if isinstance(text, bytes) else text.encode("utf-8", "surrogatepass"))
    try:
        load_toml(path)
    except SpecimenError as err:
        assert str(path) in str(err)

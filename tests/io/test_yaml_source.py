"""YAML parsing with line numbers, YAML 1.2 scalars, ``--set`` overrides."""

import pytest
from hypothesis import given
from hypothesis import strategies as st

from inins.exceptions import InputError
from inins.scenario.yaml_source import (
    apply_override,
    dump_yaml,
    format_path,
    line_of,
    parse_override,
    parse_yaml,
)

TEXT = """\
# comment
imu:
  gyro:
    bias_dph: [1, 2, 3]
motion:
  - kind: hold
    duration_s: 5
  - kind: rotate
    duration_s: 10
"""


def test_lines_of_keys_and_items():
    data, lines = parse_yaml(TEXT, "s.yaml")
    assert data["motion"][1]["duration_s"] == 10
    assert lines[("imu",)] == 2
    assert lines[("imu", "gyro", "bias_dph")] == 4
    assert lines[("imu", "gyro", "bias_dph", 1)] == 4
    assert lines[("motion", 1)] == 8
    assert lines[("motion", 1, "duration_s")] == 9
    assert line_of(lines, ("motion", 1, "missing_key")) == 8
    assert line_of(lines, ("nothing",)) is None


@pytest.mark.parametrize(
    ("text", "value"),
    [
        ("x: yes", "yes"),
        ("x: off", "off"),
        ("x: true", True),
        ("x: False", False),
        ("x: 1e-3", 1e-3),
        ("x: 2.5E3", 2500.0),
        ("x: -1e2", -100.0),
        ("x: .5e1", 5.0),
        ("x: 1.0e+3", 1000.0),
        ("x: 12", 12),
        ("x: 2024-05-01", "2024-05-01"),
        ("x: .nan", "nan"),
        ("x: 1_000", 1000),
        ("x:", None),
    ],
)
def test_yaml_1_2_scalars(text, value):
    got = parse_yaml(text, "s.yaml")[0]["x"]
    if value == "nan":
        assert got != got
    else:
        assert got == value and type(got) is type(value)


def test_on_key_stays_text():
    assert parse_yaml("on: 1\n", "s.yaml")[0] == {"on": 1}


def test_empty_document_is_empty_mapping():
    assert parse_yaml("# nothing\n", "s.yaml")[0] == {}


def test_syntax_error_names_line_and_column():
    with pytest.raises(InputError) as info:
        parse_yaml("a: 1\nb: [1, 2\nc: 3\n", "s.yaml")
    err = info.value
    assert err.source == "s.yaml" and err.line == 3
    assert "YAML syntax error, column" in str(err)


def test_tab_indentation_is_a_syntax_error():
    with pytest.raises(InputError, match="YAML syntax error"):
        parse_yaml("a:\n\tb: 1\n", "s.yaml")


def test_duplicate_keys_rejected():
    with pytest.raises(InputError) as info:
        parse_yaml("a:\n  b: 1\n  b: 2\n", "s.yaml")
    assert info.value.key == "a.b" and info.value.line == 3
    assert "first defined at line 2" in str(info.value)


def test_top_level_must_be_mapping():
    with pytest.raises(InputError, match="mapping"):
        parse_yaml("[1, 2]\n", "s.yaml")


def test_aliases_and_recursion_do_not_hang():
    data, _ = parse_yaml("a: &x {b: 1}\nc: *x\n", "s.yaml")
    assert data["c"] == {"b": 1}
    parse_yaml("a: &x [*x]\n", "s.yaml")
    bomb = "a: &a [1,1,1,1,1,1,1,1,1]\n" + "".join(
        f"{c}: &{c} [*{p},*{p},*{p},*{p},*{p},*{p},*{p},*{p},*{p}]\n"
        for p, c in zip("abcdefg", "bcdefgh", strict=True)
    )
    with pytest.raises(InputError, match="too large"):
        parse_yaml(bomb, "s.yaml")


def test_parse_override_forms():
    assert parse_override("a.b.0.c=5") == (("a", "b", 0, "c"), 5)
    assert parse_override("a.b[0].c=5") == (("a", "b", 0, "c"), 5)
    assert parse_override("x=[1, 2]") == (("x",), [1, 2])
    assert parse_override("x={k: yes}") == (("x",), {"k": "yes"})
    assert parse_override("x=") == (("x",), None)
    assert parse_override(" x = 1e-3") == (("x",), 1e-3)
    assert parse_override("x=a=b") == (("x",), "a=b")


@pytest.mark.parametrize("item", ["x", "=1", ".x=1", "x.=1", "a..b=1", "a b=1", "a[x]=1"])
def test_parse_override_rejects_bad_syntax(item):
    with pytest.raises(InputError, match=r"--set expects KEY\.PATH=VALUE"):
        parse_override(item)


def test_apply_override_creates_missing_mappings():
    data = {"imu": None}
    apply_override(data, ("imu", "gyro", "bias_dph"), [1, 2, 3], "item")
    assert data == {"imu": {"gyro": {"bias_dph": [1, 2, 3]}}}


def test_apply_override_indexes_lists():
    data, _ = parse_yaml(TEXT, "s.yaml")
    apply_override(data, ("motion", 1, "duration_s"), 7, "item")
    apply_override(data, ("imu", "gyro", "bias_dph", 2), 9, "item")
    assert data["motion"][1]["duration_s"] == 7
    assert data["imu"]["gyro"]["bias_dph"] == [1, 2, 9]


@pytest.mark.parametrize(
    ("path", "message"),
    [
        (("motion", 5, "x"), "index 5 is out of range (motion has 2 items)"),
        (("motion", "x"), "motion is a list"),
        (("imu", "gyro", "bias_dph", 0, "x"), "imu.gyro.bias_dph[0] is a number"),
        (("nothing", 0), "nothing is not in the scenario"),
    ],
)
def test_apply_override_errors(path, message):
    data, _ = parse_yaml(TEXT, "s.yaml")
    with pytest.raises(InputError) as info:
        apply_override(data, path, 1, "ITEM")
    assert message in str(info.value) and "--set ITEM" in str(info.value)


def test_dump_round_trip():
    data, _ = parse_yaml(TEXT, "s.yaml")
    assert parse_yaml(dump_yaml(data), "d.yaml")[0] == data


_keys = st.from_regex(r"[a-z_][a-z0-9_]{0,8}", fullmatch=True)
_paths = st.lists(st.one_of(_keys, st.integers(0, 99)), min_size=1, max_size=5).filter(
    lambda p: isinstance(p[0], str)
)


@given(_paths, st.integers(-1000, 1000))
def test_format_path_round_trips_through_parse_override(path, value):
    text = format_path(path)
    assert parse_override(f"{text}={value}") == (tuple(path), value)

"""Scenario models and :func:`load_scenario`: every kind of bad input, one message."""

from typing import Annotated, Literal

import numpy as np
import pytest
from pydantic import Field, model_validator

from inins.core.units import DEG, DPH
from inins.exceptions import InputError
from inins.scenario.base import (
    DEFAULT_SEED,
    ScenarioModel,
    ScenarioSection,
    field_doc_problems,
    load_scenario,
    resolve_seed,
    to_si,
    unit_of,
)
from inins.scenario.types import NonNegFloat, PositiveFloat
from inins.scenario.validation import KeyPathError

Vec3 = tuple[float, float, float]  # strict: exactly three numbers (item-level messages)


class Gyro(ScenarioSection):
    """Gyro errors."""

    bias_dph: Vec3 = Field((0.0, 0.0, 0.0), description="Bias per axis [deg/h]")
    arw_deg_rth: NonNegFloat = Field(0.0, description="Angle random walk [deg/sqrt(h)]")


class Imu(ScenarioSection):
    """The IMU."""

    gyro: Gyro = Field(default_factory=Gyro)
    rate_hz: PositiveFloat = Field(200.0, description="Sample rate [Hz]")
    count: int = Field(1, description="Number of units")


class Hold(ScenarioSection):
    """Stay put."""

    kind: Literal["hold"] = Field(description="Step kind")
    duration_s: PositiveFloat = Field(description="Time at rest [s]")


class Rotate(ScenarioSection):
    """Turn."""

    kind: Literal["rotate"] = Field(description="Step kind")
    angle_deg: float = Field(description="Signed angle [deg]")
    duration_s: PositiveFloat = Field(description="Time of the turn [s]")


Step = Annotated[Hold | Rotate, Field(discriminator="kind")]


class Demo(ScenarioModel):
    """A demo scenario."""

    imu: Imu = Field(default_factory=Imu)
    motion: list[Step] = Field(default_factory=list, description="Steps, in order")
    enabled: bool = Field(True, description="Switch")

    @model_validator(mode="after")
    def _cross_check(self):
        for i, step in enumerate(self.motion):
            if isinstance(step, Rotate) and abs(step.angle_deg) > 720:
                raise KeyPathError(("motion", i, "angle_deg"), "at most two turns")
        return self


GOOD = """\
seed: 3
imu:
  gyro:
    bias_dph: [0.1, -0.2, 0.3]
  rate_hz: "400"
motion:
  - {kind: hold, duration_s: 5}
  - kind: rotate
    angle_deg: 180
    duration_s: 10
checks:
  - abs(err.x_dph) < 1
"""


@pytest.fixture
def write(tmp_path):
    def _write(text, name="s.yaml"):
        path = tmp_path / name
        path.write_text(text)
        return path

    return _write


def _error(write, text, overrides=()):
    path = write(text)
    with pytest.raises(InputError) as info:
        load_scenario(Demo, path, list(overrides), path)
    return info.value, str(info.value)


def test_good_scenario(write):
    path = write(GOOD)
    model, text, source = load_scenario(Demo, path, [], path)
    assert model.seed == 3 and model.imu.rate_hz == 400.0
    assert model.imu.gyro.bias_dph == (0.1, -0.2, 0.3)
    assert isinstance(model.motion[1], Rotate)
    assert text == GOOD and source == str(path)
    with pytest.raises(ValueError, match="frozen"):
        model.seed = 4


def test_default_path_is_used(write):
    default = write(GOOD, "default.yaml")
    model, text, source = load_scenario(Demo, None, ["seed=9"], default)
    assert model.seed == 9 and source == str(default)
    assert text.startswith(f"# {default} with overrides:\n#   --set seed=9\n")


@pytest.mark.parametrize(
    ("text", "key", "line", "fragment"),
    [
        (
            "imu:\n  gyro:\n    bias_dph: [1, abc, 3]\n",
            "imu.gyro.bias_dph[1]",
            3,
            "expected a number, got 'abc'",
        ),
        ("imu:\n  gyro:\n    bias_dph: [1, 2]\n", "imu.gyro.bias_dph[2]", 3, "missing list item"),
        (
            "imu:\n  gyro:\n    bias_dph: [1, 2, 3, 4]\n",
            "imu.gyro.bias_dph",
            3,
            "at most 3 items, got 4",
        ),
        (
            "imu:\n  gyro:\n    bias_dps: [1, 2, 3]\n",
            "imu.gyro.bias_dps",
            3,
            "unknown key; did you mean 'bias_dph'?",
        ),
        (
            "motion:\n  - {kind: hold, duration_s: 1}\n  - kind: rotate\n    angle_deg: 9\n"
            "    duration_s: -5\n",
            "motion[1].duration_s",
            5,
            "must be > 0",
        ),
        (
            "motion:\n  - {kind: hold, duration_s: .nan}\n",
            "motion[0].duration_s",
            2,
            "finite number",
        ),
        (
            "motion:\n  - {kind: hold, duration_s: .inf}\n",
            "motion[0].duration_s",
            2,
            "finite number",
        ),
        ("motion:\n  - {kind: hold}\n", "motion[0].duration_s", 2, "required key is missing"),
        (
            "motion:\n  - {kind: spin, duration_s: 1}\n",
            "motion[0].kind",
            2,
            "unknown kind 'spin'; expected one of 'hold', 'rotate'",
        ),
        ("motion:\n  - {duration_s: 1}\n", "motion[0].kind", 2, "required key is missing"),
        ("imu:\n  rate_hz: true\n", "imu.rate_hz", 2, "expected a number, got 'true'"),
        (
            "imu:\n  gyro: {bias_dph: [1, false, 0]}\n",
            "imu.gyro.bias_dph[1]",
            2,
            "expected a number",
        ),
        ("imu:\n  count: 2.5\n", "imu.count", 2, "expected an integer"),
        ("imu: 3\n", "imu", 1, "expected a mapping"),
        ("motion: {a: 1}\n", "motion", 1, "expected a list"),
        ("enabled: maybe\n", "enabled", 1, "expected true or false"),
        ("seed: -1\n", "seed", 1, "must be >= 0"),
        (
            "motion:\n  - kind: rotate\n    angle_deg: 900\n    duration_s: 1\n",
            "motion[0].angle_deg",
            3,
            "at most two turns",
        ),
        ("checks: [abs(x)]\n", "checks[0]", 1, "comparison or a true/false value"),
        ("checks:\n  - x < 1\n  - __import__('os')\n", "checks[1]", 3, "may be called"),
    ],
)
def test_bad_values_name_file_key_line(write, text, key, line, fragment):
    err, message = _error(write, text)
    assert (err.key, err.line) == (key, line)
    assert err.source.endswith("s.yaml")
    assert fragment in message
    assert message.startswith(f"{err.source}:{line}: {key}: ")


def test_several_problems_listed_after_the_first(write):
    _, message = _error(write, "imu:\n  rate_hz: -1\n  count: x\nextra: 1\n")
    first, *more = message.split("\n")
    assert "imu.rate_hz" in first
    assert any("imu.count (line 3)" in m for m in more)
    assert any("extra (line 4): unknown key" in m for m in more)


def test_missing_file_and_directory(tmp_path):
    with pytest.raises(InputError, match="scenario file not found"):
        load_scenario(Demo, tmp_path / "none.yaml", [], None)
    with pytest.raises(InputError, match="is a directory"):
        load_scenario(Demo, tmp_path, [], None)


def test_not_utf8(tmp_path):
    path = tmp_path / "latin.yaml"
    path.write_bytes("seed: 1 # \xe9\n".encode("latin-1"))
    with pytest.raises(InputError, match="not UTF-8"):
        load_scenario(Demo, path, [], None)


def test_override_errors_name_the_option(write):
    err, message = _error(write, GOOD, ["imu.rate_hz=fast"])
    assert err.key == "imu.rate_hz" and err.line is None
    assert "(from --set imu.rate_hz=fast)" in message
    _, message = _error(write, GOOD, ["imu.gyro.bias_dps=1"])
    assert "unknown key" in message and "--set imu.gyro.bias_dps=1" in message


def test_override_applies_and_is_recorded(write):
    path = write(GOOD)
    model, text, _ = load_scenario(
        Demo, path, ["motion.1.angle_deg=-90", "imu.gyro.bias_dph=[0, 0, 1e-3]"], path
    )
    assert model.motion[1].angle_deg == -90
    assert model.imu.gyro.bias_dph == (0.0, 0.0, 0.001)
    assert "--set motion.1.angle_deg=-90" in text and "angle_deg: -90" in text


def test_seed_precedence():
    assert resolve_seed(5, 7) == 5
    assert resolve_seed(None, 7) == 7
    assert resolve_seed(None, None) == DEFAULT_SEED == 0


def test_units():
    assert unit_of("arw_deg_rth")[0] == "deg/sqrt(h)"
    assert unit_of("heading_deg")[0] == "deg"
    assert unit_of("pulse_weight_ug_s")[0] == "ug*s"
    assert unit_of("order") is None
    assert unit_of("temp_sens_dph_per_degc") == ("deg/h/degC", DPH)
    assert unit_of("temp_degc") == ("degC", None)
    assert unit_of("x_per_y") is None
    assert to_si(1.0, "bias_dph") == pytest.approx(DPH)
    np.testing.assert_allclose(to_si([90, 180], "angle_deg"), [90 * DEG, 180 * DEG])
    with pytest.raises(ValueError, match="no lab-unit suffix"):
        to_si(1.0, "order")


def test_json_schema_has_units_and_descriptions():
    schema = Demo.model_json_schema()
    gyro = schema["$defs"]["Gyro"]["properties"]
    assert gyro["bias_dph"]["unit"] == "deg/h"
    assert gyro["arw_deg_rth"]["unit"] == "deg/sqrt(h)"
    assert schema["properties"]["seed"]["description"]
    assert schema["properties"]["checks"]["description"]


def test_field_doc_problems():
    assert field_doc_problems(Demo) == []

    class Bad(ScenarioSection):
        a_s: float = Field(1.0, description="no unit here")
        b: float = 0.0
        c_deg: float = Field(1.0, description="angle (deg)")

    assert field_doc_problems(Bad) == [
        "Bad.a_s: description must state the unit as [s], got 'no unit here'",
        "Bad.b: no description",
    ]

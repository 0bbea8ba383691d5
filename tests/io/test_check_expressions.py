"""Safe evaluation of scenario checks."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from inins.exceptions import InputError
from inins.scenario.checks import CheckSyntaxError, evaluate_checks, parse_check

RESULTS = {
    "beta_x_dph": 0.0012,
    "beta_y_dph": -0.0030,
    "valid": True,
    "na_dph": None,
    "nan_dph": math.nan,
    "np_dph": np.float32(2.0),
    "np_ok": np.bool_(True),
    "count": 3,
    "zero": 0.0,
}
TRUTH = {"beta_x_dph": 0.0016, "beta_y_dph": -0.0034, "zero": 0.0}


def _one(expr):
    return evaluate_checks([expr], RESULTS, TRUTH)[0]


@pytest.mark.parametrize(
    ("expr", "passed", "value"),
    [
        ("abs(err.beta_x_dph) < 0.002", True, 0.0004),
        ("abs(err.beta_x_dph) < 0.0001", False, 0.0004),
        ("beta_y_dph < 0", True, -0.003),
        ("-0.01 < beta_y_dph < 0", True, -0.003),
        ("-0.01 < beta_y_dph < -0.005", False, -0.003),
        ("0.002 > abs(err.beta_x_dph)", True, 0.0004),
        ("truth.beta_x_dph > 0 and valid", True, None),
        ("not valid or count == 3", True, None),
        ("valid", True, True),
        ("np_ok", True, True),
        ("np_dph >= 2", True, 2.0),
        ("max(beta_x_dph, beta_y_dph, 0) <= 0.0012", True, 0.0012),
        ("min(beta_x_dph, beta_y_dph) == beta_y_dph", True, -0.003),
        ("sqrt(beta_x_dph**2 + beta_y_dph**2) < 0.01", True, None),
        ("2 * count - 1 != 5", False, 5.0),
        ("+count / 3 == 1", True, 1.0),
        ("True", True, None),
    ],
)
def test_evaluation(expr, passed, value):
    entry = _one(expr)
    assert entry["name"] == expr
    assert entry["passed"] is passed
    if value is None or isinstance(value, bool):
        assert entry["value"] is value or value is None
    else:
        assert entry["value"] == pytest.approx(value)
    assert "reason" not in entry


@pytest.mark.parametrize(
    ("expr", "reason"),
    [
        ("na_dph < 1", "na_dph is not available (method not applicable)"),
        ("nan_dph < 1", "nan_dph is NaN"),
        ("err.valid", "no truth value for valid"),
        ("1 / zero > 0", "cannot evaluate: float division by zero"),
        ("sqrt(beta_y_dph) > 0", "cannot evaluate: math domain error"),
        ("10 ** 400 > 1", "cannot evaluate: number too large"),
    ],
)
def test_fails_with_reason(expr, reason):
    entry = _one(expr)
    assert entry["passed"] is False and entry["reason"] == reason


@pytest.mark.parametrize(
    ("expr", "fragment"),
    [
        ("", "empty check"),
        ("abs(x) <", "invalid expression"),
        ("x < 1; y", "invalid expression"),
        ("__import__('os').system('true')", "may be called"),
        ("open('f') == 1", "only abs, min, max and sqrt may be called"),
        ("x.y < 1", "only err.NAME and truth.NAME"),
        ("err.x.y < 1", "only err.NAME and truth.NAME"),
        ("err < 1", "'err' cannot be used on its own"),
        ("abs < 1", "'abs' cannot be used on its own"),
        ("abs(x, y) < 1", "abs() takes one argument"),
        ("min(x) < 1", "min() takes two or more arguments"),
        ("abs(x=1) < 1", "abs() takes one argument"),
        ("max(*x) < 1", "takes two or more"),
        ("'a' < x", "only numbers"),
        ("x if y else z", "is not allowed"),
        ("[x][0] < 1", "is not allowed"),
        ("x in (1, 2)", "is not allowed"),
        ("x // 2 < 1", "is not allowed"),
        ("lambda: 1", "is not allowed"),
        ("abs(err.x)", "a comparison or a true/false value"),
        ("x + 1", "a comparison or a true/false value"),
        ("x" * 1001, "longer than"),
    ],
)
def test_rejected_expressions(expr, fragment):
    with pytest.raises(CheckSyntaxError) as info:
        parse_check(expr)
    assert fragment in str(info.value)
    with pytest.raises(InputError) as info:
        evaluate_checks(["count > 0", expr], RESULTS, TRUTH)
    assert info.value.key == "checks[1]"


@pytest.mark.parametrize(
    ("expr", "fragment"),
    [
        ("beta_x_dps < 1", "unknown name 'beta_x_dps' in a check; did you mean 'beta_x_dph'?"),
        ("truth.nope < 1", "unknown name 'truth.nope'"),
        ("err.nope < 1", "unknown name 'err.nope'"),
    ],
)
def test_unknown_names_are_bad_input(expr, fragment):
    with pytest.raises(InputError) as info:
        evaluate_checks([expr], RESULTS, TRUTH)
    assert info.value.key == "checks[0]" and fragment in str(info.value)


def test_plain_name_must_be_a_result():
    with pytest.raises(InputError, match="unknown name"):
        evaluate_checks(["x > 0"], {}, {"x": 1.0})


def test_non_boolean_name_is_bad_input():
    with pytest.raises(InputError, match="must be true or false"):
        evaluate_checks(["count"], RESULTS, TRUTH)


def test_no_checks():
    assert evaluate_checks([], RESULTS, TRUTH) == []


@settings(max_examples=300, deadline=None)
@given(st.text(alphabet="abxyz_.()*+-/<>=!01 2,.enotadrul", max_size=40))
def test_fuzz_parse_raises_only_check_syntax_errors(expr):
    try:
        parse_check(expr)
    except CheckSyntaxError:
        return
    names = {"a", "b", "x", "y", "z", "ab", "xy"}
    try:
        checks = evaluate_checks([expr], dict.fromkeys(names, 1.0), {})
    except InputError:
        return
    assert len(checks) == 1 and checks[0]["name"] == expr
    assert isinstance(checks[0]["passed"], bool)

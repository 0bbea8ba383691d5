"""Exit codes and messages: bad input (2), failures (3), interrupts, no partial files."""

import pytest


def _scenario(tmp_path, text):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    return path


BAD_FILES = [
    # (scenario text, expected fragments of the message)
    ("name: x\nduration_s: [\n", ["bad.yaml:3", "YAML syntax error"]),
    (
        "name: x\nduraton_s: 5\n",
        ["bad.yaml:2", "duraton_s", "unknown key", "did you mean 'duration_s'"],
    ),
    (
        "name: x\nbias_dph: [1, abc, 3]\n",
        ["bad.yaml:2", "bias_dph[1]", "expected a number", "'abc'"],
    ),
    ("duration_s: 5\n", ["bad.yaml", "name", "required key is missing"]),
    ("name: x\nrate_hz: .nan\n", ["bad.yaml:2", "rate_hz", "finite number"]),
    ("name: x\nduration_s: -5\n", ["bad.yaml:2", "duration_s", "must be > 0", "got -5"]),
    ("name: x\nrate_hz: true\n", ["bad.yaml:2", "rate_hz", "expected a number"]),
    ("name: x\nname: y\n", ["bad.yaml:2", "duplicate key 'name'", "line 1"]),
    ("- name\n", ["bad.yaml:1", "mapping"]),
    (
        "name: x\nchecks:\n  - n_samples > 0\n  - abs(err.bias_x_dph <\n",
        ["bad.yaml:4", "checks[1]", "invalid expression"],
    ),
    (
        "name: x\nchecks:\n  - n_samples > 0\n  - bias_x_dps < 1\n",
        ["bad.yaml:4", "checks[1]", "unknown name 'bias_x_dps'", "did you mean 'bias_x_dph'"],
    ),
]


@pytest.mark.parametrize(("text", "fragments"), BAD_FILES)
def test_bad_scenario_exits_2_with_one_clear_message(invoke, tmp_path, text, fragments):
    result = invoke("fake", _scenario(tmp_path, text), "-o", tmp_path / "out")
    assert result.exit_code == 2, result.output
    message = result.stderr
    assert message.startswith("inins fake: error: ")
    for fragment in fragments:
        assert fragment in message
    assert "Traceback" not in result.output
    assert not (tmp_path / "out" / "summary.json").exists()
    assert not list((tmp_path / "out").glob(".*partial*")) if (tmp_path / "out").exists() else True


def test_missing_scenario_file(invoke, tmp_path):
    result = invoke("fake", tmp_path / "nope.yaml", "-o", tmp_path)
    assert result.exit_code == 2
    assert "nope.yaml: scenario file not found" in result.stderr


@pytest.mark.parametrize(
    ("override", "fragments"),
    [
        ("duration_s", ["--set expects KEY.PATH=VALUE", "'duration_s'"]),
        ("=5", ["--set expects KEY.PATH=VALUE"]),
        ("a..b=1", ["--set expects KEY.PATH=VALUE"]),
        ("duration_s=[1, 2", ["--set duration_s=[1, 2", "not valid YAML"]),
        ("duration_s=abc", ["duration_s", "expected a number", "from --set duration_s=abc"]),
        ("bias_dph.5=1", ["index 5 is out of range", "bias_dph has 3 items"]),
        ("nosuch.key=1", ["nosuch", "unknown key", "from --set nosuch.key=1"]),
        ("name.x=1", ["name is text", "not a mapping"]),
    ],
)
def test_bad_override_exits_2(invoke, tmp_path, override, fragments):
    result = invoke("fake", "-o", tmp_path, "--set", override)
    assert result.exit_code == 2, result.output
    for fragment in fragments:
        assert fragment in result.stderr
    assert "Traceback" not in result.output


def test_negative_seed_is_a_usage_error(invoke, tmp_path):
    result = invoke("fake", "-o", tmp_path, "--seed", "-1")
    assert result.exit_code == 2


def test_input_error_from_the_method(invoke, tmp_path):
    result = invoke("fake", "-o", tmp_path, "--set", "fail=input")
    assert result.exit_code == 2
    assert result.stderr.strip() == (
        "inins fake: error: log.csv: column gyro_x: the data make no sense"
    )


def test_debug_shows_traceback(invoke, tmp_path):
    result = invoke("fake", "-o", tmp_path, "--set", "duration_s=-1", "--debug")
    assert result.exit_code == 2
    assert "Traceback" in result.stderr and "must be > 0" in result.stderr


def test_internal_error_exits_3_without_traceback(invoke, tmp_path):
    result = invoke("fake", "-o", tmp_path, "--set", "fail=run")
    assert result.exit_code == 3
    assert "internal error: RuntimeError: boom (run)" in result.stderr
    assert "--debug" in result.stderr and "Traceback" not in result.stderr


def _snapshot(outdir):
    return {p.name: p.read_bytes() for p in outdir.iterdir()}


@pytest.mark.parametrize(
    ("command", "fail", "code"),
    [("fake", "run", 3), ("fake", "interrupt", 130), ("fake-stream", "late", 3)],
)
def test_failed_run_keeps_earlier_results(invoke, tmp_path, command, fail, code):
    out = tmp_path / "out"
    first = invoke(command, "-o", out, "--set", "duration_s=300", "--set", "checks=[]")
    assert first.exit_code == 0, first.output
    before = _snapshot(out)
    result = invoke(command, "-o", out, "--set", "duration_s=300", "--set", f"fail={fail}")
    assert result.exit_code == code, result.output
    assert _snapshot(out) == before  # nothing replaced, no partial file left
    if fail == "interrupt":
        assert "interrupted" in result.stderr


def test_interrupt_on_first_run_leaves_nothing(invoke, tmp_path):
    result = invoke("fake", "-o", tmp_path / "out", "--set", "fail=interrupt")
    assert result.exit_code == 130
    assert list((tmp_path / "out").iterdir()) == []


def test_command_not_yet_available(invoke, tmp_path):
    result = invoke("fake-todo", "-o", tmp_path)
    assert result.exit_code == 4
    assert result.stderr.strip() == "inins fake-todo: not yet available in this version"


def test_missing_shipped_scenario(invoke, tmp_path, configs):
    (configs / "fake" / "default.yaml").unlink()
    result = invoke("fake", "-o", tmp_path)
    assert result.exit_code == 2
    assert "no shipped scenario 'default' for fake" in result.stderr


def test_outdir_that_is_a_file(invoke, tmp_path):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    result = invoke("fake", "-o", blocker / "sub")
    assert result.exit_code == 2
    assert "cannot create the output directory" in result.stderr

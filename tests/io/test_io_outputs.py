"""Atomic files, summary.json, the text report, shipped-scenario lookup."""

import json
import math
import os
import signal

import numpy as np
import pytest

from inins.exceptions import InputError
from inins.io import resources
from inins.io.atomic import AtomicFile, AtomicGroup, deferred_interrupts, write_text_atomic
from inins.io.report import build_report
from inins.io.summary import build_summary, json_scalar, summary_text, write_summary
from inins.results import format_table, format_value


def test_atomic_file_commit_and_discard(tmp_path):
    target = tmp_path / "a.txt"
    write_text_atomic(target, "one")
    with pytest.raises(RuntimeError), AtomicFile(target) as f:
        f.tmp.write_text("two")
        raise RuntimeError
    assert target.read_text() == "one"
    assert [p.name for p in tmp_path.iterdir()] == ["a.txt"]
    assert AtomicFile(target).tmp.name == f".a.txt.partial-{os.getpid()}"


def test_atomic_group_commits_all_or_nothing(tmp_path):
    names = ("r.h5", "r.txt", "summary.json")
    with AtomicGroup(tmp_path, names) as group:
        for name in names:
            group[name].tmp.write_text(f"first {name}")
    with pytest.raises(KeyboardInterrupt), AtomicGroup(tmp_path, names) as group:
        group["r.h5"].tmp.write_text("second")
        raise KeyboardInterrupt
    assert sorted(p.read_text() for p in tmp_path.iterdir()) == [
        f"first {n}" for n in sorted(names)
    ]


def test_a_stop_request_swallowed_by_a_callback_still_commits_nothing(tmp_path, monkeypatch):
    # SIGTERM's KeyboardInterrupt raised inside a C callback (numba compiling) is printed
    # and dropped; the run goes on to its commit, which must refuse
    from inins.io import atomic

    monkeypatch.setattr(atomic, "_stop_requested", None)
    names = ("r.h5", "summary.json")
    group = AtomicGroup(tmp_path, names)
    for name in names:
        group[name].tmp.write_text(name)
    atomic.request_stop(signal.SIGTERM)
    with pytest.raises(KeyboardInterrupt):
        group.commit()
    assert list(tmp_path.iterdir()) == []


def test_atomic_group_missing_file_discards_the_rest(tmp_path):
    group = AtomicGroup(tmp_path, ("a", "b"))
    group["b"].tmp.write_text("b")
    with pytest.raises(FileNotFoundError):
        group.commit()
    assert list(tmp_path.iterdir()) == []


def test_deferred_interrupts_deliver_after_block():
    # A background job of a non-interactive shell (as CI may run us) starts with SIGINT
    # ignored, and deferred_interrupts re-delivers through the handler it found: set
    # Python's default handler for this test.
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    seen = []
    try:
        with pytest.raises(KeyboardInterrupt):
            with deferred_interrupts():
                signal.raise_signal(signal.SIGINT)
                seen.append("block finished")
    finally:
        signal.signal(signal.SIGINT, previous)
    assert seen == ["block finished"]


def test_deferred_interrupts_keep_an_ignored_sigint_ignored():
    previous = signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        with deferred_interrupts():
            signal.raise_signal(signal.SIGINT)
        assert signal.getsignal(signal.SIGINT) is signal.SIG_IGN
    finally:
        signal.signal(signal.SIGINT, previous)


def test_json_scalar():
    assert json_scalar(np.float32(1.5)) == 1.5 and type(json_scalar(np.float32(1.5))) is float
    assert json_scalar(np.int64(3)) == 3 and type(json_scalar(np.int64(3))) is int
    assert json_scalar(np.bool_(True)) is True
    assert json_scalar(math.nan) is None and json_scalar(-math.inf) is None
    assert json_scalar(None) is None
    with pytest.raises(TypeError, match="must be a number"):
        json_scalar(np.zeros(3), "x")
    with pytest.raises(TypeError):
        json_scalar("text")


def test_summary_shape_and_file(tmp_path):
    checks = [
        {"name": "x < 1", "passed": True, "value": np.float64(0.5)},
        {"name": "y < 1", "passed": False, "value": None, "reason": "y is NaN"},
    ]
    summary = build_summary(
        "demo",
        "0.1.0",
        "s.yaml",
        np.int64(4),
        {"x": np.float64(0.5), "y": math.nan},
        {"x": 0.4},
        checks,
    )
    assert list(summary) == [
        "command",
        "inins_version",
        "scenario",
        "seed",
        "results",
        "truth",
        "checks",
        "passed",
    ]
    assert summary["results"] == {"x": 0.5, "y": None} and summary["passed"] is False
    write_summary(tmp_path / "summary.json", summary)
    assert json.loads((tmp_path / "summary.json").read_text()) == summary
    assert ": NaN" not in summary_text(summary)
    assert build_summary("d", "v", "s", 0, {}, {}, [])["passed"] is True


def test_format_table():
    text = format_table(
        [("beta_x", 0.0016123456, None), ("beta_y", -0.0034, 12)],
        headers=("gyro", "estimate", "truth"),
        units=("", "deg/h", "deg/h"),
    )
    lines = text.split("\n")
    assert lines[0].split() == ["gyro", "estimate", "truth"]
    assert lines[1].split() == ["[deg/h]", "[deg/h]"]
    assert set(lines[2]) <= {"-", " "}
    assert lines[3].split() == ["beta_x", "0.00161235", "n/a"]
    assert len({len(line) for line in lines[:2] + lines[3:]}) == 1  # aligned
    assert lines[4].endswith("   12")  # numbers right-aligned
    with pytest.raises(ValueError, match="3 cells"):
        format_table([(1, 2)], headers=("a", "b", "c"))


def test_format_value():
    assert format_value(None) == "n/a" and format_value(True) == "yes"
    assert format_value(math.nan) == "nan" and format_value(np.float32(0.5)) == "0.5"
    assert format_value(1234.5678, ".2f") == "1234.57" and format_value(7) == "7"


def test_report():
    prov = {
        "command": "demo",
        "inins_version": "0.1.0",
        "created_utc": "2025-01-01T00:00:00Z",
        "scenario_source": "configs/demo/default.yaml",
        "seed": 3,
        "scenario_overrides": ["a=1"],
    }
    checks = [
        {"name": "x < 1", "passed": True, "value": 0.5},
        {"name": "y < 1", "passed": False, "value": None, "reason": "y is NaN"},
    ]
    text = build_report(prov, "Body\n", ("careful",), checks)
    for part in (
        "inins demo report",
        "2025-01-01T00:00:00Z",
        "configs/demo/default.yaml",
        "--set a=1",
        "seed      3",
        "Body",
        "- careful",
        "FAIL (y is NaN)",
        "FAILED: 1 of 2 checks passed",
    ):
        assert part in text
    assert "\x1b" not in text and text.endswith("\n")
    assert "Checks" not in build_report(prov, "", (), ())


def test_config_path(tmp_path, monkeypatch):
    (tmp_path / "cmd").mkdir()
    (tmp_path / "cmd" / "default.yaml").write_text("a: 1\n")
    (tmp_path / "cmd" / "paper-case-2.yaml").write_text("a: 2\n")
    monkeypatch.setattr(resources, "configs_root", lambda: tmp_path)
    assert resources.config_path("cmd") == tmp_path / "cmd" / "default.yaml"
    assert resources.available_configs("cmd") == ["default", "paper-case-2"]
    assert resources.display_name(tmp_path / "cmd" / "default.yaml") == "configs/cmd/default.yaml"
    with pytest.raises(InputError, match="available: default, paper-case-2"):
        resources.config_path("cmd", "nope")


def test_configs_root_in_source_checkout():
    root = resources.configs_root()
    assert root.name == "configs"
    assert root.parent == resources._PACKAGE_DIR.parent or root.parent.name == "inins"

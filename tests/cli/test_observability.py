"""``inins observability`` end to end: the shipped scenarios reproduce the classic
results (stationary alignment rank 9, paper 002's one-baseline result and its
manoeuvre), segments cut from a simulate-table file, and bad input."""

import json

import pytest
from typer.testing import CliRunner

from inins.cli import app
from tests.helpers import CONFIGS


def run(*args):
    result = CliRunner().invoke(app, ["observability", *map(str, args)])
    return result


def summary(path):
    return json.loads((path / "summary.json").read_text())["results"]


def test_stationary_alignment_at_one_heading_has_rank_9(tmp_path):
    result = run(CONFIGS / "observability" / "stationary.yaml", "-o", tmp_path)
    assert result.exit_code == 0, result.output
    r = summary(tmp_path)
    assert (r["rank"], r["n_states"], r["n_unobservable"], r["gramian_rank"]) == (9, 12, 3, 9)
    for state in ("dv_N", "dv_E", "dv_D", "ba_z"):
        assert r[f"observable_{state}"] is True, state
    for state in ("phi_N", "phi_E", "phi_D", "ba_x", "ba_y"):
        assert r[f"observable_{state}"] is False, state
    # the heading error never leaves its gyrocompass floor: bg_E is not separable
    assert r["sigma_ratio_phi_D"] > 0.01
    report = (tmp_path / "observability.txt").read_text()
    assert report.count("\n  phi_") == 3  # three combinations written out


def test_a_second_heading_makes_all_12_observable(tmp_path):
    result = run(CONFIGS / "observability" / "stationary-two-headings.yaml", "-o", tmp_path)
    assert result.exit_code == 0, result.output
    r = summary(tmp_path)
    assert r["rank"] == 12 and all(r[f"observable_{s}"] for s in ("phi_D", "ba_x", "bg_y"))


def test_paper002_level_flight_then_the_manoeuvre(tmp_path):
    """002: one baseline along body y in level flight leaves pitch and the x accelerometer
    bias unobservable (their sigma does not shrink); the turn makes all 12 observable."""
    assert (
        run(
            CONFIGS / "observability" / "paper002-level-flight.yaml", "-o", tmp_path / "level"
        ).exit_code
        == 0
    )
    assert run(CONFIGS / "observability" / "default.yaml", "-o", tmp_path / "turn").exit_code == 0
    level, turn = summary(tmp_path / "level"), summary(tmp_path / "turn")
    assert level["rank"] == 11 and turn["rank"] == 12
    assert not level["observable_phi_E"] and not level["observable_ba_x"]
    assert level["sigma_ratio_ba_x"] > 0.99
    assert turn["sigma_ratio_ba_x"] < 0.05 and turn["sigma_ratio_phi_E"] < 0.01
    combination = (tmp_path / "level" / "observability.txt").read_text()
    assert "phi_E - 9.79" in combination  # pitch paired with ba_x by g


def test_segments_cut_from_a_simulate_table_file(tmp_path):
    """A table record turning 180 deg in yaw between two holds gives two headings: the
    stationary 12-state alignment becomes fully observable."""
    sim = CliRunner().invoke(
        app,
        [
            "simulate-table",
            str(CONFIGS / "simulate-table" / "paper000-case1-no-disturbance.yaml"),
            "-o",
            str(tmp_path / "sim"),
            "--set",
            "imu.sample_rate_hz=20",
            "--set",
            "output.truth_rate_hz=2",
        ],
    )
    assert sim.exit_code == 0, sim.output
    scenario = tmp_path / "obs.yaml"
    scenario.write_text(
        "model: align12\n"
        "measurements: [{kind: velocity, sigma: 0.001}]\n"
        f"trajectory: {{file: {tmp_path / 'sim' / 'simulate-table.h5'}}}\n"
        "covariance: false\n"
    )
    result = run(scenario, "-o", tmp_path / "obs")
    assert result.exit_code == 0, result.output
    r = summary(tmp_path / "obs")
    assert r["rank"] == 12 and r["segments"] > 2


@pytest.mark.parametrize(
    ("override", "where"),
    [
        (
            "measurements=[{kind: dd_phase, sigma: 0.01, baseline_b_m: [0, 1, 0]}]",
            "measurements[0].kind",
        ),
        ("model=ekf99", "model"),
        ("segments.0.duration_s=0", "segments[0].duration_s"),
    ],
)
def test_bad_input_names_the_key(tmp_path, override, where):
    result = run(CONFIGS / "observability" / "stationary.yaml", "-o", tmp_path, "--set", override)
    assert result.exit_code == 2, result.output
    assert where in result.stderr
    assert list(tmp_path.iterdir()) == []


def test_zero_baseline_is_bad_input(tmp_path):
    result = run(
        CONFIGS / "observability" / "default.yaml",
        "-o",
        tmp_path,
        "--set",
        "measurements.1.baseline_b_m=[0, 0, 0]",
    )
    assert result.exit_code == 2, result.output
    assert "measurements[1].baseline_b_m" in result.stderr

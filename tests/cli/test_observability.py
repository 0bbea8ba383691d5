"""``inins observability`` end to end: the shipped scenarios reproduce the classic
results (stationary alignment rank 9, paper 002's one-baseline result and its
manoeuvre), segments cut from a simulate-table file, and bad input."""

import json

import numpy as np
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


def test_ekf26_along_the_paper003_flight_turn_by_turn():
    """EKF2's 26 states along run-ekf's bank-turn flight (configs/paper003/ekf2-fb.yaml):
    full rank already after the take-off, but the degree of observability shows which
    misalignments the turns identify: none before the first turn, mg_yz and mg_zy (the
    symmetric part that makes heading error grow, 003) in the first, right turn, mg_xy
    and mg_zx in the second, left one; ma_zy never (a coordinated turn keeps the body
    y specific force near zero) and the z gyro bias hardly (003's EKF1 confusion)."""
    from inins.commands import observability
    from inins.observability.segments import turns
    from inins.scenario.observability import ObservabilityScenario
    from tests.helpers import shipped

    scenario = shipped(ObservabilityScenario, "observability/ekf26-bank-turns.yaml")
    result = observability.run(scenario, 0)
    r = result.results
    spans = turns(observability.build_segments(scenario, None))
    assert r["rank"] == 26 and r["full_rank_after_s"] < spans[0][0]
    assert len(spans) == 6
    names = result.attrs["observability"]["states"]
    time = result.datasets["covariance/time"].data
    sigma = result.datasets["covariance/sigma"].data

    def ratio(name, t):
        i = names.index(name)
        return sigma[np.searchsorted(time, t), i] / sigma[0, i]

    before, turn1, turn2 = spans[0][0], spans[0][1], spans[1][1]
    for name in ("mg_xy", "mg_xz", "mg_yz", "mg_zx", "mg_zy"):
        assert ratio(name, before) > 0.95, name
    for name in ("mg_yz", "mg_zy"):
        assert ratio(name, turn1) < 0.4, name
    for name in ("mg_xy", "mg_zx"):
        assert ratio(name, turn1) > 0.8 and ratio(name, turn2) < 0.45, name
    assert r["sigma_ratio_ma_zy"] > 0.99 and r["sigma_ratio_bg_z"] > 0.95

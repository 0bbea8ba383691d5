"""Sweep files expanded into points, and the bad input refused before any run."""

import json

import pytest

from inins.exceptions import InputError
from inins.scenario.yaml_source import parse_override
from inins.sweep.plan import load_sweep, override
from tests.sweep.conftest import TINY_SIMULATE, write_sweep


def test_grid_zip_and_seeds_expand_in_order(tmp_path):
    path = write_sweep(
        tmp_path,
        command="simulate-table",
        base=str(TINY_SIMULATE),
        grid={
            "motion.0.duration_s": [1, 2],
            "imu.gyro.arw_deg_rth": {"start": 0.0, "stop": 0.02, "step": 0.01},
        },
        zip=[{"site.lat_deg": [10.0, 20.0], "site.lon_deg": [100.0, 110.0]}],
        seeds={"start": 7, "count": 2},
    )
    plan = load_sweep(path)
    assert plan.size == 2 * 3 * 2 * 2
    points = list(plan.points())
    assert [p.index for p in points] == list(range(24))
    assert plan.axis_keys == (
        "motion.0.duration_s",
        "imu.gyro.arw_deg_rth",
        "site.lat_deg",
        "site.lon_deg",
    )
    assert points[0].axis_values == (1, 0.0, 10.0, 100.0) and points[0].seed == 7
    assert points[1].axis_values == (1, 0.0, 10.0, 100.0) and points[1].seed == 8
    # zip keys move together, the range is inclusive, the first grid key is slowest
    assert points[2].axis_values == (1, 0.0, 20.0, 110.0)
    assert points[4].axis_values == (1, 0.01, 10.0, 100.0)
    assert points[-1].axis_values == (2, 0.02, 20.0, 110.0) and points[-1].seed == 8
    assert len({p.key for p in points}) == 24


def test_linspace_range_and_seed_forms(tmp_path):
    path = write_sweep(
        tmp_path,
        command="simulate-table",
        base=str(TINY_SIMULATE),
        grid={"motion.0.duration_s": {"start": 1.0, "stop": 2.0, "num": 5}},
        seeds=3,
    )
    plan = load_sweep(path)
    assert [v[0] for v in plan.axes[0].values] == [1.0, 1.25, 1.5, 1.75, 2.0]
    assert plan.seeds == (0, 1, 2)


@pytest.mark.parametrize("value", [0.1, 1e-7, 123456.789e-12, -0.0, 3, [1.5, -2.25e-9, 0.0]])
def test_override_reads_back_to_the_same_value(value):
    key, parsed = parse_override(override("imu.gyro.bias_dph", value))
    assert key == ("imu", "gyro", "bias_dph")
    assert json.dumps(parsed) == json.dumps(value)
    assert parsed == value


def _error(tmp_path, **content):
    path = write_sweep(tmp_path, **content)
    with pytest.raises(InputError) as info:
        load_sweep(path, max_points=content.pop("_max", 100_000))
    return str(info.value)


def test_unknown_key_names_the_axis(tmp_path):
    msg = _error(
        tmp_path,
        command="simulate-table",
        base=str(TINY_SIMULATE),
        grid={"imu.gyro.bias_dhp": [1, 2]},
    )
    assert "grid.imu.gyro.bias_dhp" in msg and "bias_dhp" in msg


def test_wrong_value_type_names_the_axis_and_value(tmp_path):
    msg = _error(
        tmp_path,
        command="simulate-table",
        base=str(TINY_SIMULATE),
        grid={"motion.0.duration_s": [1, "long"]},
    )
    assert "grid.motion.0.duration_s" in msg and '"long"' in msg


def test_out_of_range_value_in_a_zip_group(tmp_path):
    msg = _error(
        tmp_path,
        command="simulate-table",
        base=str(TINY_SIMULATE),
        zip=[{"motion.0.duration_s": [1, -1], "imu.sample_rate_hz": [10, 20]}],
    )
    assert "zip[0]" in msg and "must be >" in msg


def test_too_many_points(tmp_path):
    path = write_sweep(
        tmp_path,
        command="simulate-table",
        base=str(TINY_SIMULATE),
        grid={"motion.0.duration_s": list(range(1, 101))},
        seeds=1001,
    )
    with pytest.raises(InputError, match=r"100,100 points, more than --max-points 100,000"):
        load_sweep(path)


@pytest.mark.parametrize(
    ("content", "expected"),
    [
        ({"command": "simulate-tabel"}, "unknown command 'simulate-tabel'"),
        ({"command": "simulate-table", "grid": {"motion.0.duration_s": []}}, "at least one"),
        (
            {"command": "simulate-table", "zip": [{"a.b": [1, 2], "c.d": [1]}]},
            "equal length",
        ),
        ({"command": "simulate-table", "seeds": 0}, "N >= 1"),
        ({"command": "simulate-table", "grid": {"x": {"start": 0, "stop": 1}}}, "step and num"),
        ({"command": "simulate-table", "grdi": {}}, "grdi"),
    ],
)
def test_bad_sweep_files(tmp_path, content, expected):
    assert expected in _error(tmp_path, **content)


@pytest.mark.parametrize(
    ("name", "points"),
    [("hold-time-x-mount-rotation.yaml", 48), ("paper000-case1-monte-carlo.yaml", 500)],
)
def test_shipped_sweeps_load(name, points):
    from pathlib import Path

    plan = load_sweep(Path(__file__).parents[2] / "configs" / "sweep" / name)
    assert plan.size == points and plan.command == "calibrate-bias"

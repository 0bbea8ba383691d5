"""Units and axes of an IMU log checked against its GNSS solution before any filter
(inins.io.imu_units): on the lc-drive car drive (data/lc-drive, BSD-3-Clause: a MEMS IMU
in g and deg/s whose body axes are -x, y, -z of the IMU, and its RTK solution) and the
FOG/MEMS drive, every mistake of units or axes a user makes is refused with the likely
mistake named, and the right map passes."""

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from inins.exceptions import InputError
from inins.io import imu_units
from inins.io import solution_files as sf

DATA = Path(__file__).resolve().parents[2] / "data"
RIGHT = ("-x", "y", "-z")


@pytest.fixture(scope="module")
def drive():
    """The lc-drive solution and its IMU in the IMU's own axes (map x, y, z), SI."""
    sol = sf.read_rtklib_pos(DATA / "lc-drive" / "gnss_1934_sf.pos.gz")
    raw = sf.read_imu_rates_csv(
        DATA / "lc-drive" / "imu_1934.csv.gz", (0, 1, 2), (3, 4, 5), 6, 1e-3, "g", "dps",
        ("x", "y", "z"),
    )  # fmt: skip
    return sol, raw


def _mapped(raw, axes, gyro=None, accel=None):
    """The raw IMU through an axis map (as the readers apply it)."""
    index = ["xyz".index(a[-1]) for a in axes]
    sign = np.array([-1.0 if a.startswith("-") else 1.0 for a in axes])
    g = raw.gyro if gyro is None else gyro
    a = raw.accel if accel is None else accel
    return replace(raw, gyro=g[:, index] * sign, accel=a[:, index] * sign)


def _check(sol, imu, axes, **kw):
    imu_units.check_against_gnss(imu, sol, axes, gyro_bias_sigma_dps=0.1, **kw)


def test_the_right_units_and_axes_pass(drive):
    sol, raw = drive
    _check(sol, _mapped(raw, RIGHT), RIGHT, forward_needed=True)


def test_the_fog_mems_drive_passes_and_its_axes_are_checked():
    path = DATA / "transfer_align_fog_mems.mat"
    cols = dict(time=9, lat=6, lon=7, height=8, vel_e=3, vel_n=4, vel_u=5)
    sol = sf.read_solution_mat(path, "fogavp", cols, "rad", 0.05, 0.02)
    for axes, ok in (((("y", "x", "-z")), True), (("x", "y", "z"), False)):
        imu = sf.read_imu_increments_mat(path, "mimu", (0, 1, 2), (3, 4, 5), 6, axes)
        if ok:
            _check(sol, imu, axes, offset_s=-0.105)
            continue
        with pytest.raises(InputError, match=r"gravity at rest reads down along body -z"):
            _check(sol, imu, axes, offset_s=-0.105)


@pytest.mark.parametrize(
    ("scale_accel", "scale_gyro", "match"),
    [
        (1.0 / 9.80665, 1.0, r"reads 1\.01\d m/s\^2 .* is the accelerometer in g declared m/s\^2"),
        (9.80665, 1.0, r"accelerometer in m/s\^2 declared g"),
        (
            1.0,
            180.0 / math.pi,
            r"at rest reads 10\.\d+ deg/s .* gyro in deg/s declared",
        ),
        (1.0, math.pi / 180.0, r"turn rate about z is 0\.017\d times .* rad/s declared deg/s"),
    ],
)
def test_unit_mistakes_are_named(drive, scale_accel, scale_gyro, match):
    """g read as m/s^2 reads 1.013 m/s^2 at rest (9.93 m/s^2 against 9.797 of local
    gravity); deg/s read as rad/s turns a 0.19 deg/s bias into 10.6 "deg/s"; rad/s read
    as deg/s is invisible at rest and shows as turns 57 times too slow."""
    sol, raw = drive
    imu = _mapped(raw, RIGHT, raw.gyro * scale_gyro, raw.accel * scale_accel)
    with pytest.raises(InputError, match=match) as err:
        _check(sol, imu, RIGHT)
    assert "imu_1934.csv.gz" in str(err.value)


def test_gravity_removed_is_named(drive):
    sol, raw = drive
    imu = _mapped(raw, RIGHT)
    still = imu.accel.mean(axis=0)
    with pytest.raises(InputError, match="gravity removed"):
        _check(sol, replace(imu, accel=imu.accel - still), RIGHT)


@pytest.mark.parametrize(
    ("axes", "forward", "match"),
    [
        (("x", "y", "z"), False, r"down along body -z .* axes: \[-x, y, -z\] puts z down"),
        (("y", "-x", "z"), False, r"down along body -z .* axes: \[-x, y, -z\]"),
        (("y", "x", "-z"), True, r"follows accel -y .* axes: \[-x, y, -z\] puts it forward"),
        (("x", "-y", "-z"), True, r"follows accel -x .* axes: \[-x, y, -z\] puts it forward"),
    ],
)
def test_a_wrong_axis_map_is_named_with_the_right_one(drive, axes, forward, match):
    """z up is caught by gravity at rest, the forward axis by the along-track acceleration
    (only where NHC or the odometer need it); the suggested map is the right one."""
    sol, raw = drive
    with pytest.raises(InputError, match=match):
        _check(sol, _mapped(raw, axes), axes, forward_needed=forward)


def test_a_forward_axis_off_by_90_deg_passes_without_nhc(drive):
    """Without vehicle constraints the filter takes its heading from the motion, so a
    body x across the car is no mistake (the outage drift is that of the right map)."""
    sol, raw = drive
    _check(sol, _mapped(raw, ("y", "x", "-z")), ("y", "x", "-z"), forward_needed=False)


def test_gyro_columns_in_another_order_than_the_accelerometers(drive):
    sol, raw = drive
    imu = _mapped(raw, RIGHT)
    with pytest.raises(InputError, match=r"follows gyro [+-]y .* another order or sign"):
        _check(sol, replace(imu, gyro=imu.gyro[:, [0, 2, 1]]), RIGHT)


def test_a_drive_without_turns_leaves_the_turn_checks_undone(drive):
    """The first 20 s stand still: no course rate, so a gyro 57 times too slow passes the
    turn check (nothing refused on a guess) while gravity is still checked."""
    sol, raw = drive
    first = sol.select(sol.time < sol.time[0] + 20.0)
    imu = _mapped(raw, RIGHT)
    _check(first, replace(imu, gyro=imu.gyro * math.pi / 180.0), RIGHT)
    with pytest.raises(InputError, match="accelerometer in g declared"):
        _check(first, replace(imu, accel=imu.accel / 9.80665), RIGHT)

"""Epoch streams of run-ekf: the GNSS layer's simulation seen through the filter's
measurement model, recorded IMU time checks, the velocity-heading initialisation."""

import math

import numpy as np
import pytest

from inins.core import earth, imu, rotation
from inins.core.units import DEG, DPH, UG
from inins.ekf import sources
from inins.ekf.flight import FlightPlan, Leg, LegKind, flight_trajectory, imu_stream
from inins.ekf.measurements import antenna, predict
from inins.exceptions import InputError
from inins.gnss import constellation, gpstime

DT = 0.005
RX = sources.Receiver(
    (1.5, 0.2, -1.0), 10 * DEG, 2.0, 0.05, 2e-19, 2e-20, 3000.0, 0.5, 0.15, 2, 0.05
)


def _plan(heading=180 * DEG, speed=80.0, wait=20.0, takeoff=40.0):
    return FlightPlan(
        37 * DEG,
        127 * DEG,
        100.0,
        heading,
        (
            Leg(LegKind.WAIT, wait),
            Leg(LegKind.TAKEOFF, takeoff, speed=speed),
            Leg(LegKind.STRAIGHT, 20),
        ),
    )


def test_simulated_measurements_match_the_filter_model_at_truth():
    """Pseudorange and range rate minus the filter's model (ekf.measurements.predict) at
    the true antenna state and clock: white noise of the simulated sigma (2 m, 5 cm/s).
    The satellites rotated into the receive-time frame with the SPP travel time, the
    Saastamoinen delay and the TCXO clock all agree between the two layers."""
    plan = _plan()
    base = flight_trajectory(plan)
    week, sow0 = gpstime.from_calendar(2015, 1, 8, 6, 0, 0.0)
    eph = constellation.walker(week, sow0, 200.0, per_plane=5)
    res_pr, res_rr = [], []
    stream = sources.simulated_epochs(
        base, base, imu.SensorErrors(), DT, plan.duration, eph, week, sow0, RX, seed=3, nodes=2
    )
    for ep in stream:
        t = ep.gnss.time
        mat, vel, lla = base.state([t])
        omega, _ = base.rates([t])
        omega_eb = omega[0] - mat[0].T @ earth.rate_ie_n(lla[0, 0])
        r, v = antenna(lla[0], vel[0], mat[0], omega_eb, np.array(RX.lever_arm))
        pr, rr = predict(ep.gnss, r, v, ep.truth.clock_bias, ep.truth.clock_drift)
        res_pr.append(ep.gnss.pseudorange - pr)
        res_rr.append(ep.gnss.range_rate - rr)
        assert len(ep.gnss) >= 5
    res_pr, res_rr = np.concatenate(res_pr), np.concatenate(res_rr)
    assert res_pr.size > 500
    assert abs(np.mean(res_pr)) < 0.2 and 1.85 < np.std(res_pr) < 2.15
    assert abs(np.mean(res_rr)) < 0.005 and 0.046 < np.std(res_rr) < 0.054


def test_imu_time_backwards_or_gap_names_the_dataset():
    t = np.arange(100) * DT
    sources.check_imu_time(t, DT, "f")
    back = t.copy()
    back[50] = back[48]
    with pytest.raises(InputError, match="backwards") as info:
        sources.check_imu_time(back, DT, "f")
    assert info.value.key == "imu/time"
    gap = np.concatenate([t[:50], t[50:] + 0.1])
    with pytest.raises(InputError, match="gap"):
        sources.check_imu_time(gap, DT, "f")
    jitter = t.copy()
    jitter[50] -= 0.003  # 2 ms / 8 ms pair as in the PSINS recording: not a gap
    sources.check_imu_time(jitter, DT, "f")


@pytest.mark.parametrize("heading_deg", [37.0, -120.0])
def test_velocity_heading_recovers_the_heading(heading_deg):
    """A vehicle standing 60 s then accelerating to 5 m/s in about 5 s along a heading
    (gyro bias 10 deg/h, accelerometer bias 1 mg): the levelled attitude turned by the
    velocity match has the true heading within 0.5 deg. (The free run lasts from the end
    of the static window to the fifth moving epoch, ~10 s here: the gyro bias tilts it by
    0.03 deg, 0.3 deg of heading at 5 m/s; a slow start that leaves 25 s, 2 deg.)"""
    plan = _plan(heading_deg * DEG, speed=5.0, wait=60.0, takeoff=10.0)
    traj = flight_trajectory(plan)
    errors = imu.SensorErrors(
        gyro_bias=np.array([10.0, -8.0, 6.0]) * DPH, accel_bias=np.array([1e3, -8e2, 5e2]) * UG
    )
    n = round(plan.duration / DT)
    dtheta, dv = next(imu_stream(traj, errors, DT, [0, n], np.random.default_rng(0)))
    time = np.arange(1, n + 1) * DT
    fix_time = np.arange(1.0, plan.duration, 1.0)
    _, vel_n, lla = traj.state(fix_time)
    init = sources.velocity_heading(time, dtheta, dv, DT, lla[0], (0.0, 59.0), fix_time, vel_n, 1.5)
    true0 = rotation.euler_from_mat(traj.state([0.0])[0][0])[2]
    assert math.degrees(abs(rotation.wrap_angle(init.heading - true0))) < 0.5
    assert init.epochs[0] > 59.0


@pytest.mark.parametrize("heading_deg", [37.0, -120.0, 0.0, 180.0])
def test_ground_heading_holds_until_take_off(heading_deg):
    """The airframe stands at the plan's ground heading (it used to yaw towards north or
    south during the wait for headings other than 0 and 180 deg)."""
    traj = flight_trajectory(_plan(heading_deg * DEG, speed=5.0, wait=60.0))
    mat, _, _ = traj.state(np.array([0.0, 30.0, 59.0, 100.0]))
    heading = rotation.euler_from_mat(mat)[:, 2]
    err = np.degrees(np.abs(rotation.wrap_angle(heading - heading_deg * DEG)))
    assert err.max() < 1e-6


def test_simulated_epochs_are_what_the_checked_constructor_makes():
    """The simulated stream builds its epochs unchecked from block-checked arrays
    (GnssEpoch.unchecked): field for field what GnssEpoch's own checks make of the same
    arrays, read-only like them."""
    from dataclasses import fields

    from inins.ekf.measurements import GnssEpoch

    plan = _plan(wait=5.0, takeoff=40.0)
    base = flight_trajectory(plan)
    week, sow0 = gpstime.from_calendar(2015, 1, 8, 6, 0, 0.0)
    eph = constellation.walker(week, sow0, 200.0, per_plane=5)
    stream = sources.simulated_epochs(
        base, base, imu.SensorErrors(), DT, 20.0, eph, week, sow0, RX, seed=3, nodes=2
    )
    for ep in stream:
        got = ep.gnss
        want = GnssEpoch(**{f.name: getattr(got, f.name) for f in fields(GnssEpoch)})
        for f in fields(GnssEpoch):
            a, b = getattr(got, f.name), getattr(want, f.name)
            if isinstance(b, np.ndarray):
                assert a.dtype == b.dtype and a.shape == b.shape, f.name
                assert a.flags.c_contiguous and not a.flags.writeable, f.name
                np.testing.assert_array_equal(a, b, err_msg=f.name)
            else:
                assert type(a) is type(b) and a == b, f.name

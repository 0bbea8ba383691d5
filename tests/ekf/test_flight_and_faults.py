"""Flight plans (bad input, gyrocompass closed form), gating of faulty pseudoranges,
GPS outages coasted and reported, dither moving average."""

import dataclasses
import math

import numpy as np
import pytest
from ekf_sim import Receiver, epoch_stream

from inins.core import earth, error_model, imu, rotation, strapdown
from inins.core.units import ARCSEC, DEG, DPH, UG
from inins.ekf.config import Coupling, FilterConfig, InitialSigma, Model
from inins.ekf.filter import run_filter
from inins.ekf.flight import (
    Dither,
    FlightPlan,
    Leg,
    LegKind,
    dither_window,
    flight_trajectory,
    gyrocompass_attitude,
)
from inins.exceptions import InputError

DT = 0.005


@pytest.mark.parametrize(
    ("leg", "key"),
    [
        (Leg(LegKind.STRAIGHT, -5.0), "legs.2.duration"),
        (Leg(LegKind.TURN, bank=90 * DEG, angle=1.0), "legs.2.bank"),
        (Leg(LegKind.TURN, bank=30 * DEG, angle=1.0, turn_rate=10 * DEG), "legs.2.turn_rate"),
    ],
)
def test_impossible_flight_names_the_key(leg, key):
    legs = (Leg(LegKind.WAIT, 10), Leg(LegKind.TAKEOFF, 40, speed=80.0), leg)
    with pytest.raises(InputError) as info:
        _ = FlightPlan(0.6, 2.0, 0.0, math.pi, legs).duration
    assert info.value.key == key


def test_turn_is_coordinated_and_ends_on_heading():
    plan = FlightPlan(
        0.6,
        2.0,
        100.0,
        math.pi,
        (
            Leg(LegKind.WAIT, 10),
            Leg(LegKind.TAKEOFF, 40, speed=80.0),
            Leg(LegKind.TURN, bank=30 * DEG, angle=90 * DEG),
            Leg(LegKind.STRAIGHT, 30),
        ),
    )
    traj = flight_trajectory(plan)
    mat, _, _ = traj.state(np.array([5.0, plan.duration]))
    euler = rotation.euler_from_mat(mat)
    assert euler[0, 2] == pytest.approx(math.pi, abs=1e-12)  # aligned south on the ground
    assert euler[1, 2] == pytest.approx(1.5 * math.pi, abs=1e-6)  # 180 + 90 deg
    rate = earth.GAMMA_E * math.tan(30 * DEG) / 80.0
    mid = 50.0 + 0.5 * (90 * DEG) / rate
    roll = rotation.euler_from_mat(traj.state([mid])[0])[0, 0]
    assert roll == pytest.approx(30 * DEG, abs=2 * DEG)  # track steps ripple the bank


def test_gyrocompass_heading_error_closed_form():
    """-eps_E / (W cos L) (003 eq. 10) and tilts b / g from the aligned attitude."""
    lat = 37 * DEG
    mat_nb = rotation.mat_from_euler(0.0, 2 * DEG, math.pi)
    errors = imu.SensorErrors(
        gyro_bias=np.array([0.01, -0.02, 0.03]) * DPH, accel_bias=np.array([50.0, -40.0, 0.0]) * UG
    )
    aligned = gyrocompass_attitude(mat_nb, lat, 0.0, errors)
    phi = -rotation.rotvec_from_mat(aligned @ mat_nb.T)
    eps_e = (mat_nb @ errors.gyro_bias)[1]
    heading_err = rotation.wrap_angle(rotation.euler_from_mat(aligned)[2] - math.pi)
    assert heading_err == pytest.approx(-eps_e / (earth.RATE * math.cos(lat)), rel=0.02)
    b_n = mat_nb @ errors.accel_bias
    g = earth.gravity(lat, 0.0)
    assert phi[1] == pytest.approx(-b_n[0] / g, rel=0.02)  # b_n = phi x f_n: phi_E = -b_N / g
    assert phi[0] == pytest.approx(b_n[1] / g, rel=0.02)  # phi_N = b_E / g


def test_dither_window_spans_whole_periods():
    assert dither_window(Dither(60 * ARCSEC, 40.0), DT) == 5
    assert dither_window(None, DT) == 1


@pytest.fixture(scope="module")
def short_flight():
    plan = FlightPlan(
        37 * DEG,
        127 * DEG,
        100.0,
        math.pi,
        (Leg(LegKind.WAIT, 30), Leg(LegKind.TAKEOFF, 40, speed=80.0), Leg(LegKind.STRAIGHT, 80)),
    )
    traj = flight_trajectory(plan)
    errors = imu.SensorErrors(gyro_bias=0.01 * DPH, accel_bias=50 * UG)
    rx = Receiver()
    mat0, vel0, lla0 = traj.state([0.0])
    initial = strapdown.NavState.from_attitude(
        gyrocompass_attitude(mat0[0], lla0[0, 0], lla0[0, 2], errors), vel0[0], lla0[0]
    )
    return plan, traj, errors, rx, initial


def _config(rx, **extra):
    return FilterConfig(
        Model.EKF1,
        Coupling.FB,
        DT,
        lever_arm=rx.lever_arm,
        initial_sigma=InitialSigma(heading=0.1 * DEG, gyro_bias=0.02 * DPH),
        **extra,
    )


@pytest.mark.slow
def test_faulty_pseudoranges_are_rejected(short_flight):
    plan, traj, errors, rx, initial = short_flight
    faulty = {20, 60, 100}

    def inject(k, epoch):
        if k in faulty:  # through the constructor: read-only arrays, as every epoch has
            bias = np.r_[100.0, 0.0 * epoch.pseudorange[1:]]
            epoch = dataclasses.replace(epoch, pseudorange=epoch.pseudorange + bias)
        return epoch

    epochs = epoch_stream(traj, traj, errors, DT, plan.duration, rx, seed=2, on_gnss=inject)
    result = run_filter(_config(rx), initial, 0.0, epochs, errors)
    rejected = result.innovations.epoch[~result.innovations.accepted]
    assert set(faulty) <= set(rejected.tolist())
    assert result.summary().rejected_measurements <= len(faulty) + 2  # + ~1e-4 of good ones
    assert result.summary().pos_err_rms_m < 3.0


@pytest.mark.slow
def test_outage_is_coasted_and_reported(short_flight):
    plan, traj, errors, rx, initial = short_flight
    epochs = epoch_stream(traj, traj, errors, DT, plan.duration, rx, seed=3)
    result = run_filter(_config(rx, outages=((90.0, 120.0),)), initial, 0.0, epochs, errors)
    assert result.summary().coasted_epochs == 30
    assert result.coasted_windows() == ((90.0, 119.0),)
    err = np.linalg.norm(result.nav_error[:, 0:3], axis=1)
    inside = (result.time >= 90) & (result.time < 120)
    before = (result.time >= 60) & (result.time < 90)
    assert err[inside].max() > 1.5 * err[before].max()  # drifts while coasting
    assert err[-1] < 5.0  # and recovers


@pytest.mark.slow
def test_pps_storage_pairs_measurements_with_the_right_state(short_flight):
    """003 §2.1: data arrive tau = 0.05 s after the 1PPS. Paired with the INS state at
    arrival (naive), the measurements of t_k pull the state of t_k + tau onto the
    position of t_k: the solution lags v tau = 80 m/s x 0.05 s = 4 m along track
    (flying south: +4 m north). The naive result is labelled with the arrival and
    scored against the truth there (its nav_error), not against the truth of t_k."""
    plan, traj, errors, rx, initial = short_flight
    rx = Receiver(latency=0.05)
    along = {}
    for pps in (True, False):
        epochs = epoch_stream(traj, traj, errors, DT, plan.duration, rx, seed=4)
        result = run_filter(_config(rx, pps_storage=pps), initial, 0.0, epochs, errors)
        np.testing.assert_allclose(result.time - result.gnss_time, 0.0 if pps else rx.latency)
        cruise = (result.time >= 90.0) & (result.time <= 150.0)
        _, _, lla_true = traj.state(result.time[cruise])  # when the state holds
        own = error_model.position_error_ned(result.lla[cruise], lla_true)
        np.testing.assert_allclose(result.nav_error[cruise, 0:3], own, atol=1e-6)
        along[pps] = -own[:, 0].mean()  # along track = south = -north
    assert abs(along[True]) < 1.0
    lag = along[False] - along[True]  # same noise in both runs
    assert -1.1 * 80.0 * rx.latency < lag < -0.9 * 80.0 * rx.latency


def test_no_satellites_at_all_is_bad_input(short_flight):
    _, traj, errors, rx, initial = short_flight
    blind = Receiver(mask=math.radians(89.9))
    epochs = epoch_stream(traj, traj, errors, DT, 5.0, blind, seed=0)
    with pytest.raises(InputError) as info:
        run_filter(_config(rx), initial, 0.0, epochs)
    assert info.value.key == "gnss"


def test_dither_moving_average_recovers_the_airframe_rates():
    """003 §2.2: one sample of a dithered IMU carries the dither rate (~0.07 rad/s here);
    the average over whole dither periods leaves the airframe rate and force."""
    from inins.core import trajectory
    from inins.ekf import step
    from inins.ekf.flight import Dithered

    plan = FlightPlan(
        0.6,
        2.0,
        100.0,
        math.pi,
        (
            Leg(LegKind.WAIT, 10),
            Leg(LegKind.TAKEOFF, 40, speed=80.0),
            Leg(LegKind.TURN, bank=30 * DEG, angle=90 * DEG),
        ),
    )
    base = flight_trajectory(plan)
    dither = Dither(60 * ARCSEC, 40.0)
    edges = 60.0 + DT * np.arange(201)
    dtheta, dv = trajectory.ideal_increments(Dithered(base, dither), edges)
    omega0, force0 = base.rates(np.array([edges[100]]))
    window = dither_window(dither, DT)
    filtered, raw = np.zeros((2, 3)), np.zeros((2, 3))
    step.mean_rates(dtheta, dv, 100, window, DT, filtered)
    step.mean_rates(dtheta, dv, 100, 1, DT, raw)
    assert np.abs(raw[0] - omega0[0]).max() > 0.02  # rad/s
    np.testing.assert_allclose(filtered[0], omega0[0], atol=2e-4)  # turn rate ~0.07 rad/s
    np.testing.assert_allclose(filtered[1], force0[0], atol=0.05)  # m/s^2, of ~11


@pytest.mark.slow
@pytest.mark.parametrize("split", [True, False])
def test_fast_roll_transient_keeps_the_nees(split, monkeypatch):
    """A 1-deg turn at 30 deg bank rolls in and out within half a second (~100 deg/s).
    Placed so that the mid-interval sample falls on the roll-in, one ``F`` of that
    sample holds the peak roll rate for the whole second (the misalignment columns
    ``-mat_nb[:, a] omega_b[b]`` of the gyro misalignments): the NEES of EKF2 jumps
    ten-fold and stays there. Propagated over sub-intervals, it stays as it was
    before the turn. (``split=False`` shows the defect the split removes.)"""
    from inins.ekf import filter as ekf_filter

    if not split:
        monkeypatch.setattr(ekf_filter, "RATE_CHANGE", math.inf)
        monkeypatch.setattr(ekf_filter, "FORCE_CHANGE", math.inf)
    plan = FlightPlan(
        37 * DEG,
        127 * DEG,
        100.0,
        math.pi,
        (
            Leg(LegKind.WAIT, 30),
            Leg(LegKind.TAKEOFF, 40, speed=80.0),
            Leg(LegKind.STRAIGHT, 20.45),  # turn centre 90.575 s: roll-in at 90.5 s
            Leg(LegKind.TURN, bank=30 * DEG, angle=1 * DEG),
            Leg(LegKind.STRAIGHT, 30),
        ),
    )
    traj = flight_trajectory(plan)
    errors = imu.SensorErrors(
        gyro_bias=np.array([0.01, -0.01, 0.0]) * DPH,
        accel_bias=np.array([50, -40, 30]) * UG,
        gyro_misalignment=np.array([-30, 20, 50, 200, -40, 200]) * 1e-6,
        accel_misalignment=np.array([20, -30, 10]) * 1e-6,
    )
    rx = Receiver()
    mat0, vel0, lla0 = traj.state([0.0])
    initial = strapdown.NavState.from_attitude(
        gyrocompass_attitude(mat0[0], lla0[0, 0], lla0[0, 2], errors), vel0[0], lla0[0]
    )
    config = FilterConfig(
        Model.EKF2,
        Coupling.FB,
        DT,
        lever_arm=rx.lever_arm,
        initial_sigma=InitialSigma(
            heading=0.1 * DEG,
            gyro_bias=0.02 * DPH,
            accel_bias=100 * UG,
            gyro_misalignment=300e-6,
            accel_misalignment=100e-6,
        ),
    )
    epochs = epoch_stream(traj, traj, errors, DT, plan.duration, rx, seed=2)
    result = run_filter(config, initial, 0.0, epochs, errors)
    turn = 90.45  # wait 30 + take-off 40 + straight 20.45
    before = result.nees[(result.time >= turn - 15) & (result.time < turn)].mean()
    after = result.nees[result.time > turn + 1].mean()
    assert before < 26.0  # chi-square(26) mean: the filter is consistent before the turn
    if split:
        assert after < 1.3 * before
    else:
        assert after > 3.0 * before

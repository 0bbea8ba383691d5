"""RTS smoothing of the tightly coupled filter (store of inins.ekf.tight_store) on a
simulated flight with truth: the smoothed solution beats the forward one."""

import numpy as np
import pytest
from ekf_sim import Receiver, epoch_stream

from inins.core import error_model, imu, rotation, strapdown
from inins.core.units import DEG, DEG_RTH, DPH, UG
from inins.ekf import smoother
from inins.ekf.config import Coupling, FilterConfig, InitialSigma, Model
from inins.ekf.filter import run_filter
from inins.ekf.flight import FlightPlan, Leg, LegKind, flight_trajectory, gyrocompass_attitude
from inins.ekf.tight_store import TightStore

DT = 0.01
ERRORS = imu.SensorErrors(
    gyro_bias=np.array([0.3, -0.2, 0.4]) * DPH,
    accel_bias=np.array([200, -150, 100]) * UG,
    gyro_arw=0.02 * DEG_RTH,
    accel_vrw=50 * UG,
)


@pytest.mark.slow
@pytest.mark.parametrize("coupling", [Coupling.FB, Coupling.FF])
def test_tight_smoothed_beats_forward(coupling):
    """300 s flight (wait, take-off, two 180-deg turns) with a 60 s GPS outage, EKF1.
    Measured: position RMS forward 1.17 m (FF 1.14), smoothed 0.40 m (0.40); attitude
    RMS forward 0.41 deg (0.42; the initial heading error before the first turn),
    smoothed 0.010 deg (0.011). Asserted: smoothed below 0.7 of forward (position) and
    below forward (attitude)."""
    legs = (
        Leg(LegKind.WAIT, 60),
        Leg(LegKind.TAKEOFF, 40, speed=60.0),
        Leg(LegKind.TURN, bank=20 * DEG, angle=180 * DEG),
        Leg(LegKind.STRAIGHT, 60),
        Leg(LegKind.TURN, bank=20 * DEG, angle=-180 * DEG),
        Leg(LegKind.STRAIGHT, 60),
    )
    plan = FlightPlan(0.6, 2.0, 100.0, 0.0, legs)
    truth = flight_trajectory(plan)
    rx = Receiver(latency=0.0)
    epochs = list(epoch_stream(truth, truth, ERRORS, DT, plan.duration, rx, seed=2))
    mat0, vel0, lla0 = truth.state([0.0])
    aligned = gyrocompass_attitude(mat0[0], lla0[0, 0], lla0[0, 2], ERRORS)
    initial = strapdown.NavState.from_attitude(aligned, vel0[0], lla0[0])
    config = FilterConfig(
        Model.EKF1,
        coupling,
        DT,
        lever_arm=rx.lever_arm,
        arw=np.full(3, 0.02 * DEG_RTH),
        vrw=np.full(3, 50 * UG),
        initial_sigma=InitialSigma(heading=2 * DEG, gyro_bias=0.5 * DPH, accel_bias=300 * UG),
        outages=((150.0, 210.0),),
    )
    store = TightStore()
    result = run_filter(config, initial, 0.0, epochs, ERRORS, store=store)
    run = store.run()
    sm = smoother.smooth(run)
    t = run.time
    mat, _, lla = truth.state(t)
    fwd_pos = error_model.position_error_ned(result.lla, lla)
    sm_pos = error_model.position_error_ned(sm.lla, lla)
    fwd_att = error_model.attitude_error(rotation.mat_from_quat(result.quat_nb), mat)
    sm_att = error_model.attitude_error(rotation.mat_from_quat(sm.quat), mat)
    rms = lambda a: float(np.sqrt(np.mean(np.sum(a**2, axis=1))))  # noqa: E731
    print(coupling, rms(fwd_pos), rms(sm_pos), rms(fwd_att) / DEG, rms(sm_att) / DEG)
    assert rms(sm_pos) < 0.7 * rms(fwd_pos)
    assert rms(sm_att) < rms(fwd_att)


@pytest.mark.slow
def test_psins_tc_drive_smoothed():
    """The PSINS tc drive (real MEMS, 136 s, no reference) through the shipped scenario's
    tight EKF1-FB with the store, then smoothed: the command's own run with
    ``filter.smoother: rts``. No truth: the figures are the smoothed 1-sigma against the
    forward one and the forward-smoothed difference. Measured: median horizontal 1-sigma
    forward 0.162 m, smoothed 0.090 m; heading 1-sigma at the start forward 5.0 deg (the
    initial), smoothed 0.52 deg; the largest horizontal difference forward-smoothed
    0.46 m. Asserted: median horizontal smoothed < 0.8 of forward, heading at the start
    < 1 deg, the difference < 1.5 m."""
    from inins.commands import run_ekf
    from inins.scenario.base import load_scenario
    from tests.helpers import CONFIGS

    path = CONFIGS / "run-ekf" / "psins-tc.yaml"
    scenario, _, _ = load_scenario(run_ekf.SCENARIO_MODEL, path, ["filter.smoother=rts"], path)
    r = run_ekf.run(scenario, 0).results
    print(r["forward_hor_sigma_median_m"], r["smoothed_hor_sigma_median_m"])
    assert r["smoothed_hor_sigma_median_m"] < 0.8 * r["forward_hor_sigma_median_m"]
    assert r["smoothed_heading_sigma_start_deg"] < 1.0
    assert r["smoothed_forward_hor_diff_max_m"] < 1.5

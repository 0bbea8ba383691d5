"""A recorded flight with GPS and GLONASS: the GLONASS broadcast sets travel in the
recorded-flight layout (``gnss/glonass``), run-ekf keeps the GLONASS rows and estimates
the receiver's GLONASS inter-system bias. The flight is simulated (IMU increments,
ionosphere-free pseudoranges and range rates from the smartLoc mixed navigation file,
Berlin, 2016-06-06 18:00 GPS time, a 30 m GLONASS bias), written in the layout and
given to run-ekf as a recording."""

import math

import h5py
import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from inins.cli import app
from inins.commands.import_flight import nav_records
from inins.commands.run_ekf import _ephemeris, _take_systems
from inins.core import error_model, imu
from inins.core.units import DEG, DPH, UG
from inins.ekf.flight import FlightPlan, Leg, LegKind, flight_trajectory, imu_stream
from inins.exceptions import InputError
from inins.gnss import simulate as gsim
from inins.gnss.measurements import Signal
from inins.io import flight_layout
from inins.io.flight_layout import ImuRecord, RecordedFlight, read_flight, write_flight
from inins.scenario.run_ekf import Constellation

DT = 0.01
BIAS_R = 30.0


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    path = tmp_path_factory.mktemp("multi") / "flight.h5"
    plan = FlightPlan(
        52.5 * DEG,
        13.4 * DEG,
        100.0,
        math.pi / 2,
        (
            Leg(LegKind.WAIT, 80),
            Leg(LegKind.TAKEOFF, 40, speed=60.0),
            Leg(LegKind.TURN, bank=20 * DEG, angle=120 * DEG),
            Leg(LegKind.STRAIGHT, 30),
        ),
    )
    truth = flight_trajectory(plan)
    n = math.floor(plan.duration / DT)
    rng = np.random.default_rng(7)
    errors = imu.SensorErrors(gyro_bias=0.01 * DPH, accel_bias=30 * UG)
    dtheta, dv = next(imu_stream(truth, errors, DT, [0, n], rng))
    nav, week, sow0 = _ephemeris(Constellation(source="mixed", start_hour_s=64800.0), 0.0)
    nav = _take_systems(nav, "GR")
    t = np.arange(1.0, math.floor(plan.duration) + 1.0)
    pos_e, vel_e = gsim.antenna_from_trajectory(truth, t, None)
    options = gsim.SimulationOptions(
        sigma_pr_m=0.5,
        sigma_rate_mps=0.02,
        signal=Signal.IONO_FREE,
        system_bias_m=((1, BIAS_R),),
    )
    clock = np.full(len(t), 150.0)
    obs, _ = gsim.simulate(nav, week, sow0 + t, pos_e, vel_e, clock, 0.0 * clock, rng, options)
    write_flight(
        path,
        RecordedFlight(
            gnss=obs,
            ephemeris=nav_records(nav),
            imu=ImuRecord(time=(np.arange(n) + 1.0) * DT, dtheta=dtheta, dv=dv),
            source="simulated GPS + GLONASS flight (test)",
            imu_t0_week=week,
            imu_t0_sow=sow0,
            reference_pos_e=np.full(3, np.nan),
            glonass=flight_layout.glonass_columns(nav.glonass),
        ),
    )
    return path, truth, nav


def _scenario(folder, recording, **filter_keys):
    text = {
        "data": {
            "file": str(recording),
            "static_window_s": [0.0, 75.0],
            "mask_deg": 10,
        },
        "filter": {
            "model": "ekf1",
            "coupling": "fb",
            "pseudorange_sigma_m": 0.5,
            "range_rate_sigma_mps": 0.02,
            "initial_sigma": {"position_m": 1.0},
            **filter_keys,
        },
    }
    path = folder / f"multi-{len(list(folder.glob('multi-*')))}.yaml"
    path.write_text(yaml.safe_dump(text))
    return path


def _run(scenario, out):
    return CliRunner().invoke(app, ["run-ekf", str(scenario), "-o", str(out)])


def test_the_glonass_sets_round_trip_through_the_layout(recording):
    path, _, nav = recording
    back = read_flight(path).glonass
    for name, *_ in flight_layout.GLONASS_FIELDS:
        np.testing.assert_array_equal(back[name], getattr(nav.glonass, name))
    assert "/gnss/glonass/pos" in "\n".join(flight_layout.layout_text())


def test_a_glonass_table_of_the_wrong_shape_is_refused(recording, tmp_path):
    path, _, _ = recording
    bad = tmp_path / "bad.h5"
    bad.write_bytes(path.read_bytes())
    with h5py.File(bad, "a") as f:
        del f["gnss/glonass/vel"]
        f["gnss/glonass/vel"] = np.zeros((3, 2))
    with pytest.raises(InputError, match="shape") as err:
        read_flight(bad)
    assert err.value.key == "gnss/glonass/vel" and err.value.source == str(bad)


@pytest.mark.slow
def test_recorded_gps_and_glonass_through_the_tight_filter(recording, tmp_path):
    """The filter takes both systems of the recording (default ``filter.systems``): 18
    states, the GLONASS bias estimated at 30 m within 3 sigma (measured: 29.97 +- 0.05 m),
    the GLONASS rows used; the IMU track on the truth (position error RMS 0.17 m)."""
    path, truth, _ = recording
    done = _run(_scenario(tmp_path, path), tmp_path / "gr")
    assert done.exit_code == 0, done.output
    with h5py.File(tmp_path / "gr" / "run-ekf.h5") as f:
        names = [str(n) for n in f["ekf"].attrs["states"]]
        est, sigma = f["states/estimate"][-1], f["states/sigma"][-1]
        prn, kind = f["innovations/prn"][:], f["innovations/kind"][:]
        accepted = f["innovations/accepted"][:].astype(bool)
        time, lla = f["nav/time"][:], f["nav/lla"][:]
    assert names[-1] == "isb_R" and len(names) == 18
    assert abs(est[-1] - BIAS_R) < 3.0 * sigma[-1] and sigma[-1] < 1.0
    glo = (prn // 100 == 1) & (kind == 0)
    assert glo.sum() > 500 and accepted[glo].mean() > 0.99
    _, _, lla_true = truth.state(time)
    err = error_model.position_error_ned(lla, lla_true)
    rms = np.sqrt(np.mean(np.sum(err[5:] ** 2, axis=1)))
    assert rms < 1.0


def test_a_system_the_recording_lacks_is_refused(recording, tmp_path):
    path, _, _ = recording
    done = _run(_scenario(tmp_path, path, systems="GE"), tmp_path / "ge")
    assert done.exit_code == 2
    assert "filter.systems" in done.output and "not in the recording" in done.output


def test_a_recording_without_glonass_sets_runs_on_gps(recording, tmp_path):
    """A file imported before the layout carried the GLONASS sets: the default takes GPS
    and says so; asking for GLONASS is bad input."""
    path, _, _ = recording
    old = tmp_path / "old.h5"
    old.write_bytes(path.read_bytes())
    with h5py.File(old, "a") as f:
        del f["gnss/glonass"]
    done = _run(_scenario(tmp_path, old), tmp_path / "g")
    assert done.exit_code == 0, done.output
    assert "GLONASS rows left out" in (tmp_path / "g" / "run-ekf.txt").read_text()
    with h5py.File(tmp_path / "g" / "run-ekf.h5") as f:
        assert "isb_R" not in [str(n) for n in f["ekf"].attrs["states"]]
        assert (f["innovations/prn"][:] < 100).all()
    done = _run(_scenario(tmp_path, old, systems="GR"), tmp_path / "gr")
    assert done.exit_code == 2 and "no GLONASS navigation sets" in done.output

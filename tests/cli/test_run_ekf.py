"""``inins run-ekf`` end to end: a short simulated flight through the command, the real
PSINS tc recording (packaged data/insgpseo_tc.mat), the paper 003 scenarios (slow),
and bad input (exit 2, nothing written)."""

import json

import h5py
import numpy as np
import pytest
from scipy import stats
from typer.testing import CliRunner

from inins.cli import app
from inins.commands import run_ekf
from tests.helpers import CONFIGS

SHORT = (
    "flight.legs=[{kind: wait, duration_s: 30}, {kind: takeoff, duration_s: 40, speed_mps: 80},"
    " {kind: turn, bank_deg: 30, angle_deg: 180}, {kind: straight, duration_s: 20}]"
)
# the shipped checks and heading window (from 290 s) are the full flight's
SHORT_ARGS = ("--set", SHORT, "--set", "checks=[]", "--set", "filter.turning_from_s=70")
P003 = CONFIGS / "paper003"


def run(*args):
    return CliRunner().invoke(app, ["run-ekf", *map(str, args)])


def results(path):
    found = json.loads((path / "summary.json").read_text())["results"]
    assert set(found) == set(run_ekf.RESULT_NAMES)  # the same keys in every run
    return found


def test_short_simulated_flight(tmp_path):
    """80 s flight with a 180-deg turn: EKF2-FB stays on truth (metres, 0.1 m/s) and
    consistent; all summary keys are written."""
    out = run(
        P003 / "ekf2-fb.yaml", "-o", tmp_path, *SHORT_ARGS, "--set", "filter.turning_from_s=0"
    )
    assert out.exit_code == 0, out.output
    r = results(tmp_path)
    assert r["pos_err_rms_m"] < 3.0
    assert r["vel_err_rms_mps"] < 0.1
    assert abs(r["heading_err_final_deg"]) < 0.1
    assert 0.8 < r["nis_mean"] < 1.2
    assert r["nees_mean"] < stats.chi2.ppf(0.975, 26)
    assert r["realtime_factor"] > 0
    with h5py.File(tmp_path / "run-ekf.h5") as f:
        assert f["nav/time"].shape[0] == r["epochs"] == 134
        assert f["states/sigma"].shape == (134, 26)
        assert f["truth/heading_error"].shape == (134,)


def test_ff_keeps_no_corrections(tmp_path):
    out = run(P003 / "ekf1-ff.yaml", "-o", tmp_path, *SHORT_ARGS)
    assert out.exit_code == 0, out.output
    r = results(tmp_path)
    assert r["fb_heading_correction_deg"] == 0.0
    assert r["mg_yz_est_arcsec"] is None  # EKF1 has no misalignment states
    report = (tmp_path / "run-ekf.txt").read_text()  # a simulated flight: truth is known
    row = next(line for line in report.splitlines() if line.startswith("mg_yz_est_arcsec"))
    assert "n/a (not estimated by this model)" in row and "without truth" not in row


def test_walker_constellation_and_outage(tmp_path):
    out = run(
        P003 / "ekf2-fb.yaml",
        "-o",
        tmp_path,
        *SHORT_ARGS,
        "--set",
        "gnss.constellation.source=walker",
        "--set",
        "filter.outages_s=[[50, 60]]",
    )
    assert out.exit_code == 0, out.output
    assert results(tmp_path)["coasted_epochs"] == 10


@pytest.fixture(scope="module")
def tc(tmp_path_factory):
    data = CONFIGS.parent / "data" / "insgpseo_tc.mat"
    if not data.exists():
        pytest.skip("data/insgpseo_tc.mat not packaged")
    path = tmp_path_factory.mktemp("tc")
    out = run(CONFIGS / "run-ekf" / "psins-tc.yaml", "-o", path)
    assert out.exit_code == 0, out.output
    return path


def test_import_flight_output_gives_the_same_run(tc, tmp_path):
    """data.file may be the import-flight output instead of the .mat: same solution."""
    done = CliRunner().invoke(
        app,
        [
            "import-flight",
            str(CONFIGS / "import-flight" / "psins-tc.yaml"),
            "-o",
            str(tmp_path / "i"),
        ],
    )
    assert done.exit_code == 0, done.output
    out = run(
        CONFIGS / "run-ekf" / "psins-tc.yaml",
        "-o",
        tmp_path / "r",
        "--set",
        f"data.file={tmp_path / 'i' / 'import-flight.h5'}",
    )
    assert out.exit_code == 0, out.output
    with h5py.File(tc / "run-ekf.h5") as a, h5py.File(tmp_path / "r" / "run-ekf.h5") as b:
        np.testing.assert_allclose(a["nav/lla"][()], b["nav/lla"][()], rtol=0, atol=1e-12)


def test_real_recording_runs_whole_record_consistently(tc):
    """135 epochs, nothing coasted, sigmas bounded; time-averaged NIS of the accepted
    scalar measurements (1.02 measured) inside the 95 % band of their mean if they were
    independent chi-square(1) samples, 1 +- 1.96 sqrt(2 / n); the measurement sigmas are
    tuned on the innovations (the scenario's comment)."""
    r = results(tc)
    assert r["epochs"] == 135 and r["coasted_epochs"] == 0
    with h5py.File(tc / "run-ekf.h5") as f:
        n = int(f["innovations/accepted"][()].sum())
    assert n > 1500
    half = 1.96 * np.sqrt(2.0 / n)
    assert 1.0 - half < r["nis_mean"] < 1.0 + half
    with h5py.File(tc / "run-ekf.h5") as f:
        sigma = f["states/sigma"][()]
        assert np.all(np.isfinite(sigma))
        assert sigma[-1, :3].max() < 5.0  # position sigma (m)


def test_real_recording_follows_spp(tc):
    """Position within 3 m of the epoch-wise SPP fix at every epoch (1.8 m max measured);
    velocity against the range-rate velocity: RMS 0.19 m/s (max 0.67 m/s, the SPP
    velocity's own noise at a few epochs)."""
    r = results(tc)
    assert r["spp_pos_diff_max_m"] < 3.0
    assert r["spp_vel_diff_rms_mps"] < 0.3


def test_real_recording_heading_on_the_straight(tc):
    """IMU t 94.5-120.5 s: the heading of the forward axis within 5 deg of the SPP track
    (heading about 3 deg); the initialisation used only epochs before 80 s."""
    with h5py.File(tc / "run-ekf.h5") as f:
        t = f["nav/time"][()]
        heading = f["nav/forward_heading"][()]
        vel = f["spp/vel_n"][()]
    sel = (t > 94.5) & (t < 120.5)
    track = np.arctan2(vel[sel, 1], vel[sel, 0])
    assert np.degrees(np.abs(np.mean(track))) < 6.0
    diff = np.degrees(np.angle(np.exp(1j * (heading[sel] - track))))
    assert np.abs(diff).max() < 5.0


@pytest.mark.parametrize(
    ("override", "key"),
    [
        ("gnss.mask_deg=89.9", "gnss.mask_deg"),
        ("gnss.lever_arm_m=[1500, 0, 0]", "gnss.lever_arm_m"),
        ("flight.imu.gyro.arw_deg_rth=5000", "flight.imu.gyro.arw_deg_rth"),
        ("flight.imu.accel.vrw_ug_rthz=1e7", "flight.imu.accel.vrw_ug_rthz"),
        ("filter.noise.arw_deg_rth=5000", "filter.noise.arw_deg_rth"),
        ("flight.legs.0.duration_s=-5", "flight.legs[0].duration_s"),
        ("flight.legs.2.bank_deg=90", "flight.legs[2].bank_deg"),
        ("flight.legs.2.turn_rate_dps=20", "flight.legs[2].turn_rate_dps"),
    ],
)
def test_bad_input_names_the_key(tmp_path, override, key):
    out = run(P003 / "ekf2-fb.yaml", "-o", tmp_path, *SHORT_ARGS, "--set", override)
    assert out.exit_code == 2, out.output
    assert key in out.stderr, out.stderr
    assert list(tmp_path.iterdir()) == []


def test_both_sources_is_bad_input(tmp_path):
    out = run(
        P003 / "ekf2-fb.yaml",
        "-o",
        tmp_path,
        "--set",
        "data={file: x.h5, static_window_s: [0, 60]}",
    )
    assert out.exit_code == 2 and "data" in out.stderr


def _recording(tmp_path, edit):
    """The PSINS tc file rewritten with its IMU time edited."""
    import scipy.io

    data = CONFIGS.parent / "data" / "insgpseo_tc.mat"
    if not data.exists():
        pytest.skip("data/insgpseo_tc.mat not packaged")
    mat = scipy.io.loadmat(data)
    edit(mat["imu"])
    path = tmp_path / "edited.mat"
    scipy.io.savemat(path, {k: mat[k] for k in ("imu", "obss", "ephs", "t0")})
    scenario = tmp_path / "s.yaml"
    scenario.write_text(
        (CONFIGS / "run-ekf" / "psins-tc.yaml")
        .read_text()
        .replace("../../data/insgpseo_tc.mat", str(path))
    )
    return scenario


@pytest.mark.parametrize(
    "edit",
    [
        lambda imu: imu.__setitem__((slice(5000, 5001), 6), imu[4990, 6]),  # backwards
        lambda imu: imu.__setitem__((slice(5000, None), 6), imu[5000:, 6] + 0.5),  # gap
    ],
)
def test_bad_recording_time_is_bad_input(tmp_path, edit):
    scenario = _recording(tmp_path, edit)
    out = run(scenario, "-o", tmp_path / "out")
    assert out.exit_code == 2, out.output
    assert "imu/time" in out.stderr
    assert not (tmp_path / "out").exists() or list((tmp_path / "out").iterdir()) == []


@pytest.fixture(scope="module")
def paper003(tmp_path_factory):
    out = {}
    for name in ("ekf1-ff", "ekf2-ff", "ekf2-fb"):
        path = tmp_path_factory.mktemp(name)
        done = run(P003 / f"{name}.yaml", "-o", path)
        assert done.exit_code == 0, done.output
        out[name] = results(path)
    return out


@pytest.mark.slow
def test_paper003_through_the_command(paper003):
    """003 Figs. 9-12 through the shipped scenarios (the numerics are tested on the same
    flight in tests/ekf/test_paper003.py)."""
    e1, e2, fb = paper003["ekf1-ff"], paper003["ekf2-ff"], paper003["ekf2-fb"]
    assert abs(e1["gyro_bias_z_est_dph"]) > 3.0 * e1["gyro_bias_z_sigma_dph"]
    for r in (e2, fb):
        assert abs(r["gyro_bias_z_est_dph"]) < 2.0 * r["gyro_bias_z_sigma_dph"]
        assert abs(r["mg_yz_est_arcsec"] - 41.25) < 2.0 * r["mg_yz_sigma_arcsec"]
        assert abs(r["mg_zy_est_arcsec"] - 41.25) < 2.0 * r["mg_zy_sigma_arcsec"]
    assert fb["heading_err_rms_deg"] <= 0.3 * e1["heading_err_rms_deg"]
    low, high = stats.chi2.ppf([0.025, 0.975], 26)
    assert low < fb["nees_mean"] < high


@pytest.mark.slow
def test_compensation_file_moves_the_bias_estimates_by_its_biases(tc, tmp_path):
    """compensation: FILE on the real recording: increments less (50, -50, 30) deg/h
    and (1000, -1000, 500) ug; the FB filter's accumulated bias estimates (states 9-11
    accelerometer, 12-14 gyro) move by minus those, within 2 sigma of the final sigma
    (measured: accel within 0.1 sigma, gyro x/y 0.03 sigma, gyro z 1.1 sigma, the
    weakly observable one), and the fit to SPP stays (rms 0.636 -> 0.635 m)."""
    from inins.core.units import DPH, UG
    from inins.io.rawlog import compensation_text

    comp = tmp_path / "c.yaml"
    comp.write_text(
        compensation_text(
            {
                "format": "inins-compensation",
                "version": 1,
                "unit": {"name": "MEMS", "serial": "tc"},
                "imu": {"gyro_bias_dph": [50.0, -50.0, 30.0], "accel_bias_ug": [1e3, -1e3, 500]},
            }
        )
    )
    out = run(
        CONFIGS / "run-ekf" / "psins-tc.yaml", "-o", tmp_path / "c", "--set", f"compensation={comp}"
    )
    assert out.exit_code == 0, out.output
    with h5py.File(tc / "run-ekf.h5") as a, h5py.File(tmp_path / "c" / "run-ekf.h5") as b:
        shift = b["states/cumulative"][-1, 9:15] - a["states/cumulative"][-1, 9:15]
        sigma = b["states/sigma"][-1, 9:15]
    want = -np.r_[np.array([1e3, -1e3, 500]) * UG, np.array([50.0, -50.0, 30.0]) * DPH]
    np.testing.assert_array_less(np.abs(shift - want), 2 * sigma)
    np.testing.assert_array_less(np.abs(shift - want)[:5], 0.2 * sigma[:5])
    r0, r1 = results(tc), results(tmp_path / "c")
    assert r1["spp_pos_diff_rms_m"] == pytest.approx(r0["spp_pos_diff_rms_m"], rel=0.02)

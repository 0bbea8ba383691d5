"""``inins import-flight`` end to end on the packaged real data: the ABPO station day
(SPP against the header coordinates) and the PSINS tc drive (convergence, standing
scatter, track), the output readable as a recorded flight, and bad input."""

import json

import h5py
import numpy as np
from typer.testing import CliRunner

from inins.cli import app
from inins.commands import import_flight
from inins.io.flight_layout import read_flight
from tests.helpers import CONFIGS, ROOT


def run(*args):
    return CliRunner().invoke(app, ["import-flight", *map(str, args)])


def results(path):
    return json.loads((path / "summary.json").read_text())["results"]


def test_abpo_day_against_the_station_coordinates(tmp_path):
    result = run("-o", tmp_path)
    assert result.exit_code == 0, result.output
    r = results(tmp_path)
    assert set(r) == set(import_flight.RESULT_NAMES)  # the same keys in every run
    assert r["epochs"] == 2727 and r["epochs_no_fix"] == 1
    assert r["err_3d_rms_m"] <= 4.5 and r["err_3d_p95_m"] <= 8.0 and r["err_3d_max_m"] <= 15.0
    flight = read_flight(tmp_path / "import-flight.h5")
    assert len(flight.gnss.time) == 2727 and flight.imu is None
    np.testing.assert_allclose(flight.reference_pos_e, [4097216.6805, 4429119.0287, -2065771.3676])
    report = (tmp_path / "import-flight.txt").read_text()
    assert "ionosphere-free P1/P2" in report
    # the 46 C1-only rows (no ionosphere model in the header) are dropped and counted;
    # with them, G01's uncorrected C1 rows after acquisition were the 5 "faults excluded"
    assert r["single_frequency_rows_dropped"] == 46 and r["epochs_fault_excluded"] == 0
    assert "46 single-frequency rows dropped" in report


def test_psins_tc_drive(tmp_path):
    result = run(CONFIGS / "import-flight" / "psins-tc.yaml", "-o", tmp_path)
    assert result.exit_code == 0, result.output
    r = results(tmp_path)
    assert set(r) == set(import_flight.RESULT_NAMES)
    assert 1540 <= r["epochs_fix"] <= 1710
    assert r["residual_rms_median_m"] < 1.0
    assert r["static_horizontal_std_m"] < 0.5 and r["static_speed_rms_mps"] < 0.1
    assert 240.0 < r["track_length_imu_m"] < 290.0  # about 264 m during the IMU span
    flight = read_flight(tmp_path / "import-flight.h5")
    assert flight.imu.dtheta.shape == (27280, 3) and flight.imu_t0_sow == 185492.5
    assert "single-frequency L1" in (tmp_path / "import-flight.txt").read_text()


def test_a_navigation_file_given_as_observations_is_bad_input(tmp_path):
    result = run("-o", tmp_path, "--set", f"obs_file={ROOT / 'data' / 'abpo0080.15n.gz'}")
    assert result.exit_code == 2, result.output
    assert "abpo0080.15n.gz" in result.stderr
    assert list(tmp_path.iterdir()) == []


def test_missing_keys_and_files_are_bad_input(tmp_path):
    result = run("-o", tmp_path, "--set", "nav_file=null")
    assert result.exit_code == 2 and "nav_file" in result.stderr
    (tmp_path / "x.mat").write_bytes(b"not a mat file")
    result = run(
        CONFIGS / "import-flight" / "psins-tc.yaml",
        "-o",
        tmp_path / "out",
        "--set",
        f"file={tmp_path / 'x.mat'}",
    )
    assert result.exit_code == 2 and "x.mat" in result.stderr


def test_an_imu_log_joins_the_rinex_record(tmp_path):
    """A RINEX recording with a lab IMU log (any format import-log reads): the IMU
    increments in the recorded flight are the ones import-log writes, on its time grid."""
    log_scenario = CONFIGS / "import-log" / "csv-example.yaml"
    result = run(
        "-o",
        tmp_path / "flight",
        "--set",
        f"imu_log={log_scenario}",
        "--set",
        "imu_t0_sow=345600.0",
    )
    assert result.exit_code == 0, result.output
    flight = read_flight(tmp_path / "flight" / "import-flight.h5")
    assert (
        CliRunner()
        .invoke(app, ["import-log", str(log_scenario), "-o", str(tmp_path / "log")])
        .exit_code
        == 0
    )
    with h5py.File(tmp_path / "log" / "import-log.h5") as f:
        dtheta, dv = f["imu/dtheta"][()], f["imu/dv"][()]
        t0, dt = f["imu"].attrs["t0_s"], f["imu"].attrs["dt_s"]
    np.testing.assert_array_equal(flight.imu.dtheta, dtheta)
    np.testing.assert_array_equal(flight.imu.dv, dv)
    np.testing.assert_allclose(flight.imu.time, t0 + dt * np.arange(1, len(dv) + 1))
    assert flight.imu_t0_sow == 345600.0 and flight.imu_t0_week == flight.gnss.week[0]
    result = run("-o", tmp_path / "bad", "--set", f"imu_log={log_scenario}")
    assert result.exit_code == 2 and "imu_t0_sow" in result.stderr


def test_sky_plot_names_each_satellite_by_its_system(tmp_path, monkeypatch):
    """GLONASS slot 1 (satellite number 101) is labelled R01, not G101; GPS 5 is G05."""
    import matplotlib.axes

    from inins.commands import import_flight_figures
    from inins.results import Series

    labels = []
    annotate = matplotlib.axes.Axes.annotate
    monkeypatch.setattr(
        matplotlib.axes.Axes,
        "annotate",
        lambda self, text, *a, **k: labels.append(text) or annotate(self, text, *a, **k),
    )
    prn = np.array([5, 5, 101, 101, 121, 212])
    result = type("Result", (), {})()
    result.datasets = {
        "spp/row_elevation": Series(np.radians([30.0, 31, 40, 41, 50, 60]), "rad", "", ""),
        "spp/row_azimuth": Series(np.radians([10.0, 11, 100, 101, 200, 300]), "rad", "", ""),
        "spp/row_prn": Series(prn, "1", "", ""),
    }
    import_flight_figures.import_flight_sky(result, tmp_path / "sky.png")
    assert sorted(labels) == ["E12", "G05", "R01", "R21"]
    assert (tmp_path / "sky.png").stat().st_size > 0

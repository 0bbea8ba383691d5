"""The log importer: CSV, HDF5 and PSINS logs into the table-data layout, bad input, and
the stationary check on the real RLG log (full log when present, committed excerpt always).

Numbers from closed forms (generated logs) or from the data (the RLG log: the site
latitude in its header, Earth rate, normal gravity, its own heading).
"""

import os
import re
from pathlib import Path

import h5py
import numpy as np
import pytest

from inins.calibration import stationary
from inins.commands import import_log
from inins.core import earth
from inins.core.units import ARCSEC, DEG, DPH, UG
from inins.exceptions import InputError
from inins.io import logformats
from inins.io.logimport import ScreeningOptions
from inins.io.resources import config_path
from inins.results import MemorySink
from inins.scenario.base import load_scenario
from inins.scenario.import_log import ImportLogScenario

ROOT = Path(__file__).resolve().parents[2]
EXCERPT = ROOT / "data" / "rlg-static-excerpt.imu"
EXCERPT_ROWS = 40_000
LOG_LAT = 34.246048  # deg, the RLG log's header
LOG_HEADING = 90.6  # deg: header yaw0 = -90.6, PSINS yaw is counter-clockwise from north
LAT, HEIGHT, BASE, BIAS = 37.0 * DEG, 50.0, 30.0 * DEG, 0.05 * DPH  # the CSV example


def shared_log():
    """The full RLG log: $ININS_SHARED_DATA/rlg-static/lasergyro.imu, or found by
    walking up from the repository to shared/data/; None if absent."""
    tail = Path("rlg-static") / "lasergyro.imu"
    if os.environ.get("ININS_SHARED_DATA"):
        path = Path(os.environ["ININS_SHARED_DATA"]) / tail
        return path if path.is_file() else None
    for folder in ROOT.parents:
        if (folder / "shared" / "data" / tail).is_file():
            return folder / "shared" / "data" / tail
    return None


def example_csv():
    """Text of data/csv-example.csv: level IMU on a yaw table at 37 N, base azimuth 30 deg,
    60 s at yaw 0, 180 deg turn at 10 deg/s, 60 s at yaw 180; rates in deg/s and m/s^2,
    time column (end of each 0.1 s interval), yaw encoder; 0.05 deg/h bias on gyro x."""
    k = np.arange(1, 1381)
    time = 1000.0 + 0.1 * k
    turning = (k > 600) & (k <= 780)
    yaw = np.clip(k - 600, 0, 180) * DEG
    heading = BASE + yaw
    w_h, w_v = earth.RATE * np.cos(LAT), earth.RATE * np.sin(LAT)
    gyro = np.stack(
        [w_h * np.cos(heading) + BIAS, -w_h * np.sin(heading), -w_v + 10.0 * DEG * turning], axis=1
    )
    accel = np.tile([0.0, 0.0, -earth.gravity(LAT, HEIGHT)], (k.size, 1))
    lines = [
        "# import-log CSV example (data/README.md)",
        "time_s,gx_dps,gy_dps,gz_dps,ax_mps2,ay_mps2,az_mps2,yaw_deg",
    ]
    for t, g, a, y in zip(time, gyro / DEG, accel, yaw / DEG, strict=True):
        lines.append(f"{t:.1f}," + ",".join(f"{v:.12g}" for v in (*g, *a)) + f",{y:g}")
    return "\n".join(lines) + "\n"


def gyrocompass_truth(heading):
    """Heading, horizontal rate and latitude the gyrocompass sees with the x-gyro bias."""
    w_h, w_v = earth.RATE * np.cos(LAT), earth.RATE * np.sin(LAT)
    omega_l = np.array([w_h * np.cos(heading) + BIAS, -w_h * np.sin(heading)])
    hor = np.hypot(*omega_l)
    return np.degrees(np.arctan2(-omega_l[1], omega_l[0])) % 360, hor, np.arctan2(w_v, hor)


def run(data, base_dir):
    """Validate a scenario dict (paths relative to ``base_dir``) and import it."""
    model = ImportLogScenario.model_validate(data, context={"base_dir": base_dir})
    sink = MemorySink()
    return import_log.run(model, 0, sink=sink), sink


def csv_scenario(file="log.csv", **extra):
    data = {
        "log": {
            "file": file,
            "format": "csv",
            "columns": {"time": "t", "gyro": ["gx", "gy", "gz"], "accel": ["ax", "ay", "az"]},
        },
        "gyro": {"quantity": "rate", "unit": "deg/s"},
        "accel": {"quantity": "rate", "unit": "m/s^2"},
        "site": {"lat_deg": 37.0, "lon_deg": 127.0, "height_m": 50.0},
    }
    data.update(extra)
    return data


def tiny_csv(tmp_path, edit=None, n=30):
    """A 100 Hz log at rest: comment (line 1), header (line 2), rows from line 3.
    ``edit(rows)`` may change the list of row strings."""
    rows = [f"{0.01 * (k + 1):.2f},0.001,0,0.002,0,0,-9.8" for k in range(n)]
    if edit:
        edit(rows)
    (tmp_path / "log.csv").write_text("# tiny\nt,gx,gy,gz,ax,ay,az\n" + "\n".join(rows) + "\n")
    return tmp_path


def test_committed_csv_example_is_its_generator():
    assert (ROOT / "data" / "csv-example.csv").read_text() == example_csv()


def _set(r, text):
    def edit(rows):
        rows[r] = text

    return edit


@pytest.mark.parametrize(
    ("edit", "line", "text", "key"),
    [
        (_set(5, "0.06,0,0,0,0,0"), 8, "expected 7 columns, found 6", None),
        (_set(5, "0.06,abc,0,0,0,0,-9.8"), 8, "column 1: expected a number, got 'abc'", None),
        (
            _set(5, "0.06,nan,0,0,0,0,-9.8"),
            8,
            "got nan; expected a finite number",
            "log.columns.gyro[0]",
        ),
        (_set(5, "0.06,0,0,0,0,-inf,-9.8"), 8, "got -inf", "log.columns.accel[1]"),
        (_set(5, "0.04,0,0,0,0,0,-9.8"), 8, "time goes back or repeats", "log.columns.time"),
        (
            lambda rows: rows.__setitem__(
                slice(5, None), [r.replace("0.", "1.", 1) for r in rows[5:]]
            ),
            8,
            "time has a gap: 1.06 s, 1.01 s after line 7",
            "log.columns.time",
        ),
    ],
)
def test_bad_rows_name_the_line(tmp_path, edit, line, text, key):
    with pytest.raises(InputError) as exc:
        run(csv_scenario(), tiny_csv(tmp_path, edit))
    err = exc.value
    assert (err.source, err.line) == (str(tmp_path / "log.csv"), line), str(err)
    assert text in err.message and (key is None or err.key == key), str(err)


def test_bad_files_and_columns(tmp_path):
    with pytest.raises(InputError, match="log file not found") as exc:
        run(csv_scenario("none.csv"), tmp_path)
    assert exc.value.key == "log.file" and exc.value.source == str(tmp_path / "none.csv")
    data = csv_scenario()
    data["log"]["columns"]["gyro"] = ["gx", "gy", "gyro_z"]
    with pytest.raises(InputError, match=r"no column 'gyro_z' in the header \(line 2") as exc:
        run(data, tiny_csv(tmp_path))
    assert exc.value.key == "log.columns.gyro[2]"
    data["log"]["columns"]["gyro"] = [1, 2, 9]
    with pytest.raises(InputError, match="column index 9 is out of range: the rows have 7"):
        run(data, tmp_path)
    data = {"log": {"file": "log.csv", "format": "psins"}}
    with pytest.raises(InputError, match="not a PSINS SIMU log") as exc:
        run(data, tmp_path)
    assert exc.value.line == 1


def test_whitespace_columns_by_index_and_time_marks(tmp_path):
    """The CSV example as blank-separated text without a header, columns by 0-based index,
    times marking the start of each interval: the same increments, t0 one interval later."""
    lines = example_csv().splitlines()
    (tmp_path / "log.txt").write_text(
        "\n".join([lines[0], "junk line", *(line.replace(",", "  ") for line in lines[2:])])
    )
    sets = [
        f"log.file={tmp_path / 'log.txt'}",
        "log.time_marks=start",
        "log.csv={delimiter: whitespace, header: false, skip_lines: 2}",
        "log.columns={time: 0, gyro: [1, 2, 3], accel: [4, 5, 6], table_angles: [7]}",
    ]
    model, _, _ = load_scenario(
        ImportLogScenario, config_path("import-log", "csv-example"), sets, None
    )
    plain, _, _ = load_scenario(
        ImportLogScenario, config_path("import-log", "csv-example"), [], None
    )
    (text, sink), (csv, csv_sink) = import_log_model(model), import_log_model(plain)
    np.testing.assert_array_equal(sink["imu/dtheta"], csv_sink["imu/dtheta"])
    assert (text.attrs["imu"]["t0_s"], csv.attrs["imu"]["t0_s"]) == (1000.1, 1000.0)


def test_counts_stay_counts_on_body_axes(tmp_path):
    """Log counts (3, 5, -2) with pulse weights (1, 2, 4) arcsec, body = [+y, +x, -z]:
    body counts (5, 3, 2), body pulse weights (2, 1, 4) arcsec."""

    def edit(rows):
        rows[:] = [f"{0.01 * (k + 1):.2f},3,5,-2,0,0,-9.8" for k in range(len(rows))]

    tiny_csv(tmp_path, edit)
    data = csv_scenario(
        gyro={"unit": "count", "pulse_weight_arcsec": [1, 2, 4]}, body_axes=["+y", "+x", "-z"]
    )
    _, sink = run(data, tmp_path)
    assert sink["imu/dtheta"].dtype == np.int32 and sink["imu/dtheta"][0].tolist() == [5, 3, 2]
    np.testing.assert_allclose(
        sink.attrs["imu/dtheta"]["pulse_weight"], [2 * ARCSEC, ARCSEC, 4 * ARCSEC]
    )
    np.testing.assert_allclose(sink["imu/dv"][0], [0, 0, 9.8 * 0.01], rtol=1e-12)
    edit_bad = _set(3, "0.04,1.5,0,0,0,0,-9.8")
    tiny_csv(tmp_path, lambda rows: (edit(rows), edit_bad(rows)))
    data = csv_scenario(gyro={"unit": "count", "pulse_weight_arcsec": [0.1, 0.1, 0.1]})
    with pytest.raises(
        InputError, match=re.escape("got 1.5; expected an integer pulse count")
    ) as exc:
        run(data, tmp_path)
    assert (exc.value.line, exc.value.key) == (6, "log.columns.gyro[0]")


def test_scenario_errors_name_the_key(tmp_path):
    (tmp_path / "s.yaml").write_text(
        "log: {file: log.csv, format: csv, columns: {time: t, gyro: [gx, gy, gz], "
        "accel: [ax, ay, az]}}\ngyro:\n  quantity: rate\n  unit: deg/sec\n"
        "accel: {quantity: rate, unit: m/s^2}\nsite: {lat_deg: 37, lon_deg: 127, height_m: 50}\n"
    )
    with pytest.raises(InputError, match="expected one of 'count', 'rad'") as exc:
        load_scenario(ImportLogScenario, tmp_path / "s.yaml", [], None)
    assert (exc.value.key, exc.value.line) == ("gyro.unit", 4)
    for sets, key, text in [
        (
            ["gyro.quantity=increment"],
            "gyro.unit",
            "deg/s is a unit of a rate; for quantity increment use one of rad, deg, arcsec",
        ),
        (["body_axes=[+x,+x,+z]"], "body_axes", "name each log axis x, y, z once"),
        (["body_axes=[+y,+x,+z]"], "body_axes", "mirror image"),
        (["log.format=psins"], "log.columns", "a PSINS log has fixed columns"),
        (
            ["gyro.quantity=increment", "gyro.unit=count"],
            "gyro.pulse_weight_arcsec",
            "unit count needs the pulse weights",
        ),
    ]:
        with pytest.raises(InputError, match=text) as exc:
            load_scenario(
                ImportLogScenario,
                tmp_path / "s.yaml",
                ["gyro.unit=deg/s", "gyro.quantity=rate", *sets],
                None,
            )
        assert exc.value.key == key, str(exc.value)


def test_step_outside_the_log(tmp_path):
    data = csv_scenario(steps=[{"kind": "hold", "start_s": 5.0, "end_s": 9.0}])
    with pytest.raises(InputError, match=r"holds no whole sample of the log \(0 s to 0.3 s") as exc:
        run(data, tiny_csv(tmp_path))
    assert exc.value.key == "steps[0]"


def test_csv_example_holds_match_the_closed_form():
    model, _, _ = load_scenario(
        ImportLogScenario, config_path("import-log", "csv-example"), [], None
    )
    result, sink = import_log_model(model)
    assert result.results["samples"] == 1380 and result.attrs["imu"]["t0_s"] == 1000.0
    heading, hor, lat = gyrocompass_truth(BASE)
    r = result.results
    assert r["heading_deg"] == pytest.approx(heading, abs=1e-6)
    assert r["earth_rate_horizontal_dph"] == pytest.approx(hor / DPH, rel=1e-7)
    assert r["implied_lat_deg"] == pytest.approx(np.degrees(lat), abs=1e-6)
    assert abs(r["gravity_err_ug"]) < 1e-3 and abs(r["roll_deg"]) < 1e-9
    assert heading - 30.0 == pytest.approx(-0.118, abs=0.002)  # eps_E / (W cos L)
    assert "yaw180" in result.report and "210.12" in result.report
    # rates became increments rate * dt: the turn adds up to 180 deg about z
    turn = sink["imu/dtheta"][600:780, 2].sum() - 180 * 0.1 * (-earth.RATE * np.sin(LAT))
    assert turn == pytest.approx(np.pi, abs=1e-9)


def import_log_model(model, chunk=None, monkeypatch=None):
    if monkeypatch is not None:
        monkeypatch.setattr(logformats, "CHUNK_ROWS", chunk)
    sink = MemorySink()
    return import_log.run(model, 0, sink=sink), sink


def test_body_axes_of_float_increments():
    """[+y, -x, +z]: body x = log y, body y = -log x, body z = log z; body x is now the
    right axis of the example's forward-right-down log, so the heading is 90 deg more."""
    model, _, _ = load_scenario(
        ImportLogScenario, config_path("import-log", "csv-example"), [], None
    )
    turned, _, _ = load_scenario(
        ImportLogScenario, config_path("import-log", "csv-example"), ["body_axes=[+y,-x,+z]"], None
    )
    (plain, sink), (moved, sink2) = import_log_model(model), import_log_model(turned)
    for name in ("imu/dtheta", "imu/dv"):
        np.testing.assert_array_equal(sink2[name], sink[name][:, [1, 0, 2]] * [1, -1, 1])
    turn = (moved.results["heading_deg"] - plain.results["heading_deg"]) % 360
    assert turn == pytest.approx(90.0, abs=1e-6)


def test_holds_from_the_encoder_and_small_chunks(monkeypatch):
    """Without steps the encoder gives H1, M1, H2 (1 s blocks, 1 s margins); 7-row chunks
    give the same file as one chunk (carry of time checks and blocks across chunks)."""
    model, _, _ = load_scenario(
        ImportLogScenario, config_path("import-log", "csv-example"), ["steps=[]"], None
    )
    whole, sink = import_log_model(model)
    small, sink7 = import_log_model(model, 7, monkeypatch)
    for name in ("imu/dtheta", "imu/dv", "table/encoder", "table/time"):
        np.testing.assert_array_equal(sink[name], sink7[name])
    steps = whole.datasets
    assert [s.decode() for s in steps["steps/label"].data] == ["H1", "M1", "H2"]
    np.testing.assert_allclose(steps["steps/start_time"].data, [1001, 1059, 1079])
    np.testing.assert_allclose(steps["steps/end_time"].data, [1059, 1079, 1137])
    np.testing.assert_allclose(np.degrees(steps["steps/angles_end"].data[:, 0]), [0, 180, 180])
    assert whole.results == small.results
    assert whole.results["heading_deg"] == pytest.approx(gyrocompass_truth(BASE)[0], abs=1e-6)


def test_a_gap_across_chunks_names_its_line(tmp_path, monkeypatch):
    def edit(rows):
        rows[12:] = [f"{0.01 * (k + 3):.2f},0,0,0,0,0,-9.8" for k in range(12, 30)]

    monkeypatch.setattr(logformats, "CHUNK_ROWS", 4)
    with pytest.raises(
        InputError, match=re.escape("time has a gap: 0.15 s, 0.03 s after line 14")
    ) as exc:
        run(csv_scenario(), tiny_csv(tmp_path, edit))
    assert exc.value.line == 15


def test_screening_removes_a_knock(tmp_path):
    """A 2 s knock of 0.5 deg/s about x in a 60 s hold: without screening the heading is
    tens of degrees off; screened (2 s + 2 x 5 s guard left out) it is the closed form."""
    text = example_csv().splitlines()
    rows = [r.split(",") for r in text[2:]]
    for k in range(300, 320):
        rows[k][1] = f"{float(rows[k][1]) + 0.5:.12g}"
    (tmp_path / "knock.csv").write_text("\n".join([*text[:2], *(",".join(r) for r in rows)]))
    model, _, _ = load_scenario(
        ImportLogScenario,
        config_path("import-log", "csv-example"),
        [f"log.file={tmp_path / 'knock.csv'}"],
        None,
    )
    r = import_log_model(model)[0].results
    assert r["quiet_s"] == 60 - 2 - 2 * 5
    assert r["heading_deg"] == pytest.approx(gyrocompass_truth(BASE)[0], abs=1e-6)
    assert abs(r["heading_unscreened_deg"] - 30.0) > 10.0


def test_quiet_blocks_rule():
    """Rates r0 +- 1e-5 rad/s: median r0 + 1e-5, MAD 2e-5, robust sigma 2.97e-5; block 3
    at 9.8 sigma and block 20 with 3.25 x the median spread are disturbed (with 5 blocks
    of guard each side); block 32 at 4.7 sigma and block 36 at 2.95 x spread are not."""
    r0 = 1e-3
    rate = np.full((40, 3), r0)
    rate[:, 0] += 1e-5 * (-1.0) ** np.arange(40)
    rate[3, 0], rate[32, 0] = r0 + 3e-4, r0 + 1.5e-4
    spread = np.full((40, 3), 0.002)
    spread[20, 1], spread[36, 2] = 0.0065, 0.0059
    quiet = stationary.quiet_blocks(rate * 1.0, spread, 1.0, 0.01, ScreeningOptions())
    assert np.flatnonzero(quiet).tolist() == [*range(9, 15), *range(26, 40)]


def test_short_holds():
    """A 12 s hold is checked without noise figures (fewer than 16 blocks); an 8 s hold is
    not checked (min_hold_s 10 s)."""
    hold = "steps=[{kind: hold, start_s: 1000, end_s: %d, angles_deg: [0]}]"
    model, _, _ = load_scenario(
        ImportLogScenario, config_path("import-log", "csv-example"), [hold % 1012], None
    )
    r = import_log_model(model)[0].results
    assert r["hold_s"] == 12 and r["arw_x_deg_rth"] is None and r["heading_sigma_deg"] is None
    assert r["heading_deg"] == pytest.approx(gyrocompass_truth(BASE)[0], abs=1e-6)
    model, _, _ = load_scenario(
        ImportLogScenario, config_path("import-log", "csv-example"), [hold % 1008], None
    )
    result = import_log_model(model)[0]
    assert result.results["holds_checked"] == 0 and "heading_deg" not in result.results
    assert result.warnings == ("no hold of at least 10 s: nothing checked",)


def test_hdf5_log_matches_the_csv(tmp_path):
    table = np.loadtxt(ROOT / "data" / "csv-example.csv", delimiter=",", skiprows=2)
    with h5py.File(tmp_path / "log.h5", "w") as f:
        f["imu/time"] = table[:, 0]
        f["imu/gyro"] = table[:, 1:4] * DEG
        f["imu/accel"] = table[:, 4:7]
        f["table/yaw"] = table[:, 7]
    sets = [
        "log.format=hdf5",
        "log.file=" + str(tmp_path / "log.h5"),
        "gyro.unit=rad/s",
        "log.columns={time: imu/time, gyro: imu/gyro, accel: 'imu/accel', "
        "table_angles: ['table/yaw']}",
    ]
    model, _, _ = load_scenario(
        ImportLogScenario, config_path("import-log", "csv-example"), sets, None
    )
    from_h5, sink = import_log_model(model)
    csv_model, _, _ = load_scenario(
        ImportLogScenario, config_path("import-log", "csv-example"), [], None
    )
    from_csv, csv_sink = import_log_model(csv_model)
    np.testing.assert_allclose(sink["imu/dtheta"], csv_sink["imu/dtheta"], rtol=1e-12)
    assert from_h5.results["heading_deg"] == pytest.approx(
        from_csv.results["heading_deg"], abs=1e-9
    )
    with h5py.File(tmp_path / "log.h5", "a") as f:
        f["imu/accel"][700, 2] = np.nan
    with pytest.raises(InputError, match="row 701: got nan; expected a finite number") as exc:
        import_log_model(model)
    assert (exc.value.key, exc.value.line) == ("log.columns.accel[2]", None)
    bad = [*sets[:3], "log.columns={gyro: imu/gyro, accel: 'imu/acc'}", "log.sample_rate_hz=10"]
    model, _, _ = load_scenario(
        ImportLogScenario, config_path("import-log", "csv-example"), [*bad, "steps=[]"], None
    )
    with pytest.raises(
        InputError,
        match=r"no dataset 'imu/acc' in the file \(datasets: "
        r"imu/accel, imu/gyro",
    ) as exc:
        import_log_model(model)
    assert exc.value.key == "log.columns.accel[0]"


def psins_results(path, sets=()):
    model, _, _ = load_scenario(
        ImportLogScenario, config_path("import-log"), [f"log.file={path}", *sets], None
    )
    return import_log_model(model)


def assert_stationary(r, heading_tol):
    """What the RLG log must show: the site latitude, Earth rate, gravity and heading."""
    w_h = earth.RATE * np.cos(LOG_LAT * DEG)
    assert abs(r["implied_lat_deg"] - LOG_LAT) < 1.0
    assert abs(r["earth_rate_horizontal_dph"] * DPH / w_h - 1) < 0.05
    assert abs(r["earth_rate_horizontal_err_pct"]) < 5.0
    assert abs(r["gravity_err_ug"]) < 100.0
    assert abs(r["heading_deg"] - LOG_HEADING) < heading_tol


def test_rlg_excerpt():
    """Measured: latitude 33.72 deg, horizontal +0.14 %, |f| - gamma -18 ug, heading
    89.93 deg (1 sigma 0.65 deg from 142 s of quiet data). Unscreened, the disturbances
    put the horizontal Earth rate 5.8 % high and the latitude 1.5 deg off."""
    result, sink = psins_results(EXCERPT)
    r = result.results
    assert r["samples"] == EXCERPT_ROWS and r["sample_rate_hz"] == 100.0
    assert_stationary(r, heading_tol=2.0)
    assert abs(r["implied_lat_unscreened_deg"] - LOG_LAT) > 1.0  # the disturbances matter
    assert sink["imu/dtheta"].dtype == np.int32 and sink["imu/dv"].dtype == np.int32
    assert sink["imu/dv"][0].tolist() == [0, 0, -80]  # log row 1: 0 0 2 0 0 80, z up -> down
    pw = sink.attrs["imu/dv"]["pulse_weight"]
    np.testing.assert_allclose(pw, 125e-6 * 9.780327, rtol=1e-12)  # ug of the header's g


def test_rlg_axes_mapping_and_the_header_g():
    """The gyrocompass finds the log's y axis at the same azimuth whatever the body axes;
    the header's g (9.780327, PSINS's ug) puts |f| on normal gravity, 9.80665 does not."""
    frd = psins_results(EXCERPT)[0]
    rfu = psins_results(EXCERPT, ["body_axes=[+x,+y,+z]"])[0]  # right-forward-up
    flu = psins_results(EXCERPT, ["body_axes=[+y,-x,+z]"])[0]  # forward-left-up
    line = "log y axis azimuth from the gyrocompass (log): 89.930 deg"
    assert line in frd.report and line in rfu.report and line in flu.report
    assert abs(abs(rfu.results["roll_deg"]) - 180.0) < 2.0  # z up
    # the right axis is 90 deg clockwise from the forward axis (to second order in the tilt)
    turn = (rfu.results["heading_deg"] - frd.results["heading_deg"]) % 360
    assert turn == pytest.approx(90.0, abs=0.01)
    assert flu.results["heading_deg"] == pytest.approx(frd.results["heading_deg"], abs=1e-6)
    std = psins_results(EXCERPT, ["accel.g_mps2=9.80665"])[0]
    gamma = earth.gravity(LOG_LAT * DEG, 380.0)
    f_norm = frd.results["gravity_err_ug"] * UG + gamma
    assert std.results["gravity_err_ug"] == pytest.approx(
        (f_norm * 9.80665 / 9.780327 - gamma) / UG, abs=0.01
    )
    assert "scenario values used instead of the header: accel.g_mps2" in std.report


@pytest.mark.skipif(
    shared_log() is None,
    reason="the shared RLG log (shared/data/rlg-static/"
    "lasergyro.imu or $ININS_SHARED_DATA) is not on this machine",
)
def test_rlg_full_log():
    """Measured: latitude 34.207 deg, horizontal -0.14 %, |f| - gamma -5 ug, heading
    90.73 deg (1 sigma 0.15 deg from 891 quiet s of 1847 s); unscreened 88.59 deg."""
    path = shared_log()
    with open(path) as full, open(EXCERPT) as part:
        assert [next(full) for _ in range(14 + EXCERPT_ROWS)] == part.readlines()
    r = psins_results(path)[0].results
    assert r["samples"] == 184_718
    assert_stationary(r, heading_tol=1.0)

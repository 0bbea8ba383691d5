"""``inins import-log`` end to end: the shipped scenarios, the files written, bad input."""

import json

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

from inins.cli import app
from inins.core.units import ARCSEC
from inins.io.resources import config_path
from inins.io.tabledata import read_table_data

OUTPUTS = ("import-log.h5", "import-log.txt", "summary.json")


def invoke(*args):
    return CliRunner().invoke(app, ["import-log", *map(str, args)])


def test_default_imports_the_rlg_excerpt(tmp_path):
    result = invoke("-o", tmp_path)
    assert result.exit_code == 0, result.output
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["scenario"] == "configs/import-log/default.yaml" and summary["passed"]
    r = summary["results"]
    assert r["samples"] == 40_000 and r["duration_s"] == 400.0
    assert abs(r["implied_lat_err_deg"]) < 1.0 and abs(r["earth_rate_horizontal_err_pct"]) < 5
    report = (tmp_path / "import-log.txt").read_text()
    for text in (
        "PSINS header: lat 34.24604800 deg",
        "body x = +log y, body y = +log x, body z = -log z",
        "header yaw -90.6 deg (counter-clockwise) = azimuth 90.600 deg",
        "the same without screening",
        "rows/s",
    ):
        assert text in report
    data = read_table_data(tmp_path / "import-log.h5")  # the table-data layout
    assert (data.n_samples, data.dt, data.t0) == (40_000, 0.01, 0.0)
    np.testing.assert_allclose(np.degrees(data.lla[:2]), [34.246048, 108.909664])
    assert [s.kind for s in data.steps] == ["hold"] and data.steps[0].stop_index == 40_000
    dtheta, _ = data.imu(0, 1)
    np.testing.assert_allclose(dtheta[0], [0.0, 0.0, -2 * 0.1 * ARCSEC])  # row 1: 0 0 2
    with h5py.File(tmp_path / "import-log.h5") as f:
        assert f["imu/dtheta"].dtype == np.int32 and f["imu/dtheta"].attrs["units"] == "count"
        assert f["check/omega_b"].shape == (400, 3)


def test_csv_example(tmp_path):
    result = invoke(config_path("import-log", "csv-example"), "-o", tmp_path)
    assert result.exit_code == 0, result.output
    r = json.loads((tmp_path / "summary.json").read_text())["results"]
    assert r["steps"] == 3 and r["holds_checked"] == 2
    assert r["heading_deg"] == pytest.approx(29.882, abs=0.001)
    data = read_table_data(tmp_path / "import-log.h5")
    assert data.gimbals == ("yaw",) and data.encoder.shape == (1380, 1)
    assert [s.label for s in data.steps] == ["yaw0", "turn", "yaw180"]
    np.testing.assert_allclose(data.mat_n_base[:2, 0], [np.cos(np.pi / 6), np.sin(np.pi / 6)])


def test_bad_log_exits_2_and_writes_nothing(tmp_path):
    log = tmp_path / "log.csv"
    log.write_text(
        "t,gx,gy,gz,ax,ay,az\n"
        + "".join(f"{0.01 * k:.2f},0,0,0,0,0,-9.8\n" for k in range(1, 20))
        + "0.20,0,0,0,x,0,-9.8\n"
    )
    scenario = tmp_path / "s.yaml"
    scenario.write_text(
        "log:\n  file: log.csv\n  format: csv\n  columns: {time: t, gyro: [gx, gy, gz], "
        "accel: [ax, ay, az]}\ngyro: {quantity: rate, unit: deg/s}\n"
        "accel: {quantity: rate, unit: m/s^2}\nsite: {lat_deg: 37, lon_deg: 127, height_m: 50}\n"
    )
    out = tmp_path / "out"
    out.mkdir()
    (out / "summary.json").write_text("earlier")
    result = invoke(scenario, "-o", out)
    assert result.exit_code == 2
    assert result.stderr.strip() == (
        f"inins import-log: error: {log}:21: column 4: expected a number, got 'x'"
    )
    assert sorted(p.name for p in out.iterdir()) == ["summary.json"]
    assert (out / "summary.json").read_text() == "earlier"
    result = invoke(scenario, "-o", out, "--set", "accel.unit=m/s/s")
    assert result.exit_code == 2 and "s.yaml: accel.unit: expected one of" in result.stderr
    result = invoke(scenario, "-o", out, "--set", "log.file=none.csv")
    assert result.exit_code == 2
    assert result.stderr.strip().endswith(f"{tmp_path / 'none.csv'}: log.file: log file not found")


def test_schema_documents_every_key():
    result = CliRunner().invoke(app, ["schema", "import-log", "--json"])
    assert result.exit_code == 0
    props = json.loads(result.stdout)["$defs"]
    assert props["LogGyro"]["properties"]["pulse_weight_arcsec"]["unit"] == "arcsec"
    assert props["LogStep"]["properties"]["start_s"]["unit"] == "s"


def test_a_float_accelerometer_in_g_is_scaled_by_g(tmp_path):
    """The CSV example's specific force written in g (and in mg) imports to the same
    increments as the m/s^2 original: a log unit that is a multiple of g is multiplied
    by ``accel.g_mps2`` (a float log in g was once taken as m/s^2, 9.8 times too small)."""
    import yaml

    original = config_path("import-log", "csv-example")
    scenario = yaml.safe_load(original.read_text())
    g = 9.80665
    lines = (original.parent / scenario["log"]["file"]).resolve().read_text().splitlines()
    header = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    names = lines[header].split(",")
    accel = [names.index(c) for c in scenario["log"]["columns"]["accel"]]
    results = {}
    for unit, per in (("m/s^2", 1.0), ("g", g), ("mg", g / 1000)):
        rows = [lines[header]]
        for line in lines[header + 1 :]:
            values = line.split(",")
            for j in accel:
                values[j] = repr(float(values[j]) / per)
            rows.append(",".join(values))
        log = tmp_path / f"log-{unit.replace('/', '_')}.csv"
        log.write_text("\n".join(rows) + "\n")
        variant = {**scenario, "log": {**scenario["log"], "file": str(log)}}
        variant["accel"] = {"quantity": "rate", "unit": unit, "g_mps2": g}
        path = tmp_path / f"scenario-{unit.replace('/', '_')}.yaml"
        path.write_text(yaml.safe_dump(variant))
        out = tmp_path / f"out-{unit.replace('/', '_')}"
        result = invoke(path, "-o", out)
        assert result.exit_code == 0, result.output
        _, dv = read_table_data(out / "import-log.h5").imu(0, 100)
        results[unit] = dv
    np.testing.assert_allclose(results["g"], results["m/s^2"], rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(results["mg"], results["m/s^2"], rtol=1e-12, atol=1e-15)

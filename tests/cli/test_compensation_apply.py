"""``compensation: FILE`` (a calibrate-imu compensation file) applied to raw data by
import-log, calibrate-bias and run-ekf: the errors it estimated are removed, the
refusals name the file and key."""

import hashlib
import json

import h5py
import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from inins.calibration import imu_model
from inins.cli import app
from inins.commands._compensation import CompensatedRecord, compensation_terms
from inins.core.units import ARCSEC, DPH, PPM, UG
from inins.io.rawlog import compensation_text
from inins.io.tabledata import read_table_data
from tests.helpers import CONFIGS

RATE = 50  # Hz: the shipped 24-position + rate-test schedule at a quarter of its rate
MG = ("xy", "xz", "yx", "yz", "zx", "zy")


def invoke(*args):
    return CliRunner().invoke(app, [*map(str, args)])


def comp_file(path, gyro_bias_dph=(0, 0, 0), accel_bias_ug=(0, 0, 0), serial="SIM-0001", **imu):
    """A compensation file with the given terms (the layout calibrate-imu writes)."""
    payload = {
        "format": "inins-compensation",
        "version": 1,
        "unit": {"name": "RLG-NAV", "serial": serial},
        "method": "test",
        "imu": {"gyro_bias_dph": list(gyro_bias_dph), "accel_bias_ug": list(accel_bias_ug), **imu},
    }
    path.write_text(compensation_text(payload))
    return path


@pytest.fixture(scope="module")
def lab(tmp_path_factory):
    """The shipped calibrate-imu schedule simulated with its errors, and once without
    any (same motion): the true increments; calibrate-imu on the first."""
    root = tmp_path_factory.mktemp("comp")
    setup = yaml.safe_load((CONFIGS / "calibrate-imu" / "default.yaml").read_text())
    sim = setup["simulate"]
    sim["imu"]["sample_rate_hz"] = RATE
    (root / "raw.yaml").write_text(yaml.safe_dump({**sim, "seed": 11}))
    for s in ("gyro", "accel"):
        for k in ("bias_dph", "scale_ppm", "misalignment_arcsec", "arw_deg_rth", "bias_ug"):
            sim["imu"][s].pop(k, None)
        sim["imu"][s].pop("vrw_ug_rthz", None)
    (root / "true.yaml").write_text(yaml.safe_dump({**sim, "seed": 11}))
    for name in ("raw", "true"):
        done = invoke("simulate-table", root / f"{name}.yaml", "-o", root / name)
        assert done.exit_code == 0, done.output
    cal = root / "cal.yaml"
    cal.write_text(
        yaml.safe_dump({"unit": setup["unit"], "data": str(root / "raw" / "simulate-table.h5")})
    )
    done = invoke("calibrate-imu", cal, "-o", root / "cal")
    assert done.exit_code == 0, done.output
    res = json.loads((root / "cal" / "summary.json").read_text())["results"]
    return root, res


def _fit(record, true_record):
    """Per triad, the bias b (SI) and the matrix E with ``d - d_true = b dt + E d_true``,
    least squares over the sums of every step of the schedule (holds and rotations)."""
    rows = {"g": ([], []), "a": ([], [])}
    for step in record.steps:
        k0, k1 = step.start_index, step.stop_index
        if k1 <= k0:
            continue
        (dth, dv), (tth, tdv) = record.imu(k0, k1), true_record.imu(k0, k1)
        for key, d, t in (("g", dth, tth), ("a", dv, tdv)):
            rows[key][0].append([(k1 - k0) * record.dt, *t.sum(0)])
            rows[key][1].append((d - t).sum(0))
    out = {}
    for key, (design, rhs) in rows.items():
        sol = np.linalg.lstsq(np.array(design), np.array(rhs), rcond=None)[0]
        out[key] = sol[0], sol[1:].T  # b (3,), E (3, 3) with E[i, j] on d_true[j]
    return out


@pytest.mark.slow
def test_compensated_increments_lose_the_calibrated_errors(lab, tmp_path):
    root, res = lab
    raw = read_table_data(root / "raw" / "simulate-table.h5")
    true = read_table_data(root / "true" / "simulate-table.h5")
    terms = compensation_terms(root / "cal" / "calibrate-imu-compensation.yaml", "RLG-NAV")
    before = _fit(raw, true)
    after = _fit(CompensatedRecord.wrap(raw, terms), true)
    # the simulated errors through the file's keys: the fit of the raw data finds them
    # (this holds the file's sign conventions to the simulator's, misalignments too)
    sim = yaml.safe_load((root / "raw.yaml").read_text())["imu"]
    g, a = sim["gyro"], sim["accel"]
    true_terms = compensation_terms(
        comp_file(
            tmp_path / "truth.yaml",
            g["bias_dph"],
            a["bias_ug"],
            gyro_scale_ppm=g["scale_ppm"],
            accel_scale_ppm=a["scale_ppm"],
            gyro_misalignment_arcsec=g["misalignment_arcsec"],
            accel_misalignment_arcsec=a["misalignment_arcsec"],
        )
    )
    sig_bg = np.array([res[f"discrete_bg_{a}_sigma_dph"] for a in "xyz"]) * DPH
    sig_ba = np.array([res[f"discrete_ba_{a}_sigma_ug"] for a in "xyz"]) * UG
    sig_sg = np.array([res[f"discrete_sg_{a}_sigma_ppm"] for a in "xyz"]) * PPM
    sig_sa = np.array([res[f"discrete_sa_{a}_sigma_ppm"] for a in "xyz"]) * PPM
    sig_mg = max(res[f"discrete_mg_{k}_sigma_arcsec"] for k in MG) * ARCSEC
    sig_ma = max(res[f"discrete_ma_{k}_sigma_arcsec"] for k in ("yx", "zx", "zy")) * ARCSEC
    b_g, e_g = before["g"]
    b_a, e_a = before["a"]
    np.testing.assert_array_less(np.abs(b_g - true_terms.gyro_bias()), 4 * sig_bg)
    np.testing.assert_array_less(np.abs(b_a - true_terms.accel_bias()), 4 * sig_ba)
    m_g, m_a = true_terms.gyro_matrix() - np.eye(3), true_terms.accel_matrix() - np.eye(3)
    np.testing.assert_array_less(np.abs(np.diag(e_g - m_g)), 4 * sig_sg)
    np.testing.assert_array_less(np.abs(np.diag(e_a - m_a)), 4 * sig_sa)
    assert np.abs(e_g - m_g).max() < 4 * max(sig_mg, sig_sg.max())
    assert np.abs(e_a - m_a).max() < 4 * max(sig_ma, sig_sa.max())
    np.testing.assert_array_less(5 * sig_ba, np.abs(b_a))  # errors well above the noise
    np.testing.assert_array_less(5 * sig_bg[:2], np.abs(b_g[:2]))
    np.testing.assert_array_less(5 * sig_sg, np.abs(np.diag(e_g)))
    # compensated: what is left is zero within the calibration's uncertainty
    b_g, e_g = after["g"]
    b_a, e_a = after["a"]
    np.testing.assert_array_less(np.abs(b_g), 4 * sig_bg)
    np.testing.assert_array_less(np.abs(b_a), 4 * sig_ba)
    np.testing.assert_array_less(np.abs(np.diag(e_g)), 4 * sig_sg)
    np.testing.assert_array_less(np.abs(np.diag(e_a)), 4 * sig_sa)
    assert np.abs(e_g - np.diag(np.diag(e_g))).max() < 4 * sig_mg
    assert np.abs(e_a - np.diag(np.diag(e_a))).max() < 4 * sig_ma
    print(
        "bias before/after (deg/h, ug):",
        before["g"][0] / DPH,
        b_g / DPH,
        before["a"][0] / UG,
        b_a / UG,
    )
    print(
        "scale before/after (ppm):",
        np.diag(before["g"][1]) / PPM,
        np.diag(e_g) / PPM,
        np.diag(before["a"][1]) / PPM,
        np.diag(e_a) / PPM,
    )


def _beta(out):
    res = json.loads((out / "summary.json").read_text())["results"]
    return np.array([res["beta_x_dph"], res["beta_y_dph"]]), res["beta_x_sigma_dph"]


def test_calibrate_bias_on_compensated_data_finds_what_is_left(tmp_path):
    # the shipped simulation (gyro biases 0.0096, -0.0204 deg/h): a file removing
    # (0.01, -0.02) deg/h shifts both estimates by exactly that (the methods are
    # linear in a constant bias; measured 1e-9 deg/h), one removing the truth leaves
    # zero within the method's 4 sigma
    plain = invoke("calibrate-bias", "-o", tmp_path / "plain", "--set", "checks=[]")
    assert plain.exit_code == 0, plain.output
    comp = comp_file(tmp_path / "c.yaml", (0.01, -0.02, 0.0), (30.0, 0.0, 0.0))
    done = invoke(
        "calibrate-bias",
        "-o",
        tmp_path / "c",
        "--set",
        f"compensation={comp}",
        "--set",
        "checks=[]",
    )
    assert done.exit_code == 0, done.output
    (b0, sigma), (b1, _) = _beta(tmp_path / "plain"), _beta(tmp_path / "c")
    np.testing.assert_allclose(b1 - b0, [-0.01, 0.02], atol=1e-6)
    truth = comp_file(tmp_path / "t.yaml", (0.0096, -0.0204, 0.005))
    done = invoke(
        "calibrate-bias",
        "-o",
        tmp_path / "t",
        "--set",
        f"compensation={truth}",
        "--set",
        "checks=[]",
    )
    assert done.exit_code == 0, done.output
    b2, sigma = _beta(tmp_path / "t")
    assert np.abs(b2).max() < 4 * sigma and np.abs(b0).max() > 10 * sigma


def test_another_serial_or_version_is_refused_naming_file_and_key(tmp_path):
    other = comp_file(tmp_path / "other.yaml", serial="OTHER-7")
    done = invoke(
        "calibrate-bias",
        "-o",
        tmp_path / "o",
        "--set",
        f"compensation={other}",
        "--set",
        "compensation_serial=SIM-0001",
    )
    assert done.exit_code == 2
    assert "other.yaml" in done.output and "unit" in done.output and "OTHER-7" in done.output
    assert not (tmp_path / "o" / "summary.json").exists()
    v2 = comp_file(tmp_path / "v2.yaml")
    v2.write_text(v2.read_text().replace("version: 1", "version: 2"))
    done = invoke("calibrate-bias", "-o", tmp_path / "o", "--set", f"compensation={v2}")
    assert done.exit_code == 2
    assert "v2.yaml" in done.output and "version" in done.output
    done = invoke("calibrate-bias", "-o", tmp_path / "o", "--set", "compensation=missing.yaml")
    assert done.exit_code == 2 and "compensation" in done.output


def test_run_ekf_refuses_a_compensation_for_a_simulated_flight(tmp_path):
    comp = comp_file(tmp_path / "c.yaml")
    done = invoke(
        "run-ekf",
        CONFIGS / "run-ekf" / "default.yaml",
        "-o",
        tmp_path / "o",
        "--set",
        f"compensation={comp}",
    )
    assert done.exit_code == 2 and "compensation" in done.output


def test_import_log_stores_compensated_increments_with_the_file_named(tmp_path):
    # the RLG excerpt (pulse counts): with a compensation file the stored increments
    # are float64 SI, equal to the file's compensation of the plain import's, and the
    # hold's mean rate and specific force move by minus the file's biases
    plain = invoke("import-log", "-o", tmp_path / "plain")
    assert plain.exit_code == 0, plain.output
    comp = comp_file(
        tmp_path / "c.yaml", (0.5, -0.3, 0.2), (100.0, -50.0, 80.0), gyro_scale_ppm=[20, 0, -10]
    )
    done = invoke("import-log", "-o", tmp_path / "c", "--set", f"compensation={comp}")
    assert done.exit_code == 0, done.output
    a = read_table_data(tmp_path / "plain" / "import-log.h5")
    b = read_table_data(tmp_path / "c" / "import-log.h5")
    terms = compensation_terms(comp)
    (th_a, dv_a), (th_b, dv_b) = a.imu(), b.imu()
    want_th, want_dv = imu_model.compensate(th_a, dv_a, a.dt, terms)
    np.testing.assert_allclose(th_b, want_th, rtol=0, atol=1e-18)
    np.testing.assert_allclose(dv_b, want_dv, rtol=0, atol=1e-15)
    T = a.n_samples * a.dt
    shift_g = (th_b.sum(0) - th_a.sum(0)) / T / DPH
    assert np.abs(shift_g - [-0.5, 0.3, -0.2]).max() < 1e-3  # scale part: 20 ppm of 15 deg/h
    shift_a = (dv_b.sum(0) - dv_a.sum(0)) / T / UG
    assert np.abs(shift_a - [-100.0, 50.0, -80.0]).max() < 1e-6
    with h5py.File(tmp_path / "c" / "import-log.h5") as f:
        assert f["imu/dtheta"].dtype == np.float64
        assert f["import"].attrs["compensation_file"] == "c.yaml"
        assert (
            f["import"].attrs["compensation_sha256"]
            == hashlib.sha256(comp.read_bytes()).hexdigest()
        )
    with h5py.File(tmp_path / "plain" / "import-log.h5") as f:
        assert f["imu/dtheta"].dtype == np.int32 and "compensation_file" not in f["import"].attrs

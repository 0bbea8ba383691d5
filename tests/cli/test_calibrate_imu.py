"""inins calibrate-imu through the CLI: shipped scenarios, planner, compensation file,
certificate, bad input."""

import json
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from inins.cli import app

CONFIGS = Path(__file__).parents[2] / "configs"
DEFAULT = CONFIGS / "calibrate-imu" / "default.yaml"
RATE = 50  # Hz: the shipped schedule at a quarter of its rate (the same white-noise sigma)


def run(*args):
    return CliRunner().invoke(app, ["calibrate-imu", *map(str, args)])


@pytest.fixture(scope="module")
def default_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("calimu")
    result = run(DEFAULT, "-o", out, "--plot", "--set", f"simulate.imu.sample_rate_hz={RATE}")
    assert result.exit_code == 0, result.output
    return out


def test_default_gives_every_term_with_sigma_and_expanded_uncertainty(default_run):
    summary = json.loads((default_run / "summary.json").read_text())
    res = summary["results"]
    for name, unit in (("bg_x", "dph"), ("sa_y", "ppm"), ("mg_zy", "arcsec"), ("ba_z", "ug")):
        value = res[f"discrete_{name}_{unit}"]
        sigma = res[f"discrete_{name}_sigma_{unit}"]
        assert res[f"discrete_{name}_u_{unit}"] == pytest.approx(2 * sigma)
        assert abs(value - summary["truth"][f"discrete_{name}_{unit}"]) < 4 * sigma
    assert summary["verdict"] == "pass" if "verdict" in summary else True
    report = (default_run / "calibrate-imu.txt").read_text()
    assert "residuals per interval" in report and "compensation file" in report
    assert "rate-x+" in report and "U (k=2)" in report


def test_plot_writes_figures_certificate_and_compensation(default_run):
    assert (default_run / "calibrate-imu-residuals.png").stat().st_size > 1000
    page = (default_run / "calibrate-imu-certificate.html").read_text()
    assert "data:image/png;base64," in page and "RLG-NAV" in page and "SIM-0001" in page
    assert "<script" not in page and "http" not in page.replace("http-equiv", "")
    comp = yaml.safe_load((default_run / "calibrate-imu-compensation.yaml").read_text())
    assert comp["format"] == "inins-compensation" and comp["unit"]["serial"] == "SIM-0001"
    assert len(comp["imu"]["gyro_misalignment_arcsec"]) == 6


def test_compensated_rerun_finds_what_is_left(default_run, tmp_path):
    # the compensation file applied to the same (simulated) log: the terms left are
    # zero within their uncertainty; the mounting is not compensated and stays
    comp = default_run / "calibrate-imu-compensation.yaml"
    data = yaml.safe_load(DEFAULT.read_text())
    data.pop("checks")
    data["compensation"] = str(comp)
    data["simulate"]["imu"]["sample_rate_hz"] = RATE
    scen = tmp_path / "again.yaml"
    scen.write_text(yaml.safe_dump(data))
    result = run(scen, "-o", tmp_path / "out")
    assert result.exit_code == 0, result.output
    res = json.loads((tmp_path / "out" / "summary.json").read_text())["results"]
    first = json.loads((default_run / "summary.json").read_text())["results"]
    for key, value in res.items():
        if not key.startswith("discrete_") or "_sigma_" in key or "_u_" in key:
            continue
        name = key.removeprefix("discrete_")
        if name.startswith(("mount", "chi2", "dof", "intervals", "holds", "spins", "insep")):
            continue
        unit = name.rsplit("_", 1)[1]
        sigma = res[key.replace(f"_{unit}", f"_sigma_{unit}")]
        # same data, same noise: the left-over is the rounding of the file's digits
        assert abs(value) < 1e-3 * sigma, (key, value, sigma)
    assert res["discrete_mount_x_arcsec"] == pytest.approx(first["discrete_mount_x_arcsec"])


def test_compensation_of_another_unit_is_refused(default_run, tmp_path):
    comp = yaml.safe_load((default_run / "calibrate-imu-compensation.yaml").read_text())
    comp["unit"]["serial"] = "OTHER-7"
    path = tmp_path / "other.yaml"
    path.write_text(yaml.safe_dump(comp))
    result = run(DEFAULT, "-o", tmp_path / "o", "--set", f"compensation={path}")
    assert result.exit_code == 2
    assert "other.yaml" in result.output and "OTHER-7" in result.output


def test_compensation_of_another_version_is_refused(default_run, tmp_path):
    comp = yaml.safe_load((default_run / "calibrate-imu-compensation.yaml").read_text())
    comp["version"] = 2
    path = tmp_path / "v2.yaml"
    path.write_text(yaml.safe_dump(comp))
    result = run(DEFAULT, "-o", tmp_path / "o", "--set", f"compensation={path}")
    assert result.exit_code == 2
    assert "v2.yaml" in result.output and "version" in result.output


def test_plan_only_reports_sigma_without_data(tmp_path):
    result = run(DEFAULT, "-o", tmp_path, "--set", "plan.only=true", "--set", "checks=[]")
    assert result.exit_code == 0, result.output
    res = json.loads((tmp_path / "summary.json").read_text())["results"]
    assert res["plan_inseparable"] == 0
    assert res["plan_sg_z_sigma_ppm"] > 0


def test_schedule_that_cannot_separate_is_refused_naming_the_terms(tmp_path):
    # only the level positions (outer pitch 0) and no rate test: exit 2, naming terms
    data = yaml.safe_load(DEFAULT.read_text())
    motion = data["simulate"]["motion"]
    data["simulate"]["motion"] = [m for m in motion[:12] if m.get("axis") != "pitch"]
    data.pop("checks")
    path = tmp_path / "level.yaml"
    path.write_text(yaml.safe_dump(data))
    result = run(path, "-o", tmp_path / "o")
    assert result.exit_code == 2, result.output
    assert "cannot separate" in result.output and "sa_x" in result.output
    assert "estimate" in result.output
    # told to estimate the separable combinations instead, it runs
    result = run(path, "-o", tmp_path / "o2", "--set", "plan.allow_combinations=true")
    assert result.exit_code == 0, result.output


def test_xsens_real_log_runs_and_passes_its_checks(tmp_path):
    result = run(CONFIGS / "calibrate-imu" / "xsens-real.yaml", "-o", tmp_path)
    assert result.exit_code == 0, result.output
    res = json.loads((tmp_path / "summary.json").read_text())["results"]
    assert res["table_free_static_intervals"] == 38
    assert res["table_free_gravity_norm_rms_after_mps2"] < 2e-3
    # the compensation file is written on every run, --plot or not
    comp = yaml.safe_load((tmp_path / "calibrate-imu-compensation.yaml").read_text())
    assert comp["method"] == "table-free" and comp["unit"]["name"] == "Xsens"


def test_saturated_counts_are_refused_naming_file_and_line(tmp_path):
    rows = np.column_stack([np.arange(2000) * 0.01, np.full((2000, 3), 33000.0)])
    rows[700, 2] = 65535.0
    acc, gyro = tmp_path / "acc.txt", tmp_path / "gyro.txt"
    np.savetxt(acc, rows)
    np.savetxt(gyro, rows)
    scen = tmp_path / "s.yaml"
    scen.write_text(f"methods: [table-free]\nlog: {{accel_file: {acc}, gyro_file: {gyro}}}\n")
    result = run(scen, "-o", tmp_path / "o")
    assert result.exit_code == 2
    assert "acc.txt:701" in result.output and "saturated" in result.output


def test_too_few_positions_are_refused(tmp_path):
    rows = np.column_stack([np.arange(6000) * 0.01, np.full((6000, 3), 33000.0)])
    rows[:, 1:] += np.random.default_rng(0).normal(0, 2, (6000, 3))
    acc, gyro = tmp_path / "acc.txt", tmp_path / "gyro.txt"
    np.savetxt(acc, rows)
    np.savetxt(gyro, rows)
    scen = tmp_path / "s.yaml"
    scen.write_text(
        f"methods: [table-free]\nlog: {{accel_file: {acc}, gyro_file: {gyro}}}\n"
        "table_free: {lat_deg: 45.0}\n"
    )
    result = run(scen, "-o", tmp_path / "o")
    assert result.exit_code == 2
    assert "static intervals usable" in result.output and "table_free.detector" in result.output


def test_unknown_key_and_two_sources_are_bad_input(tmp_path):
    result = run(DEFAULT, "-o", tmp_path, "--set", "plan.bogus=1")
    assert result.exit_code == 2 and "bogus" in result.output
    result = run(DEFAULT, "-o", tmp_path, "--set", "data=x.h5")
    assert result.exit_code == 2 and "exactly one of" in result.output


CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
SKIP_CHROMIUM = pytest.mark.skipif(
    CHROMIUM is None,
    reason="certificate rendering: no chromium on this machine (Debian's chromium package; "
    ".ci/run installs it)",
)


def _chromium(*args):
    return subprocess.run(
        [
            CHROMIUM,
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--no-first-run",
            "--enable-logging=stderr",
            "--v=0",
            *args,
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )


def test_certificate_says_what_a_lab_signs(default_run):
    page = (default_run / "calibrate-imu-certificate.html").read_text()
    assert "<title>Calibration certificate</title>" in page
    # lab units, not result-name suffixes
    assert "µg" in page and "°/h" in page and "arcsec" in page and "ppm" in page
    assert ">ug<" not in page and ">dph<" not in page
    # value and U to U's two significant digits: "x.xx</td><td>0.0y" style rows
    summary = json.loads((default_run / "summary.json").read_text())["results"]
    from inins.commands.calibrate_imu_certificate import value_with_uncertainty

    v, u = value_with_uncertainty(summary["discrete_ba_x_ug"], summary["discrete_ba_x_u_ug"])
    assert f"<td class='n'>ba_x</td><td>{v}</td><td>{u}</td>" in page
    assert len(u.replace("0.", "").lstrip("0").replace(".", "")) == 2  # two digits of U
    for text in ("Legend", "misalignment of gyro i toward axis j", "calibration date (UTC)"):
        assert text in page
    assert "the gyro bias is the sensor&#x27;s alone" in page and "all 24 terms separable" in page


def test_certificate_escapes_and_wraps_the_serial(tmp_path):
    serial = "<script>alert(1)</script>&" + "X" * 120
    result = run(
        DEFAULT,
        "-o",
        tmp_path,
        "--plot",
        "--set",
        f"simulate.imu.sample_rate_hz={RATE}",
        "--set",
        "checks=[]",
        "--set",
        f"unit.serial={serial}",
    )
    assert result.exit_code == 0, result.output
    page = (tmp_path / "calibrate-imu-certificate.html").read_text()
    assert "<script>" not in page and "&lt;script&gt;alert(1)&lt;/script&gt;&amp;" in page
    assert "word-break:break-all" in page


@SKIP_CHROMIUM
def test_certificate_renders_in_headless_chromium_and_prints_on_a4(default_run, tmp_path):
    page = default_run / "calibrate-imu-certificate.html"
    shot = tmp_path / "certificate.png"
    out = _chromium(f"--screenshot={shot}", "--window-size=800,1130", page.as_uri())
    assert shot.is_file() and shot.stat().st_size > 5000, out.stderr[-2000:]
    console = [line for line in out.stderr.splitlines() if "CONSOLE" in line]
    assert console == [], console
    pdf = tmp_path / "certificate.pdf"
    out = _chromium(f"--print-to-pdf={pdf}", "--no-pdf-header-footer", page.as_uri())
    data = pdf.read_bytes()
    assert data.startswith(b"%PDF"), out.stderr[-2000:]
    # every page A4 (595 x 842 pt), and the certificate on a few of them
    import re

    boxes = re.findall(rb"/MediaBox\s*\[\s*0\s+0\s+([\d.]+)\s+([\d.]+)\s*\]", data)
    assert boxes and all(abs(float(w) - 595.3) < 1 and abs(float(h) - 841.9) < 1 for w, h in boxes)
    assert len(boxes) <= 4


def test_static_log_planner_says_what_it_can_and_cannot_give(tmp_path):
    # the schedule of the real RLG log: one position, attitude from the unit itself
    scen = CONFIGS / "calibrate-imu" / "rlg-static-plan.yaml"
    result = run(scen, "-o", tmp_path, "--plot")
    assert result.exit_code == 0, result.output
    plan = (tmp_path / "calibrate-imu-certificate.html").read_text()
    assert "<title>Calibration plan</title>" in plan and "Calibration certificate" not in plan
    assert "Nothing was measured" in plan
    assert "nothing estimated" in (tmp_path / "calibrate-imu-compensation.yaml").read_text()
    res = json.loads((tmp_path / "summary.json").read_text())["results"]
    assert res["plan_ba_z_sigma_ug"] > 0  # the vertical accelerometer bias: separable
    for name in ("ba_x_sigma_ug", "ba_y_sigma_ug", "bg_x_sigma_dph", "mount_z_sigma_arcsec"):
        assert res[f"plan_{name}"] is None, name
    report = (tmp_path / "calibrate-imu.txt").read_text()
    # accelerometer bias against tilt: 1 ug is 0.206 arcsec of tilt (1 / g)
    assert "+1 ba_x[ug] +0.206 mount_y[arcsec]" in report
    # asked for every term without leave to estimate combinations: refused, exit 2
    result = run(
        scen,
        "-o",
        tmp_path / "all",
        "--set",
        "plan.allow_combinations=false",
        "--set",
        "estimate=[accel_bias, gyro_bias, accel_scale, gyro_scale, mount]",
    )
    assert result.exit_code == 2
    assert "cannot separate" in result.output and "sg_x" in result.output


def test_data_file_with_the_wrong_imu_axes_is_refused(tmp_path):
    # the schedule written by simulate-table, read back as a data file: the nominal IMU
    # axes are the scenario's to give; wrong ones are bad input, right ones calibrate
    sim = yaml.safe_load(DEFAULT.read_text())["simulate"]
    sim["imu"]["sample_rate_hz"] = 20
    (tmp_path / "sim.yaml").write_text(yaml.safe_dump(sim))
    out = CliRunner().invoke(
        app, ["simulate-table", str(tmp_path / "sim.yaml"), "-o", str(tmp_path)]
    )
    assert out.exit_code == 0, out.output
    scen = tmp_path / "cal.yaml"
    scen.write_text("data: simulate-table.h5\nimu_axes: [right, forward, up]\n")
    result = run(scen, "-o", tmp_path / "bad")
    assert result.exit_code == 2
    assert "imu_axes" in result.output and "check the IMU axes" in result.output
    scen.write_text("data: simulate-table.h5\nimu_axes: [forward, right, down]\n")
    result = run(scen, "-o", tmp_path / "good")
    assert result.exit_code == 0, result.output
    res = json.loads((tmp_path / "good" / "summary.json").read_text())["results"]
    assert abs(res["discrete_sg_z_ppm"] - 8.0) < 4 * res["discrete_sg_z_sigma_ppm"]


def test_positions_not_found_are_bad_input(tmp_path):
    result = run(
        CONFIGS / "calibrate-imu" / "xsens-real.yaml",
        "-o",
        tmp_path,
        "--set",
        "table_free.use_positions=[0, 40]",
    )
    assert result.exit_code == 2
    assert "table_free.use_positions" in result.output and "38 static intervals" in result.output


def _scenario(tmp_path, config, motion=None, **top):
    data = yaml.safe_load((CONFIGS / "calibrate-imu" / config).read_text())
    data.pop("checks", None)
    data["simulate"]["imu"]["sample_rate_hz"] = 20
    if motion is not None:
        data["simulate"]["motion"] = motion
    data.update(top)
    path = tmp_path / "s.yaml"
    path.write_text(yaml.safe_dump(data))
    return path


ROLLS = [{"kind": "hold", "duration_s": 20, "label": "init"}] + [
    step
    for k in range(11)
    for step in (
        {"kind": "rotate", "axis": "roll", "angle_deg": 30 + 5 * (k % 3), "rate_dps": 60},
        {"kind": "hold", "duration_s": 6},
    )
]


@pytest.mark.parametrize("only", [True, False])
def test_table_free_rolls_only_is_refused_naming_the_null_space(tmp_path, only):
    # turns about body x alone: the x accelerometer never sees gravity (ba_x, sa_x, ma_yx,
    # ma_zx free); the planner and the run say so alike, exit 2, nothing written
    scen = _scenario(tmp_path, "table-free-mems.yaml", ROLLS)
    result = run(scen, "-o", tmp_path / "o", "--set", f"plan.only={str(only).lower()}")
    assert result.exit_code == 2, result.output
    assert "table-free: the schedule cannot separate" in result.output
    for name in ("ba_x", "sa_x", "ma_yx", "ma_zx"):
        assert name in result.output
    assert not (tmp_path / "o" / "calibrate-imu-compensation.yaml").exists()


LEVEL = [{"kind": "hold", "duration_s": 30.0}, {"kind": "rotate", "axis": "yaw", "angle_deg": 90}]
LEVEL += [{"kind": "hold", "duration_s": 10.0}]
for _ in range(8):
    LEVEL += [
        {"kind": "rotate", "axis": "pitch", "angle_deg": 90},
        {"kind": "hold", "duration_s": 10.0},
    ]
YAW = [{"kind": "hold", "duration_s": 30.0}]
for _ in range(8):
    YAW += [
        {"kind": "rotate", "axis": "yaw", "angle_deg": 90},
        {"kind": "hold", "duration_s": 10.0},
    ]


@pytest.mark.parametrize(
    "motion, only, names",
    [
        (YAW, True, ("sa_x", "sa_y", "ma_zy")),
        (LEVEL, True, ("sa_x", "ma_yx", "ma_zx")),
        (LEVEL, False, ("sa_x", "ma_yx", "ma_zx")),
    ],
)
def test_system_level_degenerate_sequences_are_refused(tmp_path, motion, only, names):
    # yaw turns only, or the x axis level throughout: the filter's information leaves
    # combinations free; refused with them named (no sigma at the prior, no compensation)
    scen = _scenario(tmp_path, "system-level-19.yaml", motion)
    result = run(scen, "-o", tmp_path / "o", "--set", f"plan.only={str(only).lower()}")
    assert result.exit_code == 2, result.output
    assert "system-level: the schedule cannot separate" in result.output
    for name in names:
        assert name in result.output
    # told to estimate the combinations, the run reports those terms without a sigma
    if not only:
        result = run(scen, "-o", tmp_path / "c", "--set", "plan.allow_combinations=true")
        assert result.exit_code == 0, result.output
        res = json.loads((tmp_path / "c" / "summary.json").read_text())["results"]
        assert res["system_sa_x_sigma_ppm"] is None and res["system_sa_x_ppm"] is None
        assert res["system_sa_z_sigma_ppm"] > 0 and res["system_inseparable"] >= 3
        comp = yaml.safe_load((tmp_path / "c" / "calibrate-imu-compensation.yaml").read_text())
        assert "sa_x" in comp["not_determined"] and comp["imu"]["accel_scale_ppm"][0] == 0.0


def test_max_sigma_is_one_rule_for_the_plan_and_the_run(tmp_path):
    # the discrete schedule with 5-s holds at 20 Hz: scale-factor 1-sigma of a few ppm
    for only in ("true", "false"):
        result = run(
            DEFAULT,
            "-o",
            tmp_path / only,
            "--set",
            "simulate.imu.sample_rate_hz=20",
            "--set",
            "checks=[]",
            "--set",
            "plan.max_sigma_ppm=0.001",
            "--set",
            f"plan.only={only}",
        )
        assert result.exit_code == 2, result.output
        assert "plan.max_sigma_ppm" in result.output and "predicted 1-sigma above" in result.output


@pytest.mark.parametrize(
    "case, message",
    [
        ("constant", "accelerometer x, accelerometer y, accelerometer z give the same count"),
        ("zero", "read their nominal zero"),
        ("stuck", "accelerometer y give the same count at every sample"),
    ],
)
def test_raw_counts_that_cannot_be_calibrated_are_bad_input(tmp_path, case, message):
    n = 6000
    rng = np.random.default_rng(0)
    acc = np.column_stack([np.arange(n) * 0.01, np.full((n, 3), 32768.0)])
    gyro = acc.copy()
    gyro[:, 1:] += rng.normal(0, 2, (n, 3))
    if case == "stuck":
        acc[:, 1:] += rng.normal(0, 2, (n, 3))
        acc[:, 2] = 33000.0
    elif case == "zero":  # moving about the nominal zero, mean exactly zero
        acc[:, 1:] += np.where(np.arange(n) % 2, 1.0, -1.0)[:, None]
    np.savetxt(tmp_path / "acc.txt", acc)
    np.savetxt(tmp_path / "gyro.txt", gyro)
    scen = tmp_path / "s.yaml"
    scen.write_text(
        "methods: [table-free]\nlog: {accel_file: acc.txt, gyro_file: gyro.txt}\n"
        "table_free: {earth_rate: imu_tk}\n"
    )
    result = run(scen, "-o", tmp_path / "o")
    assert result.exit_code == 2, result.output
    assert message in result.output and "acc.txt" in result.output

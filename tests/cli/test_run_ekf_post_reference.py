"""run-ekf ``post.reference``: the shipped lc-drive-15s scenario scored against a
reference trajectory derived from its own RTK fixes (UTC time tags, a known 1 m north
offset), and a bad reference file (exit 2 naming file and line)."""

import importlib.util
import json

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

from inins.cli import app
from inins.commands import run_ekf_post
from inins.io import solution_files as sf
from tests.helpers import CONFIGS

RUN = CONFIGS / "run-ekf"
DATA = CONFIGS.parent / "data" / "lc-drive"
if not (DATA / "imu_1934.csv.gz").exists():
    DATA = CONFIGS.parent.parent / "shared" / "data" / "lc-drive"
pytestmark = pytest.mark.skipif(
    not (DATA / "imu_1934.csv.gz").exists(),
    reason="the lc-drive data (data/lc-drive/ or ../shared/data/lc-drive/) is absent",
)
LEAP_2024_S = 18.0
"""GPS - UTC in July 2024 (s)."""
NORTH_M = 1.0
"""The offset put into the reference: it lies this far north of the RTK fixes (m)."""


def run(*args):
    return CliRunner().invoke(app, ["run-ekf", *map(str, args)])


def reference_csv(path, north=NORTH_M):
    """The RTK-fixed epochs (Q = 1) of the lc-drive .pos as a reference CSV: Unix time
    (UTC), lat/lon in deg ``north`` m north of the fix, height, NED velocity as vn/ve/vu."""
    sol = sf.read_rtklib_pos(DATA / "gnss_1934_sf.pos.gz")
    sol = sol.select(sol.q == 1)
    from inins.core import error_model

    lla = error_model.lla_offset(sol.lla, np.tile([north, 0.0, 0.0], (len(sol), 1)))
    unix = sol.time - LEAP_2024_S + sf.UNIX_GPS_EPOCH_S
    rows = ["unix_s,lat_deg,lon_deg,h_m,vn,ve,vu"]
    for i in range(len(sol)):
        lat, lon = np.degrees(lla[i, :2])
        vn, ve, vd = sol.vel_ned[i]
        rows.append(
            f"{unix[i]:.3f},{lat:.10f},{lon:.10f},{lla[i, 2]:.4f},{vn:.4f},{ve:.4f},{-vd:.4f}"
        )
    path.write_text("\n".join(rows) + "\n")
    return path


SECTION = """  reference:
    file: {file}
    format: csv
    columns: {{time: unix_s, lat: lat_deg, lon: lon_deg, height: h_m, vel_n: vn, vel_e: ve,
               vel_u: vu}}
    time_system: unix
    lever_arm_m: [0.0, -0.05, 0.0]
"""


def scenario(tmp_path, ref):
    """lc-drive-15s.yaml with a ``post.reference`` section naming ``ref``."""
    text = (RUN / "lc-drive-15s.yaml").read_text()
    text = text.replace("../../data/lc-drive/", f"{DATA}/")
    text = text.replace("  outages:\n", SECTION.format(file=ref) + "  outages:\n")
    path = tmp_path / "s.yaml"
    path.write_text(text)
    return path


@pytest.fixture(scope="module")
def scored(tmp_path_factory):
    path = tmp_path_factory.mktemp("lc15-reference")
    plot = ["--plot"] if importlib.util.find_spec("matplotlib") else []
    out = run(scenario(path, reference_csv(path / "ref.csv")), "-o", path / "out", *plot)
    assert out.exit_code == 0, out.output
    return path / "out"


def test_reference_offset_moves_the_scores_by_it(scored):
    """The reference is the RTK fixes put 1.00 m north, tagged in Unix time (UTC: 18 leap
    seconds, which if missed put the reference 18 s x ~10 m/s off). The solution minus
    the reference is then the error against the fixes minus 1 m north: its mean north
    component -1.00 m (within 5 cm: the smoothed error against the fixes is ~0.1 m RMS
    with outages), horizontal RMS ~1 m (0.9-1.1 m). Adding 1 m back to the stored errors
    gives, per outage window, the built-in drift scores against the same fixes
    (``post_sm_drift_hor_*``) within 1 cm (the two interpolate the solution differently)."""
    r = json.loads((scored / "summary.json").read_text())["results"]
    assert set(r) == set(run_ekf_post.RESULT_NAMES)
    assert r["post_ref_epochs"] > 2000
    for p in ("fwd", "sm"):
        assert r[f"post_ref_{p}_hor_max_m"] >= r[f"post_ref_{p}_hor_p95_m"]
        assert r[f"post_ref_{p}_heading_rms_deg"] is None  # no attitude in the reference
    assert 0.9 < r["post_ref_sm_hor_rms_m"] < 1.1
    assert r["post_ref_sm_vel_rms_mps"] < 0.3
    with h5py.File(scored / "run-ekf.h5") as f:
        err = f["post/reference_trajectory/smoothed/pos_error_ned"][:]
        t = f["post/reference_trajectory/smoothed/time"][:]
        windows = f["post/outage_windows"][:]
        assert f["post/reference_trajectory/lla"].shape[1] == 3
    assert np.mean(err[:, 0]) == pytest.approx(-NORTH_M, abs=0.05)
    err[:, 0] += NORTH_M
    hor = np.hypot(err[:, 0], err[:, 1])
    drift = [hor[(t >= a) & (t < b)].max() for a, b in windows]
    assert np.sqrt(np.mean(np.square(drift))) == pytest.approx(
        r["post_sm_drift_hor_rms_m"], abs=0.01
    )
    fwd_shifted = r["post_ref_fwd_drift_hor_rms_m"]
    assert fwd_shifted == pytest.approx(r["post_fwd_drift_hor_rms_m"], abs=NORTH_M + 0.01)
    report = (scored / "run-ekf.txt").read_text()
    assert "against the reference trajectory ref.csv" in report
    if importlib.util.find_spec("matplotlib"):
        for name in ("trajectory", "horizontal-error"):
            assert (scored / f"run-ekf-post-{name}.png").stat().st_size > 10_000


def _bad(tmp_path, kind):
    good = reference_csv(tmp_path / "good.csv").read_text().splitlines()
    if kind == "missing":
        good = [s.rsplit(",", 1)[0] for s in good]  # no vu column
    elif kind == "nan":
        f = good[7].split(",")
        f[1] = "nan"
        good[7] = ",".join(f)
    elif kind == "backwards":
        good[9], good[10] = good[10], good[9]  # line 11 before line 10
    bad = tmp_path / "bad.csv"
    bad.write_text("\n".join(good) + "\n")
    return bad


@pytest.mark.parametrize(
    ("kind", "expect"),
    [
        ("missing", ["bad.csv:1", "column 'vu' (for vel_u) not in the header"]),
        ("nan", ["bad.csv:8", "latitude NaN"]),
        ("backwards", ["bad.csv:11", "does not increase"]),
    ],
)
def test_bad_reference_exit_2_naming_file_and_line(tmp_path, kind, expect):
    out = run(scenario(tmp_path, _bad(tmp_path, kind)), "-o", tmp_path / "out")
    assert out.exit_code == 2, out.output
    for text in expect:
        assert text in out.stderr, out.stderr
    assert not (tmp_path / "out").exists() or list((tmp_path / "out").iterdir()) == []


@pytest.mark.parametrize(
    ("edit", "expect"),
    [
        (("vel_u: vu}", "vel_u: vu, sigma_n: s}"), ["post.reference.columns.sigma_n"]),
        (("vel_u: vu}", "vel_u: vu, roll: r}"), ["post.reference.columns.heading", "alone"]),
        (("format: csv", "format: rtklib"), ["post.reference.columns", "no columns"]),
        (("time_system: unix", "time_system: tai"), ["post.reference.time_system"]),
        (("lever_arm_m: [0.0, -0.05, 0.0]", "lever_arm_m: [0.0, 500, 0.0]"), ["lever_arm_m"]),
        (("time_system: unix", "time_system: unix\n    colour: red"), ["post.reference.colour"]),
    ],
)
def test_bad_reference_section_exit_2_naming_the_key(tmp_path, edit, expect):
    """A wrong ``post.reference`` section is refused when the scenario is loaded."""
    path = scenario(tmp_path, reference_csv(tmp_path / "ref.csv"))
    path.write_text(path.read_text().replace(*edit))
    out = run(path, "-o", tmp_path / "out")
    assert out.exit_code == 2, out.output
    for text in expect:
        assert text in out.stderr, out.stderr

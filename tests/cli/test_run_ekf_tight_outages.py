"""The outage protocol in the tight mode (``filter.outages_s``: the filter coasts, no
GNSS measurement used): per window the maximum horizontal / 3D drift against the
simulated truth and the heading error at its end, the RMS of the maxima, forward and
RTS-smoothed (:func:`inins.commands.run_ekf_report.tight_outages`)."""

import json

from typer.testing import CliRunner

from inins.cli import app
from tests.helpers import CONFIGS

TACTICAL = [
    "flight.legs=[{kind: wait, duration_s: 30}, {kind: takeoff, duration_s: 40, speed_mps: 80},"
    " {kind: turn, bank_deg: 30, angle_deg: 180}, {kind: straight, duration_s: 60},"
    " {kind: turn, bank_deg: 30, angle_deg: 180, direction: left},"
    " {kind: straight, duration_s: 40}]",
    "checks=[]",
    "filter.smoother=rts",
    "filter.turning_from_s=0",
    "flight.imu.gyro.bias_dph=[1.0,-1.0,0.5]",
    "flight.imu.gyro.arw_deg_rth=0.05",
    "flight.imu.accel.bias_ug=[500,-400,300]",
    "flight.imu.accel.vrw_ug_rthz=50",
    "filter.noise.arw_deg_rth=0.05",
    "filter.noise.vrw_ug_rthz=50",
    "filter.initial_sigma.gyro_bias_dph=2",
    "filter.initial_sigma.accel_bias_ug=1000",
    "filter.initial_sigma.heading_deg=1",
    "filter.outages_s=[[100, 160], [190, 230]]",
]
"""Paper 003's EKF2-FB flight, shortened (~265 s), on a tactical-grade unit (gyro bias
1 deg/h, accel bias 500 ug), with a 60 s and a 40 s outage."""


def test_tight_outages_smoothed_drift_below_forward(tmp_path):
    """Measured (seed 0): max horizontal drift forward 13.82 / 3.14 m, smoothed 0.69 /
    0.29 m; RMS forward 10.02 m, smoothed 0.53 m; heading at the ends RMS forward
    0.048 deg, smoothed 0.0065 deg. Asserted: smoothed RMS at most 1/3 of the forward
    one (issue 19's target; measured 1/19), the forward RMS within 5-20 m (an
    unestimated 500 ug bias alone drifts 0.5 a t^2 = 8.8 m in 60 s), and the smoothed
    heading error below the forward one (fails if the truth heading's sign flips)."""
    sets = [x for s in TACTICAL for x in ("--set", s)]
    out = CliRunner().invoke(
        app, ["run-ekf", str(CONFIGS / "paper003" / "ekf2-fb.yaml"), "-o", str(tmp_path), *sets]
    )
    assert out.exit_code == 0, out.output
    r = json.loads((tmp_path / "summary.json").read_text())["results"]
    assert r["outages_scored"] == 2
    assert 5.0 < r["outage_fwd_drift_hor_rms_m"] < 20.0
    assert r["outage_sm_drift_hor_rms_m"] < r["outage_fwd_drift_hor_rms_m"] / 3
    assert r["outage_sm_drift_3d_rms_m"] < r["outage_fwd_drift_3d_rms_m"] / 3
    assert r["outage_fwd_drift_3d_rms_m"] >= r["outage_fwd_drift_hor_rms_m"]
    assert r["outage_sm_heading_end_rms_deg"] < r["outage_fwd_heading_end_rms_deg"] < 0.5
    report = (tmp_path / "run-ekf.txt").read_text()
    assert "Outages (2, no GNSS measurement used)" in report

"""run-ekf's tight filter on four constellations of the smartLoc mixed RINEX 3 file, with
the receiver's inter-system biases simulated and estimated (one state per further system)."""

import json

import h5py
import numpy as np
from typer.testing import CliRunner

from inins.cli import app
from inins.ekf import config as ekf_config
from tests.helpers import CONFIGS

SHORT = (
    "flight.legs=[{kind: wait, duration_s: 30}, {kind: takeoff, duration_s: 40, speed_mps: 80},"
    " {kind: turn, bank_deg: 30, angle_deg: 180}, {kind: straight, duration_s: 20}]"
)
BIAS = {"R": 30.0, "E": -12.0, "C": 8.0}
"""True inter-system biases (m) of the simulated receiver against GPS."""
FLOW = "{" + ", ".join(f"{k}: {v}" for k, v in BIAS.items()) + "}"


def _run(tmp_path, *sets):
    args = ["run-ekf", str(CONFIGS / "paper003" / "ekf2-fb.yaml"), "-o", str(tmp_path)]
    for item in (
        SHORT,
        "checks=[]",
        "filter.turning_from_s=0",
        "gnss.constellation.source=mixed",
        "flight.site={lat_deg: 52.5, lon_deg: 13.4, height_m: 100.0}",
        "gnss.constellation.start_hour_s=64800",  # 18:00: Galileo and BeiDou in view
        *sets,
    ):
        args += ["--set", item]
    out = CliRunner().invoke(app, args)
    assert out.exit_code == 0, out.output
    with h5py.File(tmp_path / "run-ekf.h5") as f:
        names = [str(n) for n in f["ekf"].attrs["states"]]
        run = {
            "names": names,
            "estimate": f["states/estimate"][-1],
            "sigma": f["states/sigma"][-1],
            "n_sats": f["epochs/n_sats"][:],
            "nees": f["truth/nees"][:],
            **{k: f[f"innovations/{k}"][:] for k in ("prn", "kind", "value", "variance")},
            "accepted": f["innovations/accepted"][:].astype(bool),
        }
    run["results"] = json.loads((tmp_path / "summary.json").read_text())["results"]
    return run


def _normalised(run, system):
    """Pseudorange innovations of one system over their predicted sigma."""
    sel = (run["prn"] // 100 == system) & (run["kind"] == 0)
    return run["value"][sel] / np.sqrt(run["variance"][sel]), run["accepted"][sel]


def test_inter_system_biases_estimated_by_the_tight_filter(tmp_path):
    """Berlin, 18:00 GPS time (Galileo and BeiDou in view: the file has their sets from
    about 09:00 to 23:00; at 06:00 only GPS and GLONASS are simulated), 134 s flight with a
    180-deg turn, GPS + GLONASS + Galileo + BeiDou with true biases R 30 m, E -12 m,
    C 8 m. Each bias state
    ends within 3 sigma of its truth (measured: 29.92 +- 0.10, -12.15 +- 0.15,
    8.11 +- 0.19 m); the innovations of every system are unbiased (normalised means
    below 0.1); the NEES of all 29 states, which scores the bias states against the truth
    (a bias left out of the score would add (30 / 0.1)^2 = 9e4), averages 20.3; the
    position error RMS 0.54 m is not worse than GPS alone on the same satellites
    (0.74 m), with twice the satellites (median 20 against 10)."""
    r = _run(tmp_path / "grec", "filter.systems=GREC", f"gnss.system_bias_m={FLOW}")
    gps = _run(tmp_path / "g", "filter.systems=G")
    assert r["names"][:26] == gps["names"] and r["names"][26:] == ["isb_R", "isb_E", "isb_C"]
    for k, (letter, value) in enumerate(BIAS.items()):
        est, sigma = r["estimate"][26 + k], r["sigma"][26 + k]
        assert abs(est - value) < 3.0 * sigma, (letter, est, sigma)
        assert sigma < 1.0
    for system in (0, 1, 2, 3):
        z, _ = _normalised(r, system)
        assert z.size > 50 and abs(z.mean()) < 0.2, system
    assert np.mean(r["nees"]) < len(r["names"])
    assert np.median(r["n_sats"]) >= 2 * np.median(gps["n_sats"])
    assert r["results"]["pos_err_rms_m"] <= gps["results"]["pos_err_rms_m"]
    assert r["results"]["pos_err_rms_m"] < 1.0 and r["results"]["vel_err_rms_mps"] < 0.05
    assert 0.8 < r["results"]["nis_mean"] < 1.2


def test_without_the_bias_state_the_glonass_innovations_are_biased(tmp_path, monkeypatch):
    """The mutation: GLONASS rows given the receiver clock alone (no bias state). The
    30 m bias then sits in every GLONASS innovation and the gate rejects them, while the
    GPS rows stay unbiased (measured: normalised mean of the GLONASS rows 14.8, all 938
    rejected)."""
    monkeypatch.setattr(ekf_config.FilterConfig, "bias_names", property(lambda self: ()))
    monkeypatch.setattr(
        ekf_config.FilterConfig, "bias_columns", lambda self: np.array([-1, -1, -2, -2, -2, -2])
    )
    r = _run(tmp_path, "filter.systems=GR", "gnss.system_bias_m={R: 30}")
    assert "isb_R" not in r["names"]
    z, accepted = _normalised(r, 1)
    assert z.mean() > 5.0 and accepted.mean() < 0.1
    z_gps, _ = _normalised(r, 0)
    assert abs(z_gps.mean()) < 0.2


def test_a_bias_for_a_system_not_simulated_is_refused(tmp_path):
    args = ["run-ekf", str(CONFIGS / "paper003" / "ekf1-ff.yaml"), "-o", str(tmp_path)]
    done = CliRunner().invoke(app, [*args, "--set", "gnss.system_bias_m={R: 30}"])
    assert done.exit_code == 2
    assert "gnss.system_bias_m" in done.output and "does not use" in done.output
    done = CliRunner().invoke(app, [*args, "--set", "filter.systems=GX"])
    assert done.exit_code == 2 and "filter.systems" in done.output


def test_a_bias_on_the_reference_system_goes_to_the_clock(tmp_path):
    """GPS alone with a 50 m GPS bias: the clock state takes it, and the NEES scores the
    clock against clock + 50 m, so the run scores as the one without the bias (measured:
    NEES mean 8.25 both); scored against the clock alone it would add (50 / 1.93 m)^2."""
    short = (
        "flight.legs=[{kind: wait, duration_s: 30}, {kind: takeoff, duration_s: 40, "
        "speed_mps: 80}, {kind: straight, duration_s: 20}]"
    )
    args = ["run-ekf", str(CONFIGS / "paper003" / "ekf1-ff.yaml"), "--set", short]
    args += ["--set", "checks=[]", "--set", "filter.turning_from_s=0"]
    nees = []
    for name, extra in (("none", []), ("g5", ["--set", "gnss.system_bias_m={G: 50}"])):
        done = CliRunner().invoke(app, [*args, *extra, "-o", str(tmp_path / name)])
        assert done.exit_code == 0, done.output
        with h5py.File(tmp_path / name / "run-ekf.h5") as f:
            nees.append(f["truth/nees"][:])
            sigma = f["states/sigma"][-1, 15]
    assert abs(nees[1].mean() - nees[0].mean()) < 0.05 * nees[0].mean()
    assert (50.0 / sigma) ** 2 > 10 * nees[0].mean()

"""Monte Carlo of the 1-sigma every calibrate-imu method reports, on a navigation-grade
and a MEMS unit: over seeds, ``z = (estimate - truth) / sigma`` of each term group must
have a standard deviation within [0.8, 1.25] (the sigma covers the scatter, neither
hiding it nor inflating it) and a mean within 0.5 (no bias the sigma does not hold).

20 seeds per case in ``make test`` (each group pools 60-120 values of z: the standard
deviation of the estimate is ~0.07-0.09, so [0.8, 1.25] is over 2.5 of those from 1);
``ININS_LONG=1`` runs 100. The records are the shipped schedules at 50 Hz with shorter
holds; the white noise is the unit's (the table-free and system-level methods find it
in the data, the discrete method is given it, as its scenario gives it).
"""

import os

import numpy as np
import pytest
import yaml
from helpers import CONFIGS

from inins.calibration import discrete, imu_model, systemlevel, tablefree
from inins.commands._table import memory_record
from inins.core import earth
from inins.core.units import DEG_RTH, UG_RTHZ
from inins.scenario.si.table import table_simulation
from inins.scenario.simulate_table import TableSetup
from inins.table import simulate

SEEDS = 100 if os.environ.get("ININS_LONG") else 20
RATE_HZ = 50

GRADES = {
    "navigation": {
        "gyro": {
            "bias_dph": [0.01, -0.02, 0.005],
            "scale_ppm": [5.0, -3.0, 8.0],
            "misalignment_arcsec": {"xy": 5, "xz": -3, "yx": 2, "yz": 4, "zx": -6, "zy": 1},
            "arw_deg_rth": 0.0005,
        },
        "accel": {
            "bias_ug": [40.0, -25.0, 60.0],
            "scale_ppm": [50.0, -30.0, 20.0],
            "misalignment_arcsec": {"yx": 10, "zx": -8, "zy": 6},
            "vrw_ug_rthz": 5.0,
        },
    },
    "mems": {
        "gyro": {
            "bias_dph": [360.0, -250.0, 180.0],
            "scale_ppm": [5000.0, -3000.0, 4000.0],
            "misalignment_arcsec": {
                "xy": 1800,
                "xz": -900,
                "yx": 600,
                "yz": 1200,
                "zx": -1500,
                "zy": 300,
            },
            "arw_deg_rth": 0.3,
        },
        "accel": {
            "bias_ug": [20000.0, -15000.0, 10000.0],
            "scale_ppm": [3000.0, -2000.0, 1500.0],
            "misalignment_arcsec": {"yx": 1000, "zx": -700, "zy": 500},
            "vrw_ug_rthz": 100.0,
        },
    },
}
"""The two units: a ring-laser-gyro INS and a MEMS IMU (the shipped scenarios' errors)."""
GROUPS = ("ba", "bg", "sa", "sg", "ma", "mg")


def setup(config, grade, holds=None):
    """The shipped schedule of ``config`` with the unit of ``grade`` at 50 Hz."""
    data = yaml.safe_load((CONFIGS / "calibrate-imu" / config).read_text())["simulate"]
    data["imu"] = {"sample_rate_hz": RATE_HZ, **GRADES[grade]}
    data.pop("mount", None)
    for k, step in enumerate(data["motion"]):
        if holds is not None and step["kind"] == "hold":
            step["duration_s"] = holds[0] if k == 0 else holds[1]
        if step["kind"] == "spin":
            step["duration_s"] = 20.0
    return TableSetup.model_validate(data)


def z_table(estimates):
    """``{group: (mean, std)}`` of z over seeds and the group's terms."""
    z = np.array([(values - truth) / sigma for values, truth, sigma in estimates])
    names = imu_model.SENSOR_TERMS
    out = {}
    for group in GROUPS:
        idx = [i for i, n in enumerate(names) if n.startswith(group)]
        out[group] = (float(z[:, idx].mean()), float(z[:, idx].std()))
    return out


def check(table, label):
    print(label, {g: (round(m, 2), round(s, 2)) for g, (m, s) in table.items()})
    for group, (mean, std) in table.items():
        assert 0.8 <= std <= 1.25, (label, group, mean, std)
        assert abs(mean) < 0.5, (label, group, mean, std)


def records(s):
    sim = table_simulation(s)
    truth = imu_model.terms_from_sensor(sim.sensor).vector(imu_model.SENSOR_TERMS)
    for seed in range(SEEDS):
        yield (
            truth,
            memory_record(sim, simulate.simulation_chunks(sim, np.random.default_rng(seed))),
        )


@pytest.mark.slow
@pytest.mark.parametrize("grade", ["navigation", "mems"])
def test_discrete_sigma_covers_the_scatter(grade):
    s = setup("default.yaml", grade, holds=(20.0, 20.0))
    g = GRADES[grade]
    noise = discrete.Noise(
        np.full(3, g["gyro"]["arw_deg_rth"] * DEG_RTH),
        np.full(3, g["accel"]["vrw_ug_rthz"] * UG_RTHZ),
        np.zeros(3),
        np.zeros(3),
    )
    names = imu_model.SENSOR_TERMS + imu_model.MOUNT_TERMS
    estimates = []
    for truth, rec in records(s):
        geo = discrete.Geometry(rec.axes, rec.mat_n_base, s.mount.nominal(), rec.lla)
        enc = s.table.encoder_noise_arcsec
        ivs = discrete.intervals(
            rec.steps,
            rec.encoder_time,
            rec.encoder,
            geo,
            rec.t0,
            rec.dt,
            rec.n_samples,
            2.0,
            enc * np.pi / 180 / 3600,
        )
        fit = discrete.calibrate(ivs, discrete.measured_means(rec, ivs), names, noise)
        estimates.append((fit.values[:21], truth, fit.sigma[:21]))
    check(z_table(estimates), f"discrete {grade}")


@pytest.mark.slow
@pytest.mark.parametrize("grade", ["navigation", "mems"])
def test_table_free_sigma_covers_the_scatter(grade):
    s = setup("table-free-mems.yaml", grade)
    det = tablefree.Detector(window=1.0, init=15.0, threshold_factor=6.0, min_interval=2.0)
    estimates = []
    for truth, rec in records(s):
        time = rec.dt * (np.arange(rec.n_samples) + 1)
        gravity = float(earth.gravity(rec.lla[0], rec.lla[2]))
        fit = tablefree.calibrate(
            time, rec.dv / rec.dt, rec.dtheta / rec.dt, gravity, det, lat=rec.lla[0]
        )
        assert not fit.verdict.inseparable
        estimates.append((fit.values, truth, fit.sigma))
    check(z_table(estimates), f"table-free {grade}")


@pytest.mark.slow
@pytest.mark.parametrize("grade", ["navigation", "mems"])
def test_system_level_sigma_covers_the_scatter(grade):
    s = setup("system-level-19.yaml", grade, holds=(60.0, 30.0))
    g = GRADES[grade]
    estimates = []
    for truth, rec in records(s):
        holds = [(st.start_index, st.stop_index) for st in rec.steps if str(st.kind) == "hold"]
        fit = systemlevel.calibrate(
            rec.dtheta,
            rec.dv,
            rec.dt,
            rec.lla,
            rec.steps[0].stop_index,
            RATE_HZ,
            g["gyro"]["arw_deg_rth"] * DEG_RTH,
            g["accel"]["vrw_ug_rthz"] * UG_RTHZ,
            1e-4,
            holds=holds,
        )
        assert not fit.verdict.inseparable
        estimates.append((fit.values, truth, fit.sigma))
    check(z_table(estimates), f"system-level {grade}")

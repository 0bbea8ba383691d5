"""ETT azimuth alignment (000 §3.1, eqs. 46-48) against truth and closed forms."""

import copy
from pathlib import Path

import numpy as np
import pytest
import yaml
from scipy.stats import chi2

from inins.calibration import ett
from inins.commands._table import load_record
from inins.core import earth, rotation
from inins.core.units import ARCSEC, DEG, DPH, UG
from inins.exceptions import InputError
from inins.scenario.align_ett import AlignEttScenario
from inins.scenario.si.align_ett import options as align_options
from inins.scenario.simulate_table import TableSetup
from tests.helpers import shipped

DEFAULT = Path(__file__).parents[2] / "configs" / "align-ett" / "default.yaml"
PAPER_AXES = ["right", "forward", "up"]  # 000's IMU: x right, y forward, z up


def record(sim, seed=0):
    """A TableRecord of a simulate-table scenario (dict or model), simulated in memory."""
    setup = TableSetup.model_validate(sim) if isinstance(sim, dict) else sim
    return load_record(setup=setup, seed=seed)[0]


def quiet(
    axes=PAPER_AXES,
    misalignment=(10.0, -20.0, 72.0),
    azimuth=0.0,
    gimbals=None,
    lead=(),
    imu=None,
    hold=20.0,
):
    """Error-free two-position sequence: start, pitch +90, vertical, pitch back, level."""
    return {
        "site": {"lat_deg": 45.0, "lon_deg": 10.0, "height_m": 100.0},
        "table": {"gimbals": gimbals or ["yaw", "pitch"], "base_azimuth_deg": azimuth},
        "mount": {"imu_axes": list(axes), "misalignment_arcsec": list(misalignment)},
        "imu": imu or {"sample_rate_hz": 100},
        "motion": [
            *lead,
            {"kind": "hold", "duration_s": 5, "label": "start"},
            {"kind": "rotate", "axis": "pitch", "angle_deg": 90},
            {"kind": "hold", "duration_s": hold, "label": "vertical"},
            {"kind": "rotate", "axis": "pitch", "angle_deg": -90},
            {"kind": "hold", "duration_s": hold, "label": "level"},
        ],
    }


def nominal(axes):
    return AlignEttScenario.model_validate({"data": "x.h5", "imu_axes": list(axes)}).mat_tb0()


def wrap_arcsec(angle):
    return float(rotation.wrap_angle(angle)) / ARCSEC


def test_paper_claim_ett_error_is_a_tenth_of_the_gyrocompass_error():
    """000 §3.1: accelerometer bias 10 ug, noise as shipped; 0.01 deg/h east gyro bias at
    45 deg gives a 0.054 deg gyrocompass error, and ETT errs by at most a tenth of it."""
    scenario = shipped(AlignEttScenario, "align-ett/default.yaml")
    rec = record(scenario.simulate, seed=3)
    est = ett.align_ett(rec, align_options(scenario))
    # the east gyro at the level position carries 0.01 deg/h
    t = rec.truth
    east = (rotation.mat_from_quat(t.quat_nb[-1]) @ t.gyro_bias[-1])[1]
    assert east / DPH == pytest.approx(0.01, rel=1e-3)  # the 72-arcsec mounting turns it
    pred = -east / (earth.RATE * np.cos(45.0 * DEG))  # NED: heading error -eps_E / (W cos L)
    assert est.truth.gyrocompass_err_pred == pytest.approx(pred, rel=1e-9)
    assert abs(pred) / DEG == pytest.approx(0.054, abs=5e-4)
    gc_err = rotation.wrap_angle(est.gyrocompass.euler[2] - est.truth.gyrocompass_heading)
    # within 4 sigma of the gyrocompass noise (ARW over the 295-s level hold)
    assert est.gyrocompass.heading_sigma < 0.2 * abs(pred)
    assert abs(gc_err - pred) < 4.0 * est.gyrocompass.heading_sigma
    ett_err = rotation.wrap_angle(est.result.heading - est.truth.heading)
    assert abs(ett_err) <= 0.1 * abs(gc_err)
    assert abs(ett_err) <= 0.1 * abs(pred)
    assert est.time_used < 0.3 * est.gyrocompass_time


@pytest.mark.parametrize(
    ("axes", "misalignment", "azimuth", "gimbals", "lead"),
    [
        (PAPER_AXES, (10.0, -20.0, 72.0), 0.0, None, ()),
        (PAPER_AXES, (-300.0, 150.0, -1800.0), 123.4, None, ()),
        (["forward", "right", "down"], (40.0, 25.0, 3600.0), 271.0, None, ()),
        (
            ["left", "up", "forward"],
            (-15.0, 60.0, -90.0),
            45.0,
            ["yaw", "pitch", "roll"],
            ({"kind": "rotate", "axis": "yaw", "angle_deg": 37.0},),
        ),
    ],
)
def test_noise_free_ett_recovers_the_mounting_exactly(axes, misalignment, azimuth, gimbals, lead):
    rec = record(quiet(axes, misalignment, azimuth, gimbals, lead))
    for mat_tb0 in (nominal(axes), None):  # stated, or the nearest axis permutation
        est = ett.align_ett(rec, ett.EttOptions(settle=1.0, mat_tb0=mat_tb0, accel_bias_sigma=0.0))
        assert abs(wrap_arcsec(est.result.heading - est.truth.heading)) < 0.1
        np.testing.assert_allclose(est.result.mu / ARCSEC, misalignment, atol=0.1)
        np.testing.assert_allclose(est.result.mat_tb0, nominal(axes))
        assert est.sigma.noise < 1e-6 * ARCSEC and est.sigma.encoder == 0.0


def test_accelerometer_bias_turns_the_azimuth_by_bias_over_g():
    """Paper geometry: dalpha = nabla_x / g (heading -nabla_x / g), dmu_y = -nabla_x / g,
    dmu_x = (nabla_y - nabla_z) / 2g (equal windows); in general -nabla . (u_v x u_l) / g."""
    bias = np.array([30.0, -20.0, 50.0])
    imu = {"sample_rate_hz": 100, "accel": {"bias_ug": bias.tolist()}}
    g = earth.gravity(45.0 * DEG, 100.0)
    nabla = bias * UG / g
    est = ett.align_ett(
        record(quiet(imu=imu)), ett.EttOptions(settle=1.0, mat_tb0=nominal(PAPER_AXES))
    )
    mu_err = (est.result.mu - est.truth.mu) / ARCSEC
    expected = np.array([(nabla[1] - nabla[2]) / 2.0, -nabla[0], nabla[0]]) / ARCSEC
    np.testing.assert_allclose(mu_err, expected, atol=0.01)
    assert wrap_arcsec(est.result.heading - est.truth.heading) == pytest.approx(
        -nabla[0] / ARCSEC, abs=0.01
    )
    assert est.truth.heading_err_pred / ARCSEC == pytest.approx(-nabla[0] / ARCSEC, abs=0.01)
    assert est.sigma.bias / ARCSEC == pytest.approx(10.0 * UG / g / ARCSEC, rel=1e-3)
    # another mounting: x forward, y right, z down; up at vertical = x, at level = -z
    axes = ["forward", "right", "down"]
    est = ett.align_ett(record(quiet(axes, imu=imu)), ett.EttOptions(settle=1.0))
    u_v, u_l = np.array([1.0, 0.0, 0.0]), np.array([0.0, 0.0, -1.0])
    assert wrap_arcsec(est.result.heading - est.truth.heading) == pytest.approx(
        -nabla @ np.cross(u_v, u_l) / ARCSEC, abs=0.01
    )


def test_mu_is_000_eq48_b_equals_w_a_u_inverse():
    """000 eqs. 46-48 on the paper's geometry: A from the vertical-position
    accelerometers, B = W A U^-1 with U = W, equals exp(-[mu_p x]) of the estimate."""
    est = ett.align_ett(
        record(quiet(misalignment=(25.0, -40.0, 150.0))),
        ett.EttOptions(settle=1.0, mat_tb0=nominal(PAPER_AXES)),
    )
    np.testing.assert_allclose(
        ett.W_PITCH90, rotation.axis_rotation(0, -np.pi / 2), atol=1e-15
    )  # eq. 47: 90 deg about 000's x (pitch) axis
    f_v = est.vertical.f_b / np.linalg.norm(est.vertical.f_b)
    f_l = est.level.f_b / np.linalg.norm(est.level.f_b)
    # 000's vertical axes: x right (IMU x), y forward horizontal (-IMU z), z up (IMU y);
    # f = A [0, 0, g] = g [alpha, -beta, 1]; gamma (~0 in 000) from the level position
    f_bc = np.array([f_v[0], -f_v[2], f_v[1]])
    alpha, beta, gamma = f_bc[0], -f_bc[1], f_l[0]
    a = ett.misalignment_matrix(alpha, beta, gamma)
    w = ett.W_PITCH90
    b = w @ a @ np.linalg.inv(w)
    expected = np.array([[1.0, alpha, gamma], [-alpha, 1.0, -beta], [-gamma, beta, 1.0]])
    np.testing.assert_allclose(b, expected, atol=1e-15)  # the printed result of eq. 48
    mu_p = ett.MAT_TP.T @ est.result.mat_tb0 @ est.result.mu
    np.testing.assert_allclose(b, rotation.mat_from_rotvec(-mu_p), atol=0.05 * ARCSEC)
    assert (est.alpha, est.beta) == pytest.approx((alpha, beta), abs=0.05 * ARCSEC)
    assert est.alpha / ARCSEC == pytest.approx(150.0, abs=0.05)


def test_heading_one_sigma_is_honest_over_seeds():
    """Noise only (VRW, encoder noise; no bias): the sample std of the heading over 80
    seeds lies within +-30 % of the reported 1 sigma. For 80 normal draws s/sigma lies in
    [0.75, 1.27] with probability 0.999 (chi-square, 79 dof), so +-30 % fails by chance
    less than once in 1000 runs."""
    sim = quiet(imu={"sample_rate_hz": 100, "accel": {"vrw_ug_rthz": 50.0}})
    sim["table"]["encoder_noise_arcsec"] = 2.0
    n = 80
    lo, hi = np.sqrt(chi2.ppf([0.0005, 0.9995], n - 1) / (n - 1))
    assert 0.7 < lo and hi < 1.3
    for vrw in (None, 50.0 * UG):  # from the data's scatter, or stated
        options = ett.EttOptions(
            settle=1.0, mat_tb0=nominal(PAPER_AXES), accel_bias_sigma=0.0, accel_vrw=vrw
        )
        errs, sigmas = [], []
        for seed in range(n):
            est = ett.align_ett(record(sim, seed), options)
            errs.append(rotation.wrap_angle(est.result.heading - est.truth.heading))
            sigmas.append(est.result.heading_sigma)
        errs, sigma = np.array(errs), np.sqrt(np.mean(np.square(sigmas)))
        assert sigma / ARCSEC > 1.0  # noise dominates: 50 ug/sqrt(Hz) over 19 s
        assert 0.7 < np.std(errs, ddof=1) / sigma < 1.3
        assert abs(errs.mean()) < 4.0 * sigma / np.sqrt(n)


def test_stated_table_azimuth_and_its_sigma():
    rec = record(quiet(azimuth=30.0))
    base = ett.align_ett(rec, ett.EttOptions(settle=1.0))
    moved = ett.align_ett(
        rec, ett.EttOptions(settle=1.0, table_azimuth=31.0 * DEG, table_azimuth_sigma=5.0 * ARCSEC)
    )
    assert wrap_arcsec(moved.result.heading - base.result.heading) == pytest.approx(
        3600.0, abs=1e-3
    )
    assert moved.sigma.azimuth / ARCSEC == pytest.approx(5.0, rel=1e-4)
    # calibrate-bias's start: the heading at another table position (yaw 180 deg)
    at = base.result.heading_at(base.result.level_angles + np.array([np.pi, 0.0]))
    assert wrap_arcsec(at - base.result.heading - np.pi) == pytest.approx(0.0, abs=1e-6)


def test_no_vertical_position_is_an_input_error():
    sim = quiet()
    sim["motion"] = [m for m in sim["motion"] if m["kind"] == "hold"]
    with pytest.raises(
        InputError,
        match=r"align-ett \(ETT.*no vertical position.*pitched "
        r"90 deg",
    ) as info:
        ett.align_ett(record(sim))
    assert info.value.key == "positions.vertical_label"


def test_unknown_label_and_unusable_positions():
    rec = record(quiet())
    with pytest.raises(InputError, match=r"no hold labelled 'up'.*'start', 'vertical', 'level'"):
        ett.align_ett(rec, ett.EttOptions(vertical_label="up"))
    with pytest.raises(InputError, match="do not fix the azimuth"):
        ett.align_ett(rec, ett.EttOptions(vertical_label="start", level_label="level"))
    with pytest.raises(InputError, match="'vertical' is not level"):
        ett.align_ett(rec, ett.EttOptions(vertical_label="start", level_label="vertical"))
    with pytest.raises(InputError, match="too short for a settle time of 30 s"):
        ett.align_ett(rec, ett.EttOptions(settle=30.0))


def test_scenario_sources_and_relative_data_path(tmp_path):
    scenario = copy.deepcopy(yaml.safe_load(DEFAULT.read_text()))
    with pytest.raises(ValueError, match="give either data"):
        AlignEttScenario.model_validate({**scenario, "data": "t.h5"})
    with pytest.raises(ValueError, match="seed"):  # the section carries no seed of its own
        AlignEttScenario.model_validate(
            {**scenario, "simulate": {**scenario["simulate"], "seed": 1}}
        )
    model = AlignEttScenario.model_validate({"data": "t.h5"}, context={"base_dir": tmp_path})
    assert Path(model.data) == tmp_path / "t.h5"
    assert model.mat_tb0() is None

"""calibrate-imu numerics against simulated truth (simulate-table) and closed forms.

Discrete rate-table method: noise-free recovery of all 21 sensor terms and the mounting,
Monte-Carlo consistency of the reported 1-sigma, the planner's 1-sigma against the Monte
Carlo scatter, the refusal of a schedule that cannot separate the terms asked for, and
the compensation that removes what was estimated.
"""

import numpy as np
import pytest

from inins.calibration import discrete, imu_model
from inins.commands._table import memory_record
from inins.core import imu as core_imu
from inins.core.units import ARCSEC, DEG_RTH, UG_RTHZ
from inins.scenario.si.table import table_simulation
from inins.scenario.simulate_table import TableSetup
from inins.table import simulate

NAMES = imu_model.SENSOR_TERMS + imu_model.MOUNT_TERMS
MOUNT_ARCSEC = [20.0, -15.0, 30.0]


def motion(hold=10.0, spin=20.0, rate=30.0, pitches=(0, 90, 180, 270), spins=True):
    """24 positions (outer pitch x inner yaw 0-300 deg by 60) and +-rate spins about
    body z, y and x, on a two-axis table (outer pitch, inner yaw)."""
    steps = [{"kind": "hold", "duration_s": hold, "label": "p0y0"}]
    cur = [0, 0]
    for p in pitches:
        for y in (0, 60, 120, 180, 240, 300):
            if p != cur[0]:
                steps.append({"kind": "rotate", "axis": "pitch", "angle_deg": p - cur[0]})
            if y != cur[1]:
                steps.append({"kind": "rotate", "axis": "yaw", "angle_deg": y - cur[1]})
            if (p, y) != (0, 0):
                steps.append({"kind": "hold", "duration_s": hold, "label": f"p{p}y{y}"})
            cur = [p, y]
    if not spins:
        return steps
    steps.append({"kind": "rotate", "axis": "pitch", "angle_deg": -cur[0]})
    steps.append({"kind": "rotate", "axis": "yaw", "angle_deg": -cur[1]})
    for axis, pre in (("yaw", 0), ("pitch", 0), ("pitch", 90)):
        if pre:
            steps.append({"kind": "rotate", "axis": "yaw", "angle_deg": pre})
        for r in (rate, -rate):
            steps.append({"kind": "spin", "axis": axis, "rate_dps": r, "duration_s": spin})
    return steps


def setup(noise=False, encoder=0.0, steps=None, rate_hz=100):
    imu = {
        "sample_rate_hz": rate_hz,
        "gyro": {
            "bias_dph": [10, -5, 3],
            "scale_ppm": [1000, -500, 300],
            "misalignment_arcsec": {"xy": 100, "xz": -50, "yx": 30, "yz": 80, "zx": -60, "zy": 20},
        },
        "accel": {
            "bias_ug": [1000, -500, 300],
            "scale_ppm": [500, -300, 200],
            "misalignment_arcsec": {"yx": 40, "zx": -30, "zy": 60},
        },
    }
    if noise:
        imu["gyro"]["arw_deg_rth"] = 0.05
        imu["accel"]["vrw_ug_rthz"] = 50.0
    return TableSetup.model_validate(
        {
            "table": {"gimbals": ["pitch", "yaw"], "encoder_noise_arcsec": encoder},
            "mount": {"misalignment_arcsec": MOUNT_ARCSEC},
            "imu": imu,
            "motion": steps or motion(),
        }
    )


def truth_vector(sim, names=NAMES):
    t = imu_model.terms_from_sensor(sim.sensor).values
    t.update(zip(imu_model.MOUNT_TERMS, np.array(MOUNT_ARCSEC) * ARCSEC, strict=True))
    return np.array([t.get(n, 0.0) for n in names])


def simulated(s, seed=1):
    sim = table_simulation(s)
    rec = memory_record(sim, simulate.simulation_chunks(sim, np.random.default_rng(seed)))
    geo = discrete.Geometry(rec.axes, rec.mat_n_base, s.mount.nominal(), rec.lla)
    ivs = discrete.intervals(
        rec.steps,
        rec.encoder_time,
        rec.encoder,
        geo,
        rec.t0,
        rec.dt,
        rec.n_samples,
        1.0,
        s.table.encoder_noise_arcsec * ARCSEC,
    )
    return sim, rec, ivs


NOISE = discrete.Noise(
    np.full(3, 0.05 * DEG_RTH), np.full(3, 50 * UG_RTHZ), np.zeros(3), np.zeros(3)
)

# absolute floors per unit of what noise-free data give back (float64 sums of ~50,000
# increments, Simpson means of the attitude): far below any lab's resolution
FLOOR = {"m/s^2": 1e-10, "rad/s": 1e-12, "1": 1e-10, "rad": 1e-10}


def test_noise_free_recovers_all_21_terms_and_the_mount():
    s = setup()
    sim, rec, ivs = simulated(s)
    assert sum(iv.kind == "spin" for iv in ivs) == 6 and len(ivs) == 30
    fit = discrete.calibrate(ivs, discrete.measured_means(rec, ivs), NAMES, NOISE)
    truth = truth_vector(sim)
    err = np.abs(fit.values - truth)
    floor = np.array([FLOOR[imu_model.UNITS[n]] for n in NAMES])
    bad = [
        (n, v, t)
        for n, v, t, e, f in zip(NAMES, fit.values, truth, err, floor, strict=True)
        if not (e <= 1e-4 * abs(t) or e <= f)
    ]
    assert not bad, bad
    # and the misfit is nothing: the model is the simulator's, exactly
    assert fit.chi2 < 1e-6


def test_g_sensitivity_is_separable_with_positions_and_found_zero():
    s = setup()
    _sim, rec, ivs = simulated(s)
    names = NAMES + imu_model.G_SENS_TERMS
    fit = discrete.calibrate(ivs, discrete.measured_means(rec, ivs), names, NOISE)
    assert fit.plan.separable.all()
    g = fit.values[-9:]
    assert np.all(np.abs(g) < 1e-12)  # rad/s per m/s^2: the simulator has none


def test_spin_sign_convention():
    # +rate about the yaw gimbal is +z in body for the FRD mounting: the reference must
    # carry the sign, else the scale factor comes back as -2 - s
    s = setup()
    _sim, _rec, ivs = simulated(s)
    spins = [iv for iv in ivs if iv.kind == "spin"]
    assert spins[0].w_ref[2] == pytest.approx(np.radians(30.0), rel=1e-3)
    assert spins[1].w_ref[2] == pytest.approx(-np.radians(30.0), rel=1e-3)


@pytest.mark.slow
def test_monte_carlo_sigma_is_consistent_and_the_planner_predicts_it():
    s = setup(noise=True, encoder=1.0, steps=motion(hold=5.0, spin=10.0), rate_hz=50)
    sim = table_simulation(s)
    truth = truth_vector(sim)
    errs, sigmas = [], []
    planned = None
    for seed in range(50):
        _, rec, ivs = simulated(s, seed)
        if planned is None:
            from inins.commands.calibrate_imu_plan import plan_intervals

            p_ivs, _ = plan_intervals(s, 1.0, 1.0 * ARCSEC)
            planned = discrete.plan(p_ivs, NAMES, NOISE_MC).sigma
        fit = discrete.calibrate(ivs, discrete.measured_means(rec, ivs), NAMES, NOISE_MC)
        errs.append(fit.values - truth)
        sigmas.append(fit.sigma)
    errs, sigmas = np.array(errs), np.array(sigmas)
    z = errs / sigmas
    # within 3 sigma for >= 99 % of all term estimates
    assert np.mean(np.abs(z) < 3.0) >= 0.99
    ratios = {}
    groups = {}
    for k, n in enumerate(NAMES):
        groups.setdefault(imu_model.GROUP_OF[n], []).append(k)
    for group, idx in groups.items():
        ratio = np.sqrt(np.mean(z[:, idx] ** 2))  # sample sigma / reported sigma, pooled
        assert 0.8 <= ratio <= 1.25, (group, ratio)
        # the planner's sigma (motion program only, nominal unit) against the scatter
        mc = np.sqrt(np.mean(errs[:, idx] ** 2))
        plan = np.sqrt(np.mean(planned[idx] ** 2))
        assert abs(mc / plan - 1.0) < 0.2, (group, mc / plan)
        ratios[group] = round(float(mc / plan), 3)
    print(
        "MC:",
        np.mean(np.abs(z) < 3.0),
        {g: round(float(np.sqrt(np.mean(z[:, i] ** 2))), 3) for g, i in groups.items()},
        "MC/plan:",
        ratios,
    )


NOISE_MC = discrete.Noise(
    np.full(3, 0.05 * DEG_RTH), np.full(3, 50 * UG_RTHZ), np.zeros(3), np.zeros(3)
)


def test_planner_names_what_a_level_only_schedule_cannot_separate():
    # every position with the z axis vertical: the horizontal accelerometer scale factors
    # never see gravity, the gyro rate tests are missing
    s = setup(steps=motion(pitches=(0, 180), spins=False))
    table_simulation(s)
    from inins.commands.calibrate_imu_plan import plan_intervals

    ivs, _ = plan_intervals(s, 1.0)
    planned = discrete.plan(ivs, NAMES, NOISE)
    bad = set(planned.inseparable)
    assert {"sa_x", "sa_y"} <= bad
    assert "ba_z" not in bad and "sa_z" not in bad
    assert planned.combinations
    # the full schedule separates everything
    s_full = setup()
    ivs, _ = plan_intervals(s_full, 1.0)
    assert discrete.plan(ivs, NAMES, NOISE).separable.all()


def test_compensation_inverts_the_sensor_model_exactly():
    rng = np.random.default_rng(3)
    dtheta = rng.normal(0, 1e-3, (500, 3))
    dv = rng.normal(0, 1e-2, (500, 3)) + np.array([0, 0, -0.098])
    sensor = table_simulation(setup()).sensor
    meas_g, meas_a, _, _ = core_imu.apply_errors(dtheta, dv, 0.01, sensor, rng)
    terms = imu_model.terms_from_sensor(sensor)
    back_g, back_a = imu_model.compensate(meas_g, meas_a, 0.01, terms)
    np.testing.assert_allclose(back_g, dtheta, rtol=0, atol=1e-15)
    np.testing.assert_allclose(back_a, dv, rtol=0, atol=1e-15)


def test_compensated_log_calibrates_to_zero():
    # the terms estimated from a noise-free log, applied to that log, leave nothing to find
    s = setup()
    _sim, rec, ivs = simulated(s)
    fit = discrete.calibrate(ivs, discrete.measured_means(rec, ivs), NAMES, NOISE)
    from inins.commands.calibrate_imu import compensated_record

    comp = imu_model.ImuTerms(
        {
            n: v
            for n, v in zip(fit.names, fit.values, strict=True)
            if imu_model.GROUP_OF[n] != "mount"
        }
    )
    again = compensated_record(rec, comp)
    fit2 = discrete.calibrate(ivs, discrete.measured_means(again, ivs), NAMES, NOISE)
    sensor = np.array([imu_model.GROUP_OF[n] != "mount" for n in NAMES])
    floor = np.array([FLOOR[imu_model.UNITS[n]] for n in NAMES])
    assert np.all(np.abs(fit2.values[sensor]) <= 10 * floor[sensor])
    # the mounting is not a sensor error: it stays
    np.testing.assert_allclose(fit2.values[~sensor], fit.values[~sensor], rtol=1e-6)


def test_moving_and_short_holds_are_flagged_and_left_out():
    s = setup()
    _sim, rec, ivs = simulated(s)
    enc = rec.encoder.copy()
    hold = rec.steps[2]  # the second position
    sel = (rec.encoder_time >= hold.start_time) & (rec.encoder_time <= hold.end_time)
    enc[sel, 1] += np.linspace(0.0, 30 * ARCSEC, sel.sum())  # the table creeps 30 arcsec
    geo = discrete.Geometry(rec.axes, rec.mat_n_base, s.mount.nominal(), rec.lla)
    flags = []
    found = discrete.intervals(
        rec.steps, rec.encoder_time, enc, geo, rec.t0, rec.dt, rec.n_samples, 1.0, 0.0, flags
    )
    assert len(found) == len(ivs) - 1
    assert len(flags) == 1 and "moves by" in flags[0] and hold.label in flags[0]
    # a settling time that leaves less than a second of each 10-s hold
    flags = []
    found = discrete.intervals(
        rec.steps, rec.encoder_time, rec.encoder, geo, rec.t0, rec.dt, rec.n_samples, 9.5, 0, flags
    )
    assert all(iv.kind == "spin" for iv in found) and len(flags) == 24
    assert "shorter than 1 s" in flags[0]

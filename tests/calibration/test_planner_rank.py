"""The planners against design matrices built here, independently of the methods' code:
for a good and a degenerate schedule of every method, the rank and the null space of
the independent design equal what the method's own verdict says (the terms it refuses
and the combinations it names).

- discrete: the linear model of a hold and a spin written out by hand (``f_meas = f +
  b_a + diag(f) s_a + A f + [f x] m``, the gyro alike) at the encoder references;
- table-free: the gravity-norm rows ``-u^T (b_a + E_a a)`` by hand, and the gyro rows
  as finite differences of residuals computed here (rotations chained sample by sample
  with :func:`inins.core.rotation.mat_from_rotvec`, static means against the Earth rate)
  from ideal increments with each error applied;
- system-level: finite differences of the nonlinear stationary navigation (the
  strapdown, not the filter's linear model) of ideal increments with each error applied,
  its velocity sampled every second, the initial attitude error a nuisance.
"""

import numpy as np
import pytest
import yaml
from helpers import CONFIGS

from inins.calibration import discrete, imu_model, systemlevel, tablefree, verdict
from inins.commands._table import memory_record
from inins.commands.calibrate_imu_plan import plan_intervals
from inins.core import earth, rotation, strapdown
from inins.core.units import DEG_RTH, UG_RTHZ
from inins.scenario.si.table import table_simulation
from inins.scenario.simulate_table import TableSetup
from inins.table import simulate

NOISE = discrete.Noise(np.full(3, 1e-3 * DEG_RTH), np.full(3, 5 * UG_RTHZ), 0.0, 0.0)
ACCEL = ("ba_x", "ba_y", "ba_z", "sa_x", "sa_y", "sa_z", "ma_yx", "ma_zx", "ma_zy")
GYRO = ("bg_x", "bg_y", "bg_z", "sg_x", "sg_y", "sg_z", "mg_xy", "mg_xz", "mg_yx", "mg_yz")
GYRO = (*GYRO, "mg_zx", "mg_zy")


def null_space(design, names, rel=1e-5):
    """Orthonormal basis (columns) of the null space of ``design`` (rows whitened, each
    term scaled to its typical size as the methods do), in the scaled coordinates, and
    the scales: singular values at or below ``rel`` of the largest."""
    scale = verdict.typical_scale(names)
    _, s, vt = np.linalg.svd(design * scale, full_matrices=True)
    s = np.r_[s, np.zeros(vt.shape[0] - s.size)]
    return vt[s <= rel * s.max()].T, scale


def same_null_space(design, names, verdict_, rel=1e-5):
    """The null space of ``design`` (columns ``names``) against the verdict: as many
    named combinations as null directions, each inside the null space, and every term
    the null space involves (weight above 1e-3) refused. Returns the null dimension."""
    basis, scale = null_space(design, names, rel)
    involved = {n for n, w in zip(names, (basis**2).sum(axis=1), strict=True) if w > 1e-6}
    assert involved <= set(verdict_.inseparable), (verdict_.inseparable, involved)
    assert len(verdict_.combinations) == basis.shape[1], verdict_.combinations
    for combo in verdict_.combinations:
        v = np.array([combo.get(n, 0.0) for n in names]) / scale
        v /= np.linalg.norm(v)  # (a combination leaves out weights below 1e-3 of its largest)
        assert np.linalg.norm(v - basis @ (basis.T @ v)) < 1e-2, combo
    return basis.shape[1]


# ----------------------------------------------------------------------------- discrete


def discrete_design(ivs, names):
    """Rows of the hold and spin means by hand (nominal unit, small-error model), each
    over its white-noise 1-sigma (``N / sqrt(T)``)."""
    rows = []
    for iv in ivs:
        f, w = iv.f_ref, iv.w_ref
        for sensor, ref in (("a", f), ("g", w)):
            if sensor == "a" and iv.kind != "hold":
                continue
            sigma = (NOISE.vrw if sensor == "a" else NOISE.arw)[0] / np.sqrt(iv.duration)
            for i, axis in enumerate("xyz"):
                row = dict.fromkeys(names, 0.0)
                row[f"b{sensor}_{axis}"] = 1.0
                row[f"s{sensor}_{axis}"] = ref[i]
                for j, other in enumerate("xyz"):
                    if f"m{sensor}_{axis}{other}" in row:
                        row[f"m{sensor}_{axis}{other}"] = ref[j]
                mount = rotation.skew(ref)[i]  # d(R^T v)/dm = [v x]
                for j, m in enumerate(imu_model.MOUNT_TERMS):
                    row[m] = mount[j]
                rows.append([row[n] / sigma for n in names])
    return np.array(rows)


def _discrete_setup(motion):
    from test_calibrate_imu_discrete import setup

    s = setup(steps=motion)
    ivs, _ = plan_intervals(s, 1.0)
    return ivs


def test_discrete_planner_rank_and_null_space():
    from test_calibrate_imu_discrete import motion

    names = imu_model.SENSOR_TERMS + imu_model.MOUNT_TERMS
    ivs = _discrete_setup(motion())
    planned = discrete.plan(ivs, names, NOISE)
    assert same_null_space(discrete_design(ivs, names), names, planned) == 0
    # level positions only (outer pitch 0 and 180 deg), no rate test
    ivs = _discrete_setup(motion(pitches=(0, 180), spins=False))
    planned = discrete.plan(ivs, names, NOISE)
    assert same_null_space(discrete_design(ivs, names), names, planned) > 0
    assert {"sa_x", "sa_y", "ma_yx", "ma_zx", "ma_zy"} <= set(planned.inseparable)


# ----------------------------------------------------------------------------- table-free


def _table_free(motion, rate_hz=20):
    data = yaml.safe_load((CONFIGS / "calibrate-imu/table-free-mems.yaml").read_text())["simulate"]
    data["imu"] = {"sample_rate_hz": rate_hz}
    if motion is not None:
        data["motion"] = motion
    s = TableSetup.model_validate(data)
    sim = table_simulation(s)
    ideal = memory_record(sim, simulate.simulation_chunks(sim, np.random.default_rng(0)))
    return sim, ideal


ROLLS = [{"kind": "hold", "duration_s": 20, "label": "init"}] + [
    step
    for k in range(11)
    for step in (
        {"kind": "rotate", "axis": "roll", "angle_deg": 30 + 5 * (k % 3), "rate_dps": 60},
        {"kind": "hold", "duration_s": 6},
    )
]
"""A schedule that turns only about body x: the x accelerometer never sees gravity and
the gyros' y and z columns never see a rate."""


def table_free_design(sim, rec, ivs, vrw, arw):
    """Accelerometer rows by hand; gyro rows (static means and gravity directions after
    each turn, heading of the first position a nuisance) by finite differences of
    residuals computed here; every row over its white-noise 1-sigma (``vrw``, ``arw``
    densities)."""
    g = float(earth.gravity(rec.lla[0], rec.lla[2]))
    acc = rec.dv / rec.dt
    means = np.array([acc[a:b].mean(axis=0) for a, b in ivs])
    u = means / np.linalg.norm(means, axis=1, keepdims=True)
    a_rows = []
    for uk, ak in zip(u, means, strict=True):
        row = dict.fromkeys(ACCEL, 0.0)
        for i, axis in enumerate("xyz"):
            row[f"ba_{axis}"] = -uk[i]
            row[f"sa_{axis}"] = -uk[i] * ak[i]
        for n in ("ma_yx", "ma_zx", "ma_zy"):
            i, j = "xyz".index(n[-2]), "xyz".index(n[-1])
            row[n] = -uk[i] * ak[j]
        a_rows.append([row[n] for n in ACCEL])
    dur = np.array([(b - a) * rec.dt for a, b in ivs])
    a_design = np.array(a_rows) / g / (vrw / np.sqrt(dur))[:, None]
    w_ie = earth.rate_ie_n(rec.lla[0])
    mat0, _, _ = sim.trajectory.state(np.array([(ivs[0][0] + 0.5) * rec.dt]))
    heading0 = rotation.euler_from_mat(mat0[0])[2]

    def residuals(theta, heading):
        terms = imu_model.ImuTerms(dict(zip(GYRO, theta, strict=True)))
        dth = rec.dtheta @ terms.gyro_matrix().T + terms.gyro_bias() * rec.dt
        level = rotation.axis_rotation(2, -heading0) @ mat0[0]
        mat = rotation.axis_rotation(2, heading) @ level
        out = [dth[ivs[0][0] : ivs[0][1]].mean(axis=0) / rec.dt - mat.T @ w_ie]
        for k in range(len(ivs) - 1):
            r = np.eye(3)
            for d in dth[ivs[k][1] : ivs[k + 1][0]]:
                w_b = (mat @ r).T @ w_ie
                r = r @ rotation.mat_from_rotvec(d - w_b * rec.dt)
            out.append(u[k + 1] - r.T @ u[k])
            mat = mat @ r
            out.append(dth[ivs[k + 1][0] : ivs[k + 1][1]].mean(axis=0) / rec.dt - mat.T @ w_ie)
        return np.concatenate(out)

    cols = []
    for k in range(len(GYRO) + 1):
        h = 1e-7 if k < len(GYRO) else 1e-6
        e = np.zeros(len(GYRO) + 1)
        e[k] = h
        plus = residuals(e[:-1], heading0 + e[-1])
        minus = residuals(-e[:-1], heading0 - e[-1])
        cols.append((plus - minus) / (2 * h))
    gap = np.array([(ivs[k + 1][0] - ivs[k][1]) * rec.dt for k in range(len(ivs) - 1)])
    ends = vrw / g * np.sqrt(1 / dur[:-1] + 1 / dur[1:])
    sig = [np.full(3, arw / np.sqrt(dur[0]))]
    for k in range(len(ivs) - 1):
        sig += [
            np.full(3, np.hypot(ends[k], arw * np.sqrt(gap[k]))),
            np.full(3, arw / np.sqrt(dur[k + 1])),
        ]
    g_design = np.stack(cols, axis=1) / np.concatenate(sig)[:, None]
    # the heading projected out (a nuisance), rows weighted alike (rank only)
    hcol = g_design[:, -1:] / np.linalg.norm(g_design[:, -1])
    g_design = g_design[:, :-1] - hcol @ (hcol.T @ g_design[:, :-1])
    return a_design, g_design


@pytest.mark.parametrize("schedule", ["shipped", "rolls"])
def test_table_free_planner_rank_and_null_space(schedule):
    sim, rec = _table_free(None if schedule == "shipped" else ROLLS)
    time = rec.dt * (np.arange(rec.n_samples) + 1)
    gravity = float(earth.gravity(rec.lla[0], rec.lla[2]))
    det = tablefree.Detector(window=1.0, init=15.0, threshold_factor=6.0, min_interval=2.0)
    args = (time, rec.dv / rec.dt, rec.dtheta / rec.dt, gravity)
    holds = [(s.start_index, s.stop_index) for s in rec.steps if str(s.kind) == "hold"]
    a_design, g_design = table_free_design(sim, rec, holds, 5 * UG_RTHZ, 5e-4 * DEG_RTH)
    # the rank (the method's information, no sigma criterion) against the designs
    planned = tablefree.plan(
        *args, np.full(3, 5 * UG_RTHZ), np.full(3, 5e-4 * DEG_RTH), det, rec.lla[0]
    )
    info, names = planned.verdict.information, planned.verdict.names
    nulls = []
    for design, block in ((a_design, ACCEL), (g_design, GYRO)):
        idx = [names.index(n) for n in block]
        # the Earth rate alone reaches some gyro columns: eigenvalues 1e-9 of the largest
        # in both, far above the null space's 1e-21; the rank tolerance sits between
        sub = info[np.ix_(idx, idx)]
        rank_only = verdict.from_information(
            sub, block, verdict.typical_scale(block), rel_tol=1e-14
        )
        nulls.append(same_null_space(design, block, rank_only, rel=1e-7))
    if schedule == "shipped":
        assert nulls == [0, 0] and not planned.inseparable
        return
    assert set(planned.inseparable) >= {"ba_x", "sa_x", "ma_yx", "ma_zx"}
    # a MEMS gyro (0.3 deg/sqrt(h)): the Earth rate in the static means no longer fixes
    # the gyro columns that no turn reaches (the sigma criterion); the x gyro's bias
    # against the heading it is, through the y and z gyros, to a 1-sigma it states
    mems = tablefree.plan(
        *args, np.full(3, 100 * UG_RTHZ), np.full(3, 0.3 * DEG_RTH), det, rec.lla[0]
    )
    expected = {"ba_x", "sa_x", "ma_yx", "ma_zx"}
    expected |= {"sg_y", "sg_z", "mg_xy", "mg_xz", "mg_yz", "mg_zy"}
    assert set(mems.inseparable) == expected


# ----------------------------------------------------------------------------- system-level


def _system(kind, rate_hz=20):
    data = yaml.safe_load((CONFIGS / "calibrate-imu/system-level-19.yaml").read_text())["simulate"]
    data["imu"] = {"sample_rate_hz": rate_hz}
    motion = [{"kind": "hold", "duration_s": 30.0}]
    if kind == "shipped":
        motion += [
            {**m, "duration_s": 10.0} if m["kind"] == "hold" else m for m in data["motion"][1:]
        ]
    else:  # the x axis level at every position and turn: x never sees gravity
        motion += [{"kind": "rotate", "axis": "yaw", "angle_deg": 90, "rate_dps": 5}]
        motion += [{"kind": "hold", "duration_s": 10.0}]
        for _ in range(8):
            motion += [{"kind": "rotate", "axis": "pitch", "angle_deg": 90, "rate_dps": 5}]
            motion += [{"kind": "hold", "duration_s": 10.0}]
    data["motion"] = motion
    sim = table_simulation(TableSetup.model_validate(data))
    rec = memory_record(sim, simulate.simulation_chunks(sim, np.random.default_rng(0)))
    return sim, rec


def system_design(sim, rec):
    """Velocity every second of the nonlinear stationary navigation (the strapdown) from
    the true initial attitude, by finite differences in each term and in the initial
    attitude error (projected out: a nuisance)."""
    names = imu_model.SENSOR_TERMS
    mat0, _, _ = sim.trajectory.state(np.array([0.5 * rec.dt]))
    step = round(1.0 / rec.dt)

    def velocity(theta, phi0):
        terms = imu_model.ImuTerms(dict(zip(names, theta, strict=True)))
        f = rec.dv / rec.dt
        f_meas = f @ terms.accel_matrix().T + terms.accel_bias()
        w_meas = (rec.dtheta / rec.dt) @ terms.gyro_matrix().T + terms.gyro_bias()
        state = strapdown.NavState.from_attitude(
            rotation.mat_from_rotvec(phi0) @ mat0[0], np.zeros(3), rec.lla
        )
        _, series = strapdown.integrate(
            state,
            w_meas * rec.dt,
            f_meas * rec.dt,
            rec.dt,
            fixed_position=True,
            zero_velocity=True,
            decimation=step,
        )
        return series.vel_n.ravel()

    cols = []
    for k in range(len(names) + 3):
        h = 1e-7
        e = np.zeros(len(names) + 3)
        e[k] = h
        cols.append((velocity(e[:-3], e[-3:]) - velocity(-e[:-3], -e[-3:])) / (2 * h))
    design = np.stack(cols, axis=1)
    nuisance, _ = np.linalg.qr(design[:, -3:])
    return design[:, :-3] - nuisance @ (nuisance.T @ design[:, :-3])


@pytest.mark.parametrize("schedule", ["shipped", "level"])
def test_system_level_planner_rank_and_null_space(schedule):
    sim, rec = _system(schedule)
    holds = [(s.start_index, s.stop_index) for s in rec.steps if str(s.kind) == "hold"]
    fit = systemlevel.calibrate(
        rec.dtheta,
        rec.dv,
        rec.dt,
        rec.lla,
        holds[0][1],
        round(1.0 / rec.dt),
        1e-4 * DEG_RTH,
        1.0 * UG_RTHZ,
        1e-5,
        passes=1,
    )
    names = imu_model.SENSOR_TERMS
    rank_only = verdict.from_information(
        fit.verdict.information, names, verdict.typical_scale(names), rel_tol=1e-14
    )
    null = same_null_space(system_design(sim, rec), names, rank_only, rel=1e-7)
    if schedule == "shipped":
        assert null == 0 and not fit.verdict.inseparable
    else:
        assert null > 0
        assert {"sa_x", "ma_yx", "ma_zx"} <= set(fit.verdict.inseparable)

"""``inins calibrate-imu``: every error term of both triads, with uncertainties.

Methods (the scenario's ``methods``): the discrete rate-table method
(:mod:`inins.calibration.discrete`) and the table-free multi-position method
(:mod:`inins.calibration.tablefree`). The planner (``plan``) checks the schedule before
anything is estimated and refuses one that cannot separate a requested term. The run
gives every term with its 1-sigma and expanded uncertainty (k = 2), residuals per
position, correlations, a compensation file (``calibrate-imu-compensation.yaml``, also
in the report and the results file) and, with ``--plot``, the before/after figures and
a self-contained HTML calibration certificate.
"""

import datetime

import numpy as np

from inins.calibration import discrete, imu_model, systemlevel, tablefree
from inins.commands import calibrate_imu_plan, calibrate_imu_report
from inins.commands._calibrate_imu_units import PREFIX, lab
from inins.commands._compensation import compensation_terms
from inins.commands._table import load_record
from inins.core import earth
from inins.core.records import MemoryRecord
from inins.core.units import ARCSEC, DEG, DPH, G0, PPM, UG
from inins.exceptions import InputError
from inins.results import CommandResult, Series
from inins.scenario.calibrate_imu import CalibrateImuScenario
from inins.scenario.si.calibrate_imu import tablefree_detector

SCENARIO_MODEL = CalibrateImuScenario


def requested_terms(scenario):
    """Term names of the groups the scenario asks for, in :data:`ALL_TERMS` order."""
    groups = set(scenario.estimate)
    return tuple(n for n in imu_model.ALL_TERMS if imu_model.GROUP_OF[n] in groups)


def _fig(name):
    def draw(result, path):
        from inins.commands import calibrate_imu_figures

        getattr(calibrate_imu_figures, name)(result, path)

    return draw


def _certificate(result, path, data):
    from inins.commands import calibrate_imu_figures

    calibrate_imu_figures.certificate(result, path, data)


FIGURES = {
    "calibrate-imu-residuals.png": _fig("residuals"),
    "calibrate-imu-certificate.html": _certificate,
}


def _compensation_text(result):
    from inins.commands import calibrate_imu_figures

    return calibrate_imu_figures.compensation_text(result)


FILES = {"calibrate-imu-compensation.yaml": _compensation_text}
"""Written beside the results on every run: the compensation file of the first method."""


# ----------------------------------------------------------------------------- inputs


def load_compensation(scenario):
    """The compensation file's terms, or None; bad input if it is of another unit."""
    if scenario.compensation is None:
        return None
    return compensation_terms(scenario.compensation, scenario.unit.name, scenario.unit.serial)


def compensation_payload(terms, scenario, method):
    """The compensation file (a dict) of estimated terms."""
    t = terms

    def three(prefix, unit):
        return [round(t[f"{prefix}_{a}"] / unit, 9) for a in "xyz"]

    imu = {
        "gyro_bias_dph": three("bg", DPH),
        "gyro_scale_ppm": three("sg", PPM),
        "gyro_misalignment_arcsec": {
            n[3:]: round(t[n] / ARCSEC, 6) for n in imu_model.SENSOR_TERMS if n.startswith("mg_")
        },
        "accel_bias_ug": three("ba", UG),
        "accel_scale_ppm": three("sa", PPM),
        "accel_misalignment_arcsec": {
            n[3:]: round(t[n] / ARCSEC, 6) for n in imu_model.SENSOR_TERMS if n.startswith("ma_")
        },
    }
    g = t.g_sensitivity()
    if np.any(g):
        imu["gyro_g_sensitivity_dph_per_g"] = (g * G0 / DPH).round(9).tolist()
    return {
        "format": "inins-compensation",
        "version": 1,
        "unit": {
            "name": scenario.unit.name,
            "serial": scenario.unit.serial,
            "description": scenario.unit.description,
        },
        "calibrated": datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "method": method,
        "imu": imu,
    }


def compensated_record(record, terms):
    """A :class:`MemoryRecord` of ``record`` with its increments compensated."""
    from dataclasses import fields

    dtheta, dv = record.imu(0, record.n_samples)
    dtheta, dv = imu_model.compensate(dtheta, dv, record.dt, terms)
    meta = {f.name: getattr(record, f.name) for f in fields(MemoryRecord) if f.init}
    meta.update(dtheta=dtheta, dv=dv)
    return MemoryRecord(**{k: v for k, v in meta.items() if k in _RECORD_FIELDS})


_RECORD_FIELDS = {
    "t0",
    "dt",
    "lla",
    "gimbals",
    "axes",
    "mat_n_base",
    "steps",
    "encoder_time",
    "encoder",
    "truth",
    "source",
    "dtheta",
    "dv",
}


# ----------------------------------------------------------------------------- run


def run(scenario, seed, *, sink=None, progress=None):
    """Plan, then calibrate with each method of the scenario."""
    names = requested_terms(scenario)
    if scenario.plan.only:
        return calibrate_imu_plan.plan_only(scenario, names)
    comp = load_compensation(scenario)
    methods = {}
    truth_terms = None
    report_parts = []
    warnings = []
    if scenario.log is not None:
        time, acc, gyro, gravity = _raw_log(scenario)
        fit = _table_free(time, acc, gyro, gravity, scenario, comp)
        methods["table-free"] = _from_tablefree(fit, "table-free")
        warnings += _tablefree_warnings(fit)
    else:
        record, sensor = load_record(scenario.data, scenario.simulate, seed, progress)
        if comp is not None:
            record = compensated_record(record, comp)
        if sensor is not None:
            truth_terms = _truth(scenario, sensor)
        geometry = _geometry(scenario, record)
        if "discrete" in scenario.methods:
            enc_sigma = calibrate_imu_plan.encoder_sigma(scenario)
            flags = []
            ivs = discrete.intervals(
                record.steps,
                record.encoder_time,
                record.encoder,
                geometry,
                record.t0,
                record.dt,
                record.n_samples,
                scenario.settle_s,
                enc_sigma,
                flags,
            )
            warnings += flags
            if not ivs:
                raise InputError("the record has no hold or spin to calibrate from", key="data")
            noise = calibrate_imu_plan.noise_figures(scenario, sensor, record, ivs)
            planned = discrete.plan(ivs, names, noise)
            calibrate_imu_plan.refuse(planned, scenario)
            fit = discrete.calibrate(ivs, discrete.measured_means(record, ivs), names, noise)
            _check_mounting(fit, scenario)
            methods["discrete"] = _from_discrete(fit, ivs, geometry, "discrete")
            warnings += _flag_intervals(fit, ivs)
        if "table-free" in scenario.methods:
            dtheta, dv = record.imu(0, record.n_samples)
            time = record.t0 + record.dt * (np.arange(record.n_samples) + 1)
            gravity = scenario.table_free.gravity_mps2 or float(
                earth.gravity(record.lla[0], record.lla[2])
            )
            fit = _table_free(time, dv / record.dt, dtheta / record.dt, gravity, scenario, None)
            methods["table-free"] = _from_tablefree(fit, "table-free")
            warnings += _tablefree_warnings(fit)
        if "system-level" in scenario.methods:
            methods["system-level"] = _system_level(scenario, record, sensor)
    results, truth, datasets, attrs = {}, {}, {}, {"": {"unit_name": scenario.unit.name}}
    for method, out in methods.items():
        pre = PREFIX[method]
        for n, v, s in zip(out["names"], out["values"], out["sigma"], strict=True):
            unit, scale = lab(n)
            results[f"{pre}_{n}_{unit}"] = float(v / scale)
            results[f"{pre}_{n}_sigma_{unit}"] = float(s / scale) if np.isfinite(s) else None
            results[f"{pre}_{n}_u_{unit}"] = float(2 * s / scale) if np.isfinite(s) else None
            if truth_terms is not None and n in truth_terms:
                truth[f"{pre}_{n}_{unit}"] = float(truth_terms[n] / scale)
        results.update({f"{pre}_{k}": v for k, v in out["scalars"].items()})
        datasets.update({f"{pre}/{k}": v for k, v in out["datasets"].items()})
        attrs[pre] = {"names": list(out["names"]), **out["attrs"]}
        payload = compensation_payload(imu_model.ImuTerms(out["terms"]), scenario, method)
        from inins.io.rawlog import compensation_text

        attrs[pre]["compensation_yaml"] = compensation_text(payload)
        report_parts.append(
            calibrate_imu_report.report(method, out, truth_terms, attrs[pre]["compensation_yaml"])
        )
    attrs[""]["methods"] = list(methods)
    attrs[""]["certificate"] = calibrate_imu_report.certificate_info(scenario)
    return CommandResult(
        "calibrate-imu",
        results,
        truth,
        datasets,
        attrs,
        "\n\n".join(report_parts),
        tuple(warnings),
    )


def _truth(scenario, sensor):
    t = imu_model.terms_from_sensor(sensor).values
    t.update({n: 0.0 for n in imu_model.G_SENS_TERMS})
    if scenario.simulate is not None:
        m = np.asarray(scenario.simulate.mount.misalignment_arcsec, float) * ARCSEC
        t.update(zip(imu_model.MOUNT_TERMS, m, strict=True))
    return t


def _geometry(scenario, record):
    if scenario.simulate is not None:
        mat_tb = scenario.simulate.mount.nominal()
    elif scenario.imu_axes is not None:
        from inins.scenario.simulate_table import DIRECTIONS

        mat_tb = np.array([DIRECTIONS[v] for v in scenario.imu_axes]).T
    else:
        mat_tb = np.eye(3)
    return discrete.Geometry(
        np.asarray(record.axes, float), np.asarray(record.mat_n_base, float), mat_tb, record.lla
    )


MAX_MOUNT = 1.0 * DEG
"""Largest mounting rotation from the nominal IMU axes the small-angle model takes."""


def _check_mounting(fit, scenario):
    """Bad input when the fit does not converge to a small mounting rotation: the
    nominal IMU axes on the table (imu_axes, or mount.imu_axes) are wrong."""
    terms = dict(zip(fit.names, fit.values, strict=True))
    mount = np.array([terms.get(n, 0.0) for n in imu_model.MOUNT_TERMS])
    if not np.all(np.isfinite(fit.values)) or np.linalg.norm(mount) > MAX_MOUNT:
        key = "simulate.mount.imu_axes" if scenario.simulate is not None else "imu_axes"
        raise InputError(
            "the measured gravity and rates do not fit the nominal IMU axes on the table "
            f"(mounting rotation {np.degrees(np.linalg.norm(mount)):.3g} deg, chi-square "
            f"{fit.chi2:.3g} on {fit.dof} degrees of freedom): check the IMU axes",
            key=key,
        )


def _flag_intervals(fit, ivs):
    """A warning per interval whose residual exceeds 5 sigma (unlevel, moving, disturbed)."""
    z = fit.residuals / fit.sigma_means
    out = []
    for k, iv in enumerate(ivs):
        worst = np.nanmax(np.abs(z[k]))
        if np.isfinite(worst) and worst > 5.0:
            out.append(
                f"interval {k} ({iv.kind} {iv.label or '-'}): residual {worst:.1f} sigma "
                "(moving, unlevel or disturbed?)"
            )
    return out


def _raw_log(scenario):
    from inins.io.rawlog import read_raw_log

    log = scenario.log
    time, acc, gyro = read_raw_log(log.accel_file, log.gyro_file, log.saturation_counts)
    gravity = scenario.table_free.gravity_mps2 or 9.80665
    acc = acc - np.asarray(log.accel_offset_counts, float)
    gyro = (gyro - np.asarray(log.gyro_offset_counts, float)) * log.gyro_scale_rad_s_per_count
    scale = log.accel_scale_mps2_per_count
    if scale is None:
        dt = float(np.median(np.diff(time)))
        n0 = max(1, round(scenario.table_free.detector.init_interval_s / dt))
        scale = gravity / float(np.linalg.norm(acc[:n0].mean(axis=0)))
    return time, acc * scale, gyro, gravity


def _tablefree_warnings(fit):
    """What a lab must know of a table-free run: flagged intervals, a gyro fit that did
    not settle (1-sigma of a scale factor or misalignment above 1 %)."""
    out = [f"table-free: {iv.flag} (interval {k})" for k, iv in enumerate(fit.intervals) if iv.flag]
    gyro = [n for n, s in zip(fit.names, fit.sigma, strict=True) if n[:2] in ("sg", "mg")]
    loose = [n for n in gyro if fit.sigma[fit.names.index(n)] > 0.01]
    if loose:
        out.append(
            "table-free: the gyro fit did not settle (1-sigma above 1 % for "
            f"{', '.join(loose)}): the method needs rotations of less than a turn between "
            "static positions, and its detector does not see turns about the vertical"
        )
    return out


def _table_free(time, acc, gyro, gravity, scenario, comp):
    if comp is not None:
        dt = np.gradient(time)[:, None]
        dtheta, dv = imu_model.compensate(gyro * dt, acc * dt, 1.0, comp)
        gyro, acc = dtheta / dt, dv / dt
    det = tablefree_detector(scenario)
    try:
        return tablefree.calibrate(time, acc, gyro, gravity, det, scenario.table_free.use_positions)
    except ValueError as exc:
        key = "table_free.use_positions" if "use_positions" in str(exc) else "table_free.detector"
        raise InputError(str(exc), key=key) from None


def _system_level(scenario, record, sensor):
    """The Kalman filter on the navigation errors over the whole record."""
    first = record.steps[0] if record.steps else None
    if first is None or str(first.kind) != "hold":
        raise InputError(
            "system-level calibration needs the record to start at rest (alignment)", key="data"
        )
    n_align = first.stop_index - first.start_index
    step = max(1, round(scenario.system_level.step_s / record.dt))
    if n_align < step or record.n_samples < 10 * step:
        raise InputError(
            f"the first position ({n_align * record.dt:g} s) or the record is shorter than "
            "the filter needs",
            key="system_level.step_s",
        )
    noise = calibrate_imu_plan.noise_figures(scenario, sensor, record, None)
    dtheta, dv = record.imu(0, record.n_samples)
    fit = systemlevel.calibrate(
        dtheta,
        dv,
        record.dt,
        np.asarray(record.lla, float),
        n_align,
        step,
        float(np.mean(noise.arw)) or 1e-12,
        float(np.mean(noise.vrw)) or 1e-12,
        scenario.system_level.velocity_noise_mps,
    )
    corr = fit.covariance / np.outer(fit.sigma, fit.sigma)
    rms_b = float(np.sqrt(np.mean(fit.velocity_before**2)))
    rms_a = float(np.sqrt(np.mean(fit.velocity_after**2)))
    return {
        "names": fit.names,
        "values": fit.values,
        "sigma": fit.sigma,
        "plan_sigma": None,
        "terms": dict(zip(fit.names, fit.values, strict=True)),
        "correlation": corr,
        "labels": [
            s.label or f"step{k}" for k, s in enumerate(record.steps) if str(s.kind) == "hold"
        ],
        "kinds": ["hold"] * sum(str(s.kind) == "hold" for s in record.steps),
        "residuals": None,
        "sigma_means": None,
        "scalars": {
            "passes": fit.passes,
            "filter_steps": int(fit.time.size),
            "velocity_rms_before_mps": rms_b,
            "velocity_rms_after_mps": rms_a,
        },
        "datasets": {
            "terms": Series(np.array([fit.values, fit.sigma]), "SI", "b", "estimate and 1-sigma"),
            "correlation": Series(corr, "1", "", "correlation between the terms"),
            "time": Series(fit.time, "s", "", "ends of the filter steps"),
            "innovation": Series(fit.innovation, "m/s", "n", "zero-velocity innovations"),
            "velocity_before": Series(
                fit.velocity_before, "m/s", "n", "velocity error of the raw data"
            ),
            "velocity_after": Series(
                fit.velocity_after, "m/s", "n", "velocity error after compensation"
            ),
        },
        "attrs": {"method": "system-level", "inseparable": [], "combinations": []},
    }


# ----------------------------------------------------------------------------- outcomes


def _from_discrete(fit, ivs, geometry, method):
    terms = dict(zip(fit.names, fit.values, strict=True))
    labels = [iv.label or f"{iv.kind}{k}" for k, iv in enumerate(ivs)]
    kinds = [iv.kind for iv in ivs]
    ref_f = np.array([iv.f_ref for iv in ivs])
    ref_w = np.array([iv.w_ref for iv in ivs])
    g = float(np.linalg.norm(geometry.f_n))
    before = fit.measured.copy()
    comp_terms = imu_model.ImuTerms(terms)
    dth, dvv = imu_model.compensate(before[:, :3], before[:, 3:], 1.0, comp_terms)
    after = np.hstack([dth, dvv])
    hold = np.array([k == "hold" for k in kinds])
    r_t = comp_terms.mount_matrix().T
    datasets = {
        "terms": Series(
            np.array([fit.values, fit.sigma]), "SI", "b", "estimate and 1-sigma of each term"
        ),
        "correlation": Series(fit.correlation(), "1", "", "correlation between the terms"),
        "residuals": Series(fit.residuals, "SI", "b", "interval means minus model: gyro, accel"),
        "sigma_means": Series(fit.sigma_means, "SI", "b", "1-sigma of each interval mean"),
        "gravity_norm_before": Series(
            np.linalg.norm(before[hold, 3:], axis=1) - g, "m/s^2", "", "|f| - g per hold, raw"
        ),
        "gravity_norm_after": Series(
            np.linalg.norm(after[hold, 3:], axis=1) - g, "m/s^2", "", "|f| - g, compensated"
        ),
        "earth_rate_before": Series(
            before[hold, :3] - ref_w[hold] @ r_t.T,
            "rad/s",
            "b",
            "gyro mean minus Earth rate per hold, raw",
        ),
        "earth_rate_after": Series(
            after[hold, :3] - ref_w[hold] @ r_t.T, "rad/s", "b", "the same, compensated"
        ),
        "rate_before": Series(
            before[~hold, :3] - ref_w[~hold] @ r_t.T, "rad/s", "b", "rate-test residual, raw"
        ),
        "rate_after": Series(
            after[~hold, :3] - ref_w[~hold] @ r_t.T, "rad/s", "b", "rate-test residual, compensated"
        ),
        "f_ref": Series(ref_f, "m/s^2", "b", "reference specific force per interval"),
    }
    combos = [calibrate_imu_plan.combination_text(c) for c in fit.plan.combinations]
    return {
        "names": fit.names,
        "values": fit.values,
        "sigma": fit.sigma,
        "plan_sigma": fit.plan.sigma,
        "terms": terms,
        "correlation": fit.correlation(),
        "labels": labels,
        "kinds": kinds,
        "residuals": fit.residuals,
        "sigma_means": fit.sigma_means,
        "scalars": {
            "chi2": fit.chi2,
            "dof": fit.dof,
            "intervals": len(ivs),
            "holds": int(hold.sum()),
            "spins": int((~hold).sum()),
        },
        "datasets": datasets,
        "attrs": {
            "labels": labels,
            "kinds": kinds,
            "inseparable": list(fit.plan.inseparable),
            "combinations": combos,
            "method": method,
        },
    }


def _from_tablefree(fit, method):
    terms = dict(zip(fit.names, fit.values, strict=True))
    ivs = [fit.intervals[i] for i in fit.used]
    flagged = [
        f"interval {i} (samples {iv.start}-{iv.stop}): {iv.flag}"
        for i, iv in enumerate(fit.intervals)
        if iv.flag
    ]
    corr = fit.covariance / np.outer(fit.sigma, fit.sigma)
    return {
        "names": fit.names,
        "values": fit.values,
        "sigma": fit.sigma,
        "plan_sigma": None,
        "terms": terms,
        "correlation": corr,
        "labels": [f"static{k}" for k in range(len(ivs))],
        "kinds": ["static"] * len(ivs),
        "residuals": None,
        "sigma_means": None,
        "scalars": {
            "static_intervals": len(ivs),
            "flagged_intervals": len(flagged),
            "gravity_norm_rms_before_mps2": float(np.sqrt(np.mean(fit.norm_before**2))),
            "gravity_norm_rms_after_mps2": float(np.sqrt(np.mean(fit.norm_after**2))),
            "gravity_dir_rms_before": float(np.sqrt(np.mean(fit.gravity_residual_before**2))),
            "gravity_dir_rms_after": float(np.sqrt(np.mean(fit.gravity_residual_after**2))),
            "detector_threshold_m2ps4": fit.threshold,
        },
        "datasets": {
            "terms": Series(np.array([fit.values, fit.sigma]), "SI", "b", "estimate and 1-sigma"),
            "correlation": Series(corr, "1", "", "correlation between the terms"),
            "static_intervals": Series(
                np.array([[iv.start, iv.stop] for iv in ivs]), "1", "", "samples [start, stop)"
            ),
            "gravity_norm_before": Series(fit.norm_before, "m/s^2", "", "|f| - g, nominal scale"),
            "gravity_norm_after": Series(fit.norm_after, "m/s^2", "", "|f| - g, calibrated"),
            "gravity_dir_before": Series(
                fit.gravity_residual_before, "1", "b", "gravity direction residual, nominal gyros"
            ),
            "gravity_dir_after": Series(
                fit.gravity_residual_after, "1", "b", "gravity direction residual, calibrated"
            ),
        },
        "attrs": {"flagged": flagged, "method": method, "inseparable": [], "combinations": []},
    }


def declared_results(scenario):
    """Names a run may give (for checking check names before the run)."""
    names = requested_terms(scenario)
    results, truth = [], []
    for method in scenario.methods:
        pre = PREFIX[method]
        for n in imu_model.ALL_TERMS:
            unit, _ = lab(n)
            results += [f"{pre}_{n}_{unit}", f"{pre}_{n}_sigma_{unit}", f"{pre}_{n}_u_{unit}"]
            truth.append(f"{pre}_{n}_{unit}")
        results += [
            f"{pre}_{k}"
            for k in (
                "chi2",
                "dof",
                "intervals",
                "holds",
                "spins",
                "static_intervals",
                "flagged_intervals",
                "gravity_norm_rms_before_mps2",
                "gravity_norm_rms_after_mps2",
                "gravity_dir_rms_before",
                "gravity_dir_rms_after",
                "detector_threshold_m2ps4",
                "passes",
                "filter_steps",
                "velocity_rms_before_mps",
                "velocity_rms_after_mps",
            )
        ]
    results += [f"plan_{n}_sigma_{lab(n)[0]}" for n in names] + ["plan_inseparable"]
    results += [f"plan_system_{n}_sigma_{lab(n)[0]}" for n in imu_model.SENSOR_TERMS]
    results += [f"plan_table_free_{n}_sigma_{lab(n)[0]}" for n in imu_model.SENSOR_TERMS]
    return tuple(results), tuple(truth)


def estimate(scenario):
    """Size of the run: the in-memory simulation, or None for a file (read once)."""
    from inins.commands._table import table_estimate

    if scenario.simulate is None or scenario.plan.only:
        return None
    return table_estimate(scenario.simulate, True)

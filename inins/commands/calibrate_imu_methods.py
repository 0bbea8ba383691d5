"""calibrate-imu, one method at a time: the calls into :mod:`inins.calibration` and the
outcome of each (terms, sigma, what the schedule separates, datasets) as the command
reports it. The numerics are the methods'; this module assembles."""

import numpy as np

from inins.calibration import discrete, systemlevel, tablefree
from inins.commands import calibrate_imu_plan
from inins.exceptions import InputError
from inins.results import Series
from inins.scenario.si.calibrate_imu import tablefree_detector

MODEL = {
    "discrete": "interval means against the encoder reference (exact model, weighted "
    "least squares); the Earth rate at each position from the encoders and the site's "
    "latitude is in the model: the gyro bias is the sensor's alone",
    "table-free-model": "gravity norm and the rotations between static positions "
    "(Tedaldi et al. 2014) with the Earth rate at latitude {lat:.4f} deg in the model "
    "(heading of the first position estimated, {heading:.2f} +- {heading_sigma:.2f} deg; "
    "each static interval a "
    "gyrocompass): the gyro bias is the sensor's alone",
    "table-free-imu_tk": "gravity norm and the rotations between static positions "
    "(Tedaldi et al. 2014, imu_tk's formulation): the Earth rate is not modelled, so the "
    "gyro bias includes the Earth rate seen at the first position (up to 15 deg/h) and "
    "the gyro scale factors and misalignments the Earth rate over each rotation",
    "system-level": "Kalman filter on the stationary navigation errors (known position, "
    "zero velocity); the Earth rate at the site's latitude is in the navigation: the gyro "
    "bias is the sensor's alone",
}
"""What each method's model is and what its gyro bias includes (certificate, report)."""


def _outcome(names, values, sigma, cov, found, method, model, **parts):
    """The common part of a method's outcome."""
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.outer(sigma, sigma)
    corr[~np.isfinite(corr)] = np.nan
    out = {
        "names": tuple(names),
        "values": np.asarray(values, float),
        "sigma": np.asarray(sigma, float),
        "plan_sigma": None,
        "terms": {n: v for n, v, ok in zip(names, values, found.separable, strict=True) if ok},
        "correlation": corr,
        "residuals": None,
        "sigma_means": None,
        "scalars": {},
        "datasets": {
            "terms": Series(np.array([values, sigma]), "SI", "b", "estimate and 1-sigma"),
            "correlation": Series(corr, "1", "", "correlation between the terms"),
        },
        "attrs": {
            "method": method,
            "model": model,
            "inseparable": list(found.inseparable),
            "combinations": [calibrate_imu_plan.combination_text(c) for c in found.combinations],
            "verdict": verdict_text(found),
        },
    }
    for key, value in parts.items():
        if isinstance(value, dict) and key in out:
            out[key].update(value)
        else:
            out[key] = value
    return out


def verdict_text(found):
    """One line: what the schedule separates."""
    if not found.inseparable:
        return f"all {len(found.names)} terms separable (rank {found.rank} of {len(found.names)})"
    return (
        f"not separable: {', '.join(found.inseparable)} (rank {found.rank} of "
        f"{len(found.names)}; estimated as combinations only)"
    )


# ----------------------------------------------------------------------------- discrete


def run_discrete(scenario, record, sensor, geometry, names):
    """Intervals, planner (refusal), fit, mount check; returns (outcome, warnings)."""
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
        calibrate_imu_plan.encoder_sigma(scenario),
        flags,
    )
    if not ivs:
        raise InputError("the record has no hold or spin to calibrate from", key="data")
    noise = calibrate_imu_plan.noise_figures(scenario, sensor, record, ivs)
    calibrate_imu_plan.refuse(discrete.plan(ivs, names, noise), scenario, "discrete")
    fit = discrete.calibrate(ivs, discrete.measured_means(record, ivs), names, noise)
    try:
        discrete.check_mounting(fit)
    except ValueError as exc:
        key = "simulate.mount.imu_axes" if scenario.simulate is not None else "imu_axes"
        raise InputError(f"{exc}: check the IMU axes", key=key) from None
    return from_discrete(fit, ivs, geometry), flags + _flag_intervals(fit, ivs)


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


def from_discrete(fit, ivs, geometry):
    """The outcome of a discrete fit."""
    from inins.calibration import imu_model

    labels = [iv.label or f"{iv.kind}{k}" for k, iv in enumerate(ivs)]
    kinds = [iv.kind for iv in ivs]
    ref_w = np.array([iv.w_ref for iv in ivs])
    g = float(np.linalg.norm(geometry.f_n))
    before = fit.measured.copy()
    comp_terms = imu_model.ImuTerms(dict(zip(fit.names, fit.values, strict=True)))
    dth, dvv = imu_model.compensate(before[:, :3], before[:, 3:], 1.0, comp_terms)
    after = np.hstack([dth, dvv])
    hold = np.array([k == "hold" for k in kinds])
    r_t = comp_terms.mount_matrix().T

    def rate(x, sel):
        return x[sel, :3] - ref_w[sel] @ r_t.T

    datasets = {
        "residuals": Series(fit.residuals, "SI", "b", "interval means minus model: gyro, accel"),
        "sigma_means": Series(fit.sigma_means, "SI", "b", "1-sigma of each interval mean"),
        "gravity_norm_before": Series(
            np.linalg.norm(before[hold, 3:], axis=1) - g, "m/s^2", "", "|f| - g per hold, raw"
        ),
        "gravity_norm_after": Series(
            np.linalg.norm(after[hold, 3:], axis=1) - g, "m/s^2", "", "|f| - g, compensated"
        ),
        "earth_rate_before": Series(
            rate(before, hold), "rad/s", "b", "gyro mean minus Earth rate per hold, raw"
        ),
        "earth_rate_after": Series(rate(after, hold), "rad/s", "b", "the same, compensated"),
        "rate_before": Series(rate(before, ~hold), "rad/s", "b", "rate-test residual, raw"),
        "rate_after": Series(rate(after, ~hold), "rad/s", "b", "rate-test residual, compensated"),
        "f_ref": Series(
            np.array([iv.f_ref for iv in ivs]), "m/s^2", "b", "reference specific force"
        ),
    }
    return _outcome(
        fit.names,
        fit.values,
        fit.sigma,
        fit.covariance,
        fit.plan,
        "discrete",
        MODEL["discrete"],
        plan_sigma=fit.plan.sigma,
        labels=labels,
        kinds=kinds,
        residuals=fit.residuals,
        sigma_means=fit.sigma_means,
        scalars={
            "chi2": fit.chi2,
            "dof": fit.dof,
            "intervals": len(ivs),
            "holds": int(hold.sum()),
            "spins": int((~hold).sum()),
        },
        datasets=datasets,
        attrs={"labels": labels, "kinds": kinds},
    )


# ----------------------------------------------------------------------------- table-free


def run_table_free(time, acc, gyro, gravity, lat, scenario):
    """The table-free fit, refused where the positions do not separate the terms;
    returns (outcome, warnings)."""
    det = tablefree_detector(scenario)
    try:
        fit = tablefree.calibrate(
            time, acc, gyro, gravity, det, scenario.table_free.use_positions, lat
        )
    except ValueError as exc:
        key = "table_free.use_positions" if "use_positions" in str(exc) else "table_free.detector"
        raise InputError(str(exc), key=key) from None
    calibrate_imu_plan.refuse(fit.verdict, scenario, "table-free")
    return from_tablefree(fit), _tablefree_warnings(fit)


def _tablefree_warnings(fit):
    """Flagged intervals, a gyro fit that did not settle (1-sigma of a scale factor or
    misalignment above 1 %), and imu_tk's Earth rate where it matters."""
    out = [f"table-free: {iv.flag} (interval {k})" for k, iv in enumerate(fit.intervals) if iv.flag]
    loose = [
        n for n, s in zip(fit.names, fit.sigma, strict=True) if n[:2] in ("sg", "mg") and s > 0.01
    ]
    if loose:
        out.append(
            "table-free: the gyro fit did not settle (1-sigma above 1 % for "
            f"{', '.join(loose)}): the method needs rotations of less than a turn between "
            "static positions, and its detector does not see turns about the vertical"
        )
    if not fit.earth_rate:
        from inins.core import earth
        from inins.core.units import DPH

        bias = np.linalg.norm(fit.terms.gyro_bias())
        if bias < 10.0 * earth.RATE:
            out.append(
                f"table-free (imu_tk): the gyro bias found ({bias / DPH:.3g} deg/h) is not "
                f"large against the Earth rate it includes (up to {earth.RATE / DPH:.3g} "
                "deg/h): give the latitude (table_free.lat_deg) to model it"
            )
    return out


def from_tablefree(fit):
    """The outcome of a table-free fit."""
    ivs = [fit.intervals[i] for i in fit.used]
    flagged = [
        f"interval {i} (samples {iv.start}-{iv.stop}): {iv.flag}"
        for i, iv in enumerate(fit.intervals)
        if iv.flag
    ]
    if fit.earth_rate:
        model = MODEL["table-free-model"].format(
            lat=np.degrees(fit.lat),
            heading=np.degrees(fit.heading),
            heading_sigma=np.degrees(fit.heading_sigma),
        )
    else:
        model = MODEL["table-free-imu_tk"]
    scalars = {
        "static_intervals": len(ivs),
        "flagged_intervals": len(flagged),
        "gravity_norm_rms_before_mps2": float(np.sqrt(np.mean(fit.norm_before**2))),
        "gravity_norm_rms_after_mps2": float(np.sqrt(np.mean(fit.norm_after**2))),
        "gravity_dir_rms_before": float(np.sqrt(np.mean(fit.gravity_residual_before**2))),
        "gravity_dir_rms_after": float(np.sqrt(np.mean(fit.gravity_residual_after**2))),
        "detector_threshold_m2ps4": fit.threshold,
        "earth_rate_modelled": int(fit.earth_rate),
    }
    if fit.earth_rate:
        scalars["heading_deg"] = float(np.degrees(fit.heading))
        scalars["heading_sigma_deg"] = float(np.degrees(fit.heading_sigma))
    datasets = {
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
    }
    return _outcome(
        fit.names,
        fit.values,
        fit.sigma,
        fit.covariance,
        fit.verdict,
        "table-free",
        model,
        labels=[f"static{k}" for k in range(len(ivs))],
        kinds=["static"] * len(ivs),
        scalars=scalars,
        datasets=datasets,
        attrs={"flagged": flagged},
    )


# ----------------------------------------------------------------------------- system-level


def run_system_level(scenario, record, sensor):
    """The Kalman filter on the navigation errors over the whole record, refused where the
    sequence does not resolve the terms; returns (outcome, warnings)."""
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
    holds = [(s.start_index, s.stop_index) for s in record.steps if str(s.kind) == "hold"]
    try:
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
            holds=holds,
        )
    except ValueError as exc:
        raise InputError(str(exc), key="system_level") from None
    calibrate_imu_plan.refuse(fit.verdict, scenario, "system-level")
    return from_system(fit, record), []


def from_system(fit, record):
    """The outcome of a system-level fit."""
    rms_b = float(np.sqrt(np.mean(fit.velocity_before**2)))
    rms_a = float(np.sqrt(np.mean(fit.velocity_after**2)))
    holds = [s for s in record.steps if str(s.kind) == "hold"]
    return _outcome(
        fit.names,
        fit.values,
        fit.sigma,
        fit.covariance,
        fit.verdict,
        "system-level",
        MODEL["system-level"],
        labels=[s.label or f"hold{k}" for k, s in enumerate(holds)],
        kinds=["hold"] * len(holds),
        scalars={
            "passes": fit.passes,
            "filter_steps": int(fit.time.size),
            "velocity_rms_before_mps": rms_b,
            "velocity_rms_after_mps": rms_a,
            "alignment_correction_deg": float(np.degrees(np.linalg.norm(fit.alignment_correction))),
        },
        datasets={
            "time": Series(fit.time, "s", "", "ends of the filter steps"),
            "innovation": Series(fit.innovation, "m/s", "n", "zero-velocity innovations"),
            "velocity_before": Series(
                fit.velocity_before, "m/s", "n", "velocity error of the raw data"
            ),
            "velocity_after": Series(
                fit.velocity_after, "m/s", "n", "velocity error after compensation"
            ),
        },
    )

"""``inins calibrate-imu``: every error term of both triads, with uncertainties.

Methods (the scenario's ``methods``): the discrete rate-table method
(:mod:`inins.calibration.discrete`), the table-free multi-position method
(:mod:`inins.calibration.tablefree`) and the system-level Kalman filter
(:mod:`inins.calibration.systemlevel`), each run by
:mod:`inins.commands.calibrate_imu_methods`. Each method's own information decides
what the schedule separates (:mod:`inins.calibration.verdict`): the planner (``plan``)
before anything is estimated, and every fit again; a schedule that cannot separate a
requested term is refused (exit 2), naming the combinations it leaves free. The run
gives every term with its 1-sigma and expanded uncertainty (k = 2), residuals per
position, correlations, a compensation file (``calibrate-imu-compensation.yaml``, also
in the report and the results file) and, with ``--plot``, the before/after figures and
a self-contained HTML calibration certificate.
"""

import datetime

import numpy as np

from inins.calibration import counts, discrete, imu_model
from inins.commands import calibrate_imu_methods, calibrate_imu_plan, calibrate_imu_report
from inins.commands._calibrate_imu_units import PREFIX, lab
from inins.commands._compensation import compensation_terms
from inins.commands._table import load_record
from inins.core import earth
from inins.core.records import MemoryRecord
from inins.core.units import ARCSEC, DPH, G0, PPM, UG
from inins.exceptions import InputError
from inins.results import CommandResult
from inins.scenario.calibrate_imu import CalibrateImuScenario

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


def compensation_payload(out, scenario, method):
    """The compensation file (a dict) of a method's outcome: the terms it determined
    (those the schedule does not separate are left at zero and named)."""
    t = imu_model.ImuTerms(out["terms"])

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
    payload = {
        "format": "inins-compensation",
        "version": 1,
        "unit": {
            "name": scenario.unit.name,
            "serial": scenario.unit.serial,
            "description": scenario.unit.description,
        },
        "calibrated": datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "method": method,
        "model": out["attrs"]["model"],
        "imu": imu,
    }
    sensor = [n for n in out["attrs"]["inseparable"] if n in imu_model.SENSOR_TERMS]
    if sensor:
        payload["not_determined"] = sensor
    return payload


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
    methods, warnings = {}, []
    truth_terms = None
    if scenario.log is not None:
        time, acc, gyro, gravity = _raw_log(scenario)
        if comp is not None:
            acc, gyro = _compensated_rates(time, acc, gyro, comp)
        lat = calibrate_imu_plan.latitude(scenario)
        methods["table-free"], flags = calibrate_imu_methods.run_table_free(
            time, acc, gyro, gravity, lat, scenario
        )
        warnings += flags
    else:
        record, sensor = load_record(scenario.data, scenario.simulate, seed, progress)
        if comp is not None:
            record = compensated_record(record, comp)
        if sensor is not None:
            truth_terms = _truth(scenario, sensor)
        if "discrete" in scenario.methods:
            methods["discrete"], flags = calibrate_imu_methods.run_discrete(
                scenario, record, sensor, _geometry(scenario, record), names
            )
            warnings += flags
        if "table-free" in scenario.methods:
            dtheta, dv = record.imu(0, record.n_samples)
            time = record.t0 + record.dt * (np.arange(record.n_samples) + 1)
            gravity = scenario.table_free.gravity_mps2 or float(
                earth.gravity(record.lla[0], record.lla[2])
            )
            lat = calibrate_imu_plan.latitude(scenario, record.lla[0])
            methods["table-free"], flags = calibrate_imu_methods.run_table_free(
                time, dv / record.dt, dtheta / record.dt, gravity, lat, scenario
            )
            warnings += flags
        if "system-level" in scenario.methods:
            methods["system-level"], flags = calibrate_imu_methods.run_system_level(
                scenario, record, sensor
            )
            warnings += flags
    return _result(scenario, methods, truth_terms, warnings)


def _result(scenario, methods, truth_terms, warnings):
    """The :class:`CommandResult` of the methods' outcomes."""
    from inins.io.rawlog import compensation_text

    results, truth, datasets, attrs = {}, {}, {}, {"": {"unit_name": scenario.unit.name}}
    report_parts = []
    for method, out in methods.items():
        pre = PREFIX[method]
        for n, v, s in zip(out["names"], out["values"], out["sigma"], strict=True):
            unit, scale = lab(n)
            ok = np.isfinite(s)
            results[f"{pre}_{n}_{unit}"] = float(v / scale) if ok else None
            results[f"{pre}_{n}_sigma_{unit}"] = float(s / scale) if ok else None
            results[f"{pre}_{n}_u_{unit}"] = float(2 * s / scale) if ok else None
            if truth_terms is not None and n in truth_terms:
                truth[f"{pre}_{n}_{unit}"] = float(truth_terms[n] / scale)
        results.update({f"{pre}_{k}": v for k, v in out["scalars"].items()})
        results[f"{pre}_inseparable"] = len(out["attrs"]["inseparable"])
        datasets.update({f"{pre}/{k}": v for k, v in out["datasets"].items()})
        attrs[pre] = {"names": list(out["names"]), **out["attrs"]}
        payload = compensation_payload(out, scenario, method)
        attrs[pre]["compensation_yaml"] = compensation_text(payload)
        attrs[pre]["calibrated"] = payload["calibrated"]
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


def _raw_log(scenario):
    """Time, nominal specific force and rate, gravity of the scenario's raw log."""
    from inins.io.rawlog import read_raw_log

    log = scenario.log
    time, acc, gyro = read_raw_log(log.accel_file, log.gyro_file, log.saturation_counts)
    gravity = scenario.table_free.gravity_mps2 or 9.80665
    try:
        acc, gyro, _ = counts.nominal_rates(
            time,
            acc,
            gyro,
            log.accel_offset_counts,
            log.gyro_offset_counts,
            log.gyro_scale_rad_s_per_count,
            log.accel_scale_mps2_per_count,
            gravity,
            scenario.table_free.detector.init_interval_s,
        )
    except ValueError as exc:
        raise InputError(str(exc), source=str(log.accel_file), key="log") from None
    return time, acc, gyro, gravity


def _compensated_rates(time, acc, gyro, comp):
    dt = np.gradient(time)[:, None]
    dtheta, dv = imu_model.compensate(gyro * dt, acc * dt, 1.0, comp)
    return dv / dt, dtheta / dt


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
                "alignment_correction_deg",
                "earth_rate_modelled",
                "heading_deg",
                "heading_sigma_deg",
                "inseparable",
            )
        ]
    results += [f"plan_{n}_sigma_{lab(n)[0]}" for n in names] + ["plan_inseparable"]
    results += [f"plan_system_{n}_sigma_{lab(n)[0]}" for n in imu_model.SENSOR_TERMS]
    results += [f"plan_table_free_{n}_sigma_{lab(n)[0]}" for n in imu_model.SENSOR_TERMS]
    results += ["plan_system_inseparable", "plan_table_free_inseparable"]
    return tuple(results), tuple(truth)


def estimate(scenario):
    """Size of the run: the in-memory simulation, or None for a file (read once)."""
    from inins.commands._table import table_estimate

    if scenario.simulate is None or scenario.plan.only:
        return None
    return table_estimate(scenario.simulate, True)

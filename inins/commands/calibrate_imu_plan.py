"""calibrate-imu's planner: the noise figures, the schedule's intervals and the predicted
1-sigma of every requested term from the motion program alone, and the refusal of a
schedule that cannot separate a term (before anything is estimated)."""

import numpy as np

from inins.calibration import discrete, systemlevel, tablefree
from inins.commands._calibrate_imu_units import lab
from inins.commands.calibrate_imu_report import certificate_info
from inins.core import earth
from inins.core.units import ARCSEC, DEG, DEG_RTH, PPM, UG_RTHZ, UG_S
from inins.exceptions import InputError
from inins.results import CommandResult, Series, format_table
from inins.scenario.si.calibrate_imu import tablefree_detector
from inins.scenario.si.table import table_simulation


def noise_figures(scenario, sensor, record=None, ivs=None):
    """White-noise figures (SI): the scenario's, else the simulation's, else estimated
    from the scatter of 1-s block means within the holds."""
    n = scenario.noise
    est = None

    def pick(given, unit, sim_value, index):
        nonlocal est
        if given is not None:
            return np.asarray(given, float) * unit
        if sim_value is not None:
            return np.asarray(sim_value, float)
        if est is None:
            est = _estimate_noise(record, ivs)
        return est[index]

    arw = pick(n.arw_deg_rth, DEG_RTH, None if sensor is None else sensor.gyro_arw, 0)
    vrw = pick(n.vrw_ug_rthz, UG_RTHZ, None if sensor is None else sensor.accel_vrw, 1)
    gq = (
        np.asarray(n.gyro_pulse_weight_arcsec, float) * ARCSEC
        if n.gyro_pulse_weight_arcsec is not None
        else (np.zeros(3) if sensor is None else sensor.gyro_pulse_weight)
    )
    aq = (
        np.asarray(n.accel_pulse_weight_ug_s, float) * UG_S
        if n.accel_pulse_weight_ug_s is not None
        else (np.zeros(3) if sensor is None else sensor.accel_pulse_weight)
    )
    return discrete.Noise(arw, vrw, gq, aq)


def _estimate_noise(record, ivs):
    """ARW and VRW from the scatter within the holds (:func:`discrete.noise_from_holds`)."""
    if record is None:
        raise InputError("no noise figures given and no data to estimate them", key="noise")
    if ivs is None:  # the holds of the schedule
        spans = [(s.start_index, s.stop_index) for s in record.steps if str(s.kind) == "hold"]
    else:
        spans = [(iv.start, iv.stop) for iv in ivs if iv.kind == "hold"]
    try:
        return discrete.noise_from_holds(record, spans)
    except ValueError as exc:
        raise InputError(str(exc), key="noise") from None


def encoder_sigma(scenario):
    if scenario.noise.encoder_noise_arcsec is not None:
        return scenario.noise.encoder_noise_arcsec * ARCSEC
    if scenario.simulate is not None:
        return scenario.simulate.table.encoder_noise_arcsec * ARCSEC
    return 0.0


def combination_text(combo):
    """An inseparable direction in lab units (largest coefficient 1, terms below 1e-5 of
    it left out): ``+1 ba_x[ug] +0.206 mount_y[arcsec]``."""
    lab_coef = {n: c / lab(n)[1] for n, c in combo.items()}
    top = max(abs(c) for c in lab_coef.values())
    return " ".join(
        f"{c / top:+.3g} {n}[{lab(n)[0]}]" for n, c in lab_coef.items() if abs(c) > 1e-5 * top
    )


def refuse(planned, scenario, method="discrete"):
    """Bad input when a method's information does not separate a requested term (unless
    ``plan.allow_combinations``), or gives a scale factor worse than
    ``plan.max_sigma_ppm``: one rule for the planner and every run, every method.

    ``planned`` is a :class:`inins.calibration.verdict.Verdict` (names, sigma,
    separable, combinations)."""
    bad = planned.inseparable
    if bad and not scenario.plan.allow_combinations:
        combos = "; ".join(combination_text(c) for c in planned.combinations[:4])
        more = len(planned.combinations) - 4
        raise InputError(
            f"{method}: the schedule cannot separate {', '.join(bad)} (not observable, "
            f"inseparable: {combos}{f'; {more} more' if more > 0 else ''}); add positions "
            "or rate tests, drop the group from estimate, or set "
            "plan.allow_combinations: true",
            key="estimate",
        )
    limit = scenario.plan.max_sigma_ppm
    if limit is not None:
        worse = [
            f"{n} {s / PPM:.3g} ppm"
            for n, s in zip(planned.names, planned.sigma, strict=True)
            if n[:2] in ("sa", "sg") and np.isfinite(s) and s / PPM > limit
        ]
        if worse:
            raise InputError(
                f"{method}: predicted 1-sigma above {limit:g} ppm for {', '.join(worse)}",
                key="plan.max_sigma_ppm",
            )


def plan_intervals(setup, settle, encoder_sigma=0.0):
    """The intervals of a simulate: section's motion program, from the program alone
    (gimbal angles of the compiled program on the truth grid; nothing simulated)."""
    from inins.table import simulate

    sim = table_simulation(setup)
    steps = simulate.schedule(sim)
    grid = np.arange(0.0, sim.trajectory.program.duration, 1.0 / setup.output.truth_rate_hz)
    angles, _ = sim.trajectory.program.segments.evaluate(grid)
    traj = sim.trajectory
    geometry = discrete.Geometry(traj.axes, traj.mat_n_base, setup.mount.nominal(), traj.lla)
    ivs = discrete.intervals(
        steps, grid, angles, geometry, 0.0, sim.dt, sim.n_samples, settle, encoder_sigma
    )
    return ivs, sim


def _plan_rows(planned, prefix, results):
    """Results and report rows of a method's planned verdict."""
    rows = []
    for n, s_, ok in zip(planned.names, planned.sigma, planned.separable, strict=True):
        unit, scale = lab(n)
        results[f"{prefix}{n}_sigma_{unit}"] = float(s_ / scale) if ok else None
        rows.append([n, "yes" if ok else "NO", (s_ / scale) if ok else float("nan"), unit])
    results[f"{prefix}inseparable"] = len(planned.inseparable)
    text = [format_table(rows, ["term", "separable", "predicted 1-sigma", "unit"], fmt=".4g")]
    if planned.combinations:
        text.append("inseparable combinations (the data fix nothing along them):")
        text += ["  " + combination_text(combo) for combo in planned.combinations]
    return text


def plan_only(scenario, names):
    """The plan of every method of the scenario from its motion program: what each
    separates and the predicted 1-sigma; refused (exit 2) as a run would be."""
    if scenario.simulate is None:
        raise InputError("plan.only needs the motion program: a simulate: section", key="plan")
    results, text, datasets, attrs = {}, [], {}, {}
    verdicts = []
    if "discrete" in scenario.methods:
        ivs, sim = plan_intervals(scenario.simulate, scenario.settle_s, encoder_sigma(scenario))
        noise = noise_figures(scenario, sim.sensor)
        planned = discrete.plan(ivs, names, noise)
        text.append(
            f"planner, discrete: {len(ivs)} intervals "
            f"({sum(iv.kind == 'hold' for iv in ivs)} holds, "
            f"{sum(iv.kind == 'spin' for iv in ivs)} spins) from the motion program alone"
        )
        text += _plan_rows(planned, "plan_", results)
        datasets["plan/sigma"] = Series(planned.sigma, "SI", "b", "predicted 1-sigma per term")
        datasets["plan/information"] = Series(planned.information, "SI", "", "information")
        attrs["plan"] = {"names": list(planned.names), "inseparable": list(planned.inseparable)}
        verdicts.append((planned, "discrete"))
    if "system-level" in scenario.methods:
        planned = plan_system_level(scenario)
        text.append(
            "planner, system-level: the filter's information along the motion program "
            "(an ideal unit's increments, the scenario's noise)"
        )
        text += _plan_rows(planned, "plan_system_", results)
        datasets["plan_system/sigma"] = Series(
            planned.sigma, "SI", "b", "predicted 1-sigma per term"
        )
        verdicts.append((planned, "system-level"))
    if "table-free" in scenario.methods:
        planned_tf = plan_table_free(scenario)
        text.append(
            f"planner, table-free: {planned_tf.positions} static positions found in the "
            "motion program (an ideal unit's increments, the scenario's noise; "
            + (
                "the Earth rate modelled"
                if planned_tf.earth_rate
                else "imu_tk's formulation: the gyro bias is the initial interval's mean, "
                "the Earth rate is outside the model"
            )
            + ")"
        )
        text += _plan_rows(planned_tf.verdict, "plan_table_free_", results)
        verdicts.append((planned_tf.verdict, "table-free"))
    if not text:
        raise InputError("the planner needs a method to plan", key="plan")
    for planned, method in verdicts:
        refuse(planned, scenario, method)
    attrs[""] = {
        "unit_name": scenario.unit.name,
        "methods": [],
        "plan_only": True,
        "certificate": certificate_info(scenario),
    }
    return CommandResult(
        "calibrate-imu", results, datasets=datasets, attrs=attrs, report="\n".join(text)
    )


def latitude(scenario, record_lat=None):
    """Latitude (rad) for the table-free Earth-rate model, None for imu_tk's formulation."""
    tf = scenario.table_free
    if tf.earth_rate == "imu_tk":
        return None
    if tf.lat_deg is not None:
        return tf.lat_deg * DEG
    if record_lat is not None:
        return float(record_lat)
    raise InputError(
        "the Earth-rate model needs the lab's latitude: give table_free.lat_deg, or set "
        "table_free.earth_rate: imu_tk (the gyro bias then includes the Earth rate)",
        key="table_free.lat_deg",
    )


def plan_table_free(scenario):
    """What the table-free method separates and the predicted 1-sigma, from the motion
    program alone."""
    from dataclasses import replace

    from inins.commands._table import memory_record
    from inins.core import imu
    from inins.table import simulate

    sim = table_simulation(scenario.simulate)
    noise = noise_figures(scenario, sim.sensor)
    ideal = replace(sim, sensor=imu.SensorErrors.none(), encoder_noise=0.0)
    rec = memory_record(ideal, simulate.simulation_chunks(ideal, np.random.default_rng(0)))
    time = rec.t0 + rec.dt * (np.arange(rec.n_samples) + 1)
    gravity = scenario.table_free.gravity_mps2 or float(earth.gravity(rec.lla[0], rec.lla[2]))
    det = tablefree_detector(scenario)
    try:
        return tablefree.plan(
            time,
            rec.dv / rec.dt,
            rec.dtheta / rec.dt,
            gravity,
            noise.vrw,
            noise.arw,
            det,
            latitude(scenario, rec.lla[0]),
        )
    except ValueError as exc:
        raise InputError(str(exc), key="table_free.detector") from None


def plan_system_level(scenario):
    """What the system-level filter resolves and its predicted 1-sigma from the motion
    program alone: one pass over the increments of an ideal unit on the same program (the
    covariance of a linear filter depends on the trajectory, not on the errors)."""
    from dataclasses import replace

    from inins.commands._table import memory_record
    from inins.core import imu
    from inins.table import simulate

    sim = table_simulation(scenario.simulate)
    noise = noise_figures(scenario, sim.sensor)
    ideal = replace(sim, sensor=imu.SensorErrors.none(), encoder_noise=0.0)
    record = memory_record(ideal, simulate.simulation_chunks(ideal, np.random.default_rng(0)))
    step = max(1, round(scenario.system_level.step_s / record.dt))
    first = record.steps[0]
    fit = systemlevel.calibrate(
        record.dtheta,
        record.dv,
        record.dt,
        np.asarray(record.lla, float),
        first.stop_index - first.start_index,
        step,
        float(np.mean(noise.arw)) or 1e-12,
        float(np.mean(noise.vrw)) or 1e-12,
        scenario.system_level.velocity_noise_mps,
        passes=1,
    )
    return fit.verdict

"""``inins observability``: which error states an aided INS design can ever estimate,
and how well (spec §7, paper 002).

Builds the segments (listed in the scenario, or cut from a table-data trajectory),
the measurement rows and the priors in SI, runs
:func:`inins.observability.analysis.analyse` (PWCS rank and null space, Gramian
cross-check, covariance analysis) and writes the per-state table, the unobservable
combinations, the singular values per segment and the 1-sigma history.
"""

import numpy as np

from inins.commands import figures
from inins.core import earth, rotation
from inins.core.error_model import GROUPS
from inins.core.units import ARCSEC, DEG, DEG_RTH, DPH, UG, UG_RTHZ
from inins.exceptions import InputError
from inins.io.tabledata import read_table_data
from inins.observability import analysis, models
from inins.observability import measurements as meas
from inins.observability.segments import cut_segments, make_segment
from inins.results import CommandResult, Series, format_table
from inins.scenario.observability import ObservabilityScenario

SCENARIO_MODEL = ObservabilityScenario
FIGURES = {
    "observability-sigma.png": figures.observability_sigma,
    "observability-singular-values.png": figures.observability_singular_values,
}

_PRIOR_OF_GROUP = {  # state group -> (prior key, SI per unit)
    "position": ("position_m", 1.0),
    "velocity": ("velocity_mps", 1.0),
    "attitude": ("attitude_deg", DEG),
    "accel_bias": ("accel_bias_ug", UG),
    "gyro_bias": ("gyro_bias_dph", DPH),
    "accel_misalignment": ("accel_misalignment_arcsec", ARCSEC),
    "gyro_misalignment": ("gyro_misalignment_arcsec", ARCSEC),
}


def run(scenario, seed, *, sink=None, progress=None):
    """Analyse the scenario's model along its segments; ``seed`` is unused."""
    model = models.model_by_name(scenario.model)
    los_n = lines_of_sight(scenario.satellites)
    segments = build_segments(scenario, los_n)
    rows = [measurement(m, i) for i, m in enumerate(scenario.measurements)]
    sigma_0 = priors(scenario.priors, model.names) if scenario.covariance else None
    noise = models.ProcessNoise(
        arw=scenario.noise.arw_deg_rth * DEG_RTH, vrw=scenario.noise.vrw_ug_rthz * UG_RTHZ
    )
    found = analysis.analyse(
        model, segments, rows, sigma_0=sigma_0, noise=noise, dt=scenario.update_interval_s
    )
    return CommandResult(
        command="observability",
        results=result_numbers(found, segments),
        datasets=datasets(found, segments),
        attrs={
            "observability": {
                "model": found.model,
                "states": list(model.names),
                "method": found.pwcs.method,
            }
        },
        report=report(scenario, found, segments) + turn_report(found, segments),
        warnings=found.warnings,
    )


def declared_results(scenario):
    """``(results, truth)`` names of a run of ``scenario``'s model."""
    names = models.model_by_name(scenario.model).names
    fixed = ("rank", "n_states", "n_unobservable", "gramian_rank", "segments", "full_rank_after_s")
    per_state = [f"{kind}_{n}" for kind in ("observable", "sigma_ratio") for n in names]
    return (*fixed, *per_state), ()


def estimate(scenario):
    """Size of the analysis (:mod:`inins.commands.preflight`)."""
    from inins.commands.preflight import observability_estimate

    return observability_estimate(scenario)


def lines_of_sight(satellites):
    """Unit vectors receiver -> satellite in NED, shape (k, 3), or None."""
    if not satellites:
        return None
    az = np.array([s.azimuth_deg for s in satellites]) * DEG
    el = np.array([s.elevation_deg for s in satellites]) * DEG
    return np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), -np.sin(el)], axis=1)


def measurement(m, index):
    """A scenario measurement as a :class:`inins.observability.measurements.Measurement`."""
    return meas.Measurement(
        kind=m.kind,
        sigma=m.sigma,
        baseline_b=m.baseline_b_m,
        lever_arm_b=m.lever_arm_b_m,
        reference=m.reference,
        key=f"measurements[{index}]",
    )


def build_segments(scenario, los_n):
    """The listed segments, or those cut from the trajectory file."""
    lla = scenario.site.lla()
    if scenario.trajectory is not None:
        return trajectory_segments(scenario.trajectory, los_n)
    if scenario.flight is not None:
        return flight_segments(scenario.flight, los_n)
    out = []
    for i, s in enumerate(scenario.segments):
        mat_nb = rotation.mat_from_euler(s.roll_deg * DEG, s.pitch_deg * DEG, s.heading_deg * DEG)
        if s.vel_n_mps is not None:
            vel = np.array(s.vel_n_mps, dtype=float)
        elif s.speed_mps is not None:
            h = s.heading_deg * DEG
            vel = s.speed_mps * np.array([np.cos(h), np.sin(h), 0.0])
        else:
            vel = np.zeros(3)
        omega = None
        if s.omega_b_dps is not None:
            w_in = earth.rate_ie_n(lla[0]) + earth.rate_en_n(lla[0], lla[2], vel)
            omega = mat_nb.T @ w_in + np.array(s.omega_b_dps) * DEG
        out.append(
            make_segment(
                s.duration_s,
                lla,
                mat_nb=mat_nb,
                vel_n=vel,
                f_b=s.f_b_mps2,
                omega_ib_b=omega,
                los_n=los_n,
                key=f"segments[{i}]",
            )
        )
    return tuple(out)


def trajectory_segments(trajectory, los_n):
    """Segments of a table-data file: its truth attitude, and the mean specific force and
    body rate of the IMU increments over each truth interval (the table is at rest)."""
    record = read_table_data(trajectory.file)
    truth = record.truth
    if truth is None or len(truth.time) < 2:
        raise InputError(
            "the trajectory file has no truth attitude (a simulate-table output is needed)",
            source=str(trajectory.file),
            key="truth/quat_nb",
        )
    edges = np.round((np.concatenate([[record.t0], truth.time]) - record.t0) / record.dt)
    edges = np.clip(edges.astype(np.int64), 0, record.n_samples)
    sums = np.zeros((len(truth.time), 6))
    for k0, dtheta, dv in record.imu_chunks():
        rows = np.hstack([dtheta, dv])
        owner = np.searchsorted(edges, np.arange(k0, k0 + len(rows)), side="right") - 1
        inside = (owner >= 0) & (owner < len(sums))
        np.add.at(sums, owner[inside], rows[inside])
    span = np.maximum(np.diff(edges), 1)[:, None] * record.dt
    n = len(truth.time)
    return cut_segments(
        truth.time,
        rotation.mat_from_quat(truth.quat_nb),
        sums[:, 3:] / span,
        sums[:, :3] / span,
        np.zeros((n, 3)),
        np.tile(record.lla, (n, 1)),
        attitude_threshold=trajectory.attitude_threshold_deg * DEG,
        force_threshold=trajectory.force_threshold_mps2,
        los_n=los_n,
    )


def flight_segments(source, los_n):
    """Segments of a run-ekf scenario's simulated flight, sampled at ``sample_rate_hz``."""
    from inins.commands.run_ekf import flight_plan
    from inins.ekf.flight import flight_trajectory
    from inins.scenario.base import load_scenario
    from inins.scenario.run_ekf import RunEkfScenario

    ekf_scenario = load_scenario(RunEkfScenario, source.scenario, [], None)[0]
    if ekf_scenario.flight is None:
        raise InputError(
            "the run-ekf scenario has no flight: section", source=str(source.scenario), key="flight"
        )
    plan = flight_plan(ekf_scenario.flight)
    truth = flight_trajectory(plan)
    time = np.arange(0.0, plan.duration + 1e-9, 1.0 / source.sample_rate_hz)
    mat_nb, vel_n, lla = truth.state(time)
    omega_ib_b, f_b = truth.rates(time)
    return cut_segments(
        time,
        mat_nb,
        f_b,
        omega_ib_b,
        vel_n,
        lla,
        attitude_threshold=source.attitude_threshold_deg * DEG,
        force_threshold=source.force_threshold_mps2,
        los_n=los_n,
    )


def priors(p, names):
    """Initial 1-sigma per state (SI) from the prior groups."""
    group_of = {name: group for group, members in GROUPS.items() for name in members}
    out = []
    for name in names:
        if name == "clock_bias":
            out.append(p.clock_bias_m)
        elif name == "clock_drift":
            out.append(p.clock_drift_mps)
        else:
            key, unit = _PRIOR_OF_GROUP[group_of[name]]
            out.append(getattr(p, key) * unit)
    return np.array(out)


def result_numbers(found, segments):
    """Flat results: ranks and per state ``observable_<state>``, ``sigma_ratio_<state>``."""
    out = {
        "rank": found.rank,
        "n_states": found.n_states,
        "n_unobservable": found.n_unobservable,
        "gramian_rank": found.gramian_rank,
        "segments": len(found.pwcs.segment_rank),
        "full_rank_after_s": _full_rank_time(found, segments),
    }
    for s in found.states:
        out[f"observable_{s.name}"] = bool(s.observable)
    for s in found.states:
        out[f"sigma_ratio_{s.name}"] = None if not np.isfinite(s.sigma_ratio) else s.sigma_ratio
    return out


def _full_rank_time(found, segments):
    """End time (s) of the first segment after which every state is observable, or None."""
    ends = np.cumsum([s.duration for s in segments])
    full = [j for j, r in enumerate(found.pwcs.segment_rank) if r == found.n_states]
    return float(ends[full[0]]) if full else None


def datasets(found, segments):
    """Singular values per segment, the null space and the 1-sigma history."""
    p = found.pwcs
    out = {
        "observability/singular_values": Series(
            p.singular_values,
            "1",
            "",
            "singular values of the scaled observability matrix stacked up to each segment",
        ),
        "observability/segment_rank": Series(
            np.array(p.segment_rank), "1", "", "rank after each segment"
        ),
        "observability/null_space": Series(
            p.null_space,
            "SI",
            "",
            "unobservable directions (columns), SI per unit of the pivot state",
        ),
        "observability/segment_end": Series(
            np.cumsum([s.duration for s in segments]), "s", "", "end time of each segment"
        ),
    }
    if found.covariance is not None:
        c = found.covariance
        out["covariance/time"] = Series(c.time, "s", "", "time of each update")
        out["covariance/sigma"] = Series(
            c.sigma, "SI", "", "1-sigma per state (SI units of each state) after each update"
        )
        out["covariance/eigenvalues"] = Series(
            c.eigenvalues, "1", "", "eigenvalues of the normalised covariance at each segment end"
        )
    return out


TURN_ROLL = 10.0 * DEG
"""A segment banked more than this is part of a turn."""


def turns(segments):
    """(start, end) times (s) of the turns: runs of segments banked beyond :data:`TURN_ROLL`."""
    ends = np.cumsum([s.duration for s in segments])
    banked = [abs(rotation.euler_from_mat(s.mat_nb)[0]) > TURN_ROLL for s in segments]
    out, start = [], None
    for j, b in enumerate(banked):
        if b and start is None:
            start = float(ends[j] - segments[j].duration)
        if start is not None and not b:
            out.append((start, float(ends[j - 1])))
            start = None
    if start is not None:
        out.append((start, float(ends[-1])))
    return out


def turn_report(found, segments):
    """Degree of observability turn by turn: sigma / prior of the sensor-error states
    before the first turn and at the end of each turn (flights only)."""
    spans = turns(segments)
    cov = found.covariance
    if not spans or cov is None:
        return ""
    times = [spans[0][0], *(end for _, end in spans)]
    k = np.searchsorted(cov.time, times).clip(0, len(cov.time) - 1)
    rows = [
        [name, *(cov.sigma[k, i] / cov.sigma[0, i])]
        for i, name in enumerate(found.pwcs.names)
        if name.startswith(("mg_", "ma_", "bg_", "ba_"))
    ]
    heads = ["state", "before", *(f"turn {j + 1}" for j in range(len(spans)))]
    text = ", ".join(f"{a:.0f}-{b:.0f}" for a, b in spans)
    return (
        "\n\nsigma / prior before the first turn and at the end of each turn "
        f"(turns {text} s)\n" + format_table(rows, heads, fmt=".3g")
    )


def _sigma_text(value, unit):
    return "" if not np.isfinite(value) else f"{value:.4g} {unit}"


def report(scenario, found, segments):
    """Report body: the verdict, the per-state table, the unobservable combinations."""
    rows = [
        [
            s.name,
            s.unit,
            "yes" if s.observable else "NO",
            s.null_weight,
            _sigma_text(s.sigma_0, s.unit),
            _sigma_text(s.sigma_final, s.unit),
            s.sigma_ratio if np.isfinite(s.sigma_ratio) else None,
        ]
        for s in found.states
    ]
    kinds = ", ".join(m.kind for m in scenario.measurements)
    lines = [
        f"model {found.model}: rank {found.rank} of {found.n_states} "
        f"({found.n_unobservable} unobservable); Gramian rank {found.gramian_rank}",
        f"measurements: {kinds}; {len(segments)} segments, {sum(s.duration for s in segments):g}"
        f" s; {found.pwcs.method} observability matrix (null(Q_j) in null(F_j) on "
        f"{sum(found.pwcs.condition_holds)} of {len(segments)} segments)",
        f"rank after each segment: {list(found.pwcs.segment_rank)}",
        "",
        "states",
        format_table(
            rows,
            ["state", "unit", "observable", "null weight", "sigma 0", "sigma end", "ratio"],
            fmt=".4g",
        ),
        "",
        "unobservable combinations (moving the first state by 1 unit together with the "
        "others by their coefficients, SI, changes no measurement):",
    ]
    lines += [f"  {c}" for c in found.combinations] or ["  none: every state is observable"]
    lines += [
        "",
        f"rank tolerance {found.pwcs.tolerance:.3g} on the singular values of the "
        "SI-scaled matrix (rows normalised per measurement)",
    ]
    return "\n".join(lines)

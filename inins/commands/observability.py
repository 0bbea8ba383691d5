"""``inins observability``: which error states an aided INS design can ever estimate,
and how well (spec §7, paper 002).

Builds the segments (listed in the scenario, or cut from a table-data trajectory),
the measurement rows and the priors in SI, runs
:func:`inins.observability.analysis.analyse` (PWCS rank and null space, Gramian
cross-check, covariance analysis) and writes the per-state table, the unobservable
combinations, the singular values per segment and the 1-sigma history.
"""

import numpy as np

from inins.commands import observability_figures
from inins.core import rotation
from inins.core.error_model import GROUPS
from inins.core.units import ARCSEC, DEG, DEG_RTH, DPH, UG, UG_RTHZ
from inins.exceptions import InputError
from inins.observability import analysis, models
from inins.observability import segments as segments_mod
from inins.observability.analysis import NEAR_PRIOR, PRACTICAL_RATIO
from inins.observability.segments import cut_segments, interval_means
from inins.results import CommandResult, Series, format_table
from inins.scenario.observability import ObservabilityScenario
from inins.scenario.si.observability import listed_segments, measurement

SCENARIO_MODEL = ObservabilityScenario
FIGURES = {
    "observability-sigma.png": observability_figures.observability_sigma,
    "observability-singular-values.png": observability_figures.observability_singular_values,
}


def run(scenario, seed, *, sink=None, progress=None):
    """Analyse the scenario's model along its segments; ``seed`` is unused."""
    model = models.model_by_name(scenario.model)
    los_n = scenario.lines_of_sight()
    segments = build_segments(scenario, los_n)
    rows = [measurement(m, i) for i, m in enumerate(scenario.measurements)]
    sigma_0 = scenario.priors.sigmas(model.names) if scenario.covariance else None
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
                "combinations": list(found.combinations),
                "tolerance": float(found.pwcs.tolerance),
                "turns_s": [list(t) for t in segments_mod.turns(segments)],
            }
        },
        report=report(scenario, found, segments) + turn_report(found, segments),
        warnings=found.warnings,
    )


def declared_results(scenario):
    """``(results, truth)`` names of a run of ``scenario``'s model."""
    names = models.model_by_name(scenario.model).names
    fixed = (
        "rank",
        "n_states",
        "n_unobservable",
        "gramian_rank",
        "segments",
        "full_rank_after_s",
        "practically_observable_after_s",
        "n_poorly_observable",
    )
    per_state = [f"{kind}_{n}" for kind in ("observable", "sigma_ratio") for n in names]
    return (*fixed, *per_state), ()


def estimate(scenario):
    """Size of the analysis (:mod:`inins.commands.preflight`)."""
    from inins.commands.preflight import observability_estimate

    return observability_estimate(scenario)


def build_segments(scenario, los_n):
    """The listed segments, or those cut from the trajectory file."""
    if scenario.trajectory is not None:
        return trajectory_segments(scenario.trajectory, los_n)
    if scenario.flight is not None:
        return flight_segments(scenario.flight, los_n)
    return listed_segments(scenario, los_n)


def trajectory_segments(trajectory, los_n):
    """Segments of a table-data file: its truth attitude, and the mean specific force and
    body rate of the IMU increments over each truth interval (the table is at rest)."""
    from inins.io.tabledata import read_table_data  # only for a recorded trajectory

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
    omega_b, f_b = interval_means(record.imu_chunks(), edges, record.dt)
    n = len(truth.time)
    return cut_segments(
        truth.time,
        rotation.mat_from_quat(truth.quat_nb),
        f_b,
        omega_b,
        np.zeros((n, 3)),
        np.tile(record.lla, (n, 1)),
        attitude_threshold=trajectory.attitude_threshold_deg * DEG,
        force_threshold=trajectory.force_threshold_mps2,
        los_n=los_n,
    )


def flight_segments(source, los_n):
    """Segments of a run-ekf scenario's simulated flight, sampled at ``sample_rate_hz``."""
    from inins.ekf.flight import flight_trajectory
    from inins.scenario.base import load_scenario
    from inins.scenario.run_ekf import RunEkfScenario

    ekf_scenario = load_scenario(RunEkfScenario, source.scenario, [], None)[0]
    if ekf_scenario.flight is None:
        raise InputError(
            "the run-ekf scenario has no flight: section", source=str(source.scenario), key="flight"
        )
    plan = ekf_scenario.flight.plan()
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


def result_numbers(found, segments):
    """Flat results: ranks, the time of full rank and the time every state is observable
    in practice (sigma down to a tenth of its prior,
    :data:`inins.observability.analysis.PRACTICAL_RATIO`), the number of states that stay
    poorly observable, and per state ``observable_<state>``, ``sigma_ratio_<state>``."""
    cov = found.covariance is not None
    out = {
        "rank": found.rank,
        "n_states": found.n_states,
        "n_unobservable": found.n_unobservable,
        "gramian_rank": found.gramian_rank,
        "segments": len(found.pwcs.segment_rank),
        "full_rank_after_s": _full_rank_time(found, segments),
        "practically_observable_after_s": found.practically_observable_after_s,
        "n_poorly_observable": len(found.poorly_observable) if cov else None,
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


def turn_report(found, segments):
    """Degree of observability turn by turn: sigma / prior of the sensor-error states
    before the first turn and at the end of each turn (flights only)."""
    spans = segments_mod.turns(segments)
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


_LAB_UNIT = {  # state group -> (lab unit name, SI per lab unit)
    "attitude": ("deg", DEG),
    "accel_bias": ("ug", UG),
    "gyro_bias": ("deg/h", DPH),
    "accel_misalignment": ("arcsec", ARCSEC),
    "gyro_misalignment": ("arcsec", ARCSEC),
}


def _lab_text(name, value):
    """A sigma in the lab unit of its state group (deg, ug, deg/h, arcsec), or n/a."""
    group = next((g for g, members in GROUPS.items() if name in members), None)
    if group not in _LAB_UNIT:
        return "(SI)"
    if not np.isfinite(value):
        return "n/a"
    unit, si = _LAB_UNIT[group]
    return f"{value / si:.4g} {unit}"


def _sigma_text(value, unit):
    return "n/a" if not np.isfinite(value) else f"{value:.4g} {unit}"


def report(scenario, found, segments):
    """Report body: the verdict (rank and degree of observability), the per-state table,
    the unobservable combinations and the states that stay poorly observable."""
    rows = [
        [
            s.name,
            s.unit,
            "yes" if s.observable else "NO",
            s.null_weight,
            _sigma_text(s.sigma_0, s.unit),
            _sigma_text(s.sigma_final, s.unit),
            _lab_text(s.name, s.sigma_final),
            s.sigma_ratio if np.isfinite(s.sigma_ratio) else "n/a",
            s.degree,
        ]
        for s in found.states
    ]
    kinds = ", ".join(m.kind for m in scenario.measurements)
    full = _full_rank_time(found, segments)
    lines = [
        f"model {found.model}: rank {found.rank} of {found.n_states} "
        f"({found.n_unobservable} unobservable); Gramian rank {found.gramian_rank}",
        f"measurements: {kinds}; {len(segments)} segments, {sum(s.duration for s in segments):g}"
        f" s; {found.pwcs.method} observability matrix (null(Q_j) in null(F_j) on "
        f"{sum(found.pwcs.condition_holds)} of {len(segments)} segments)",
        f"rank after each segment: {_compact(found.pwcs.segment_rank)}",
        "full rank (every state observable in principle): "
        + ("never" if full is None else f"after {full:g} s"),
        _practical_line(found),
        "",
        "states (degree of the observable ones: good = sigma down to "
        f"{PRACTICAL_RATIO:g} of the prior or below, weak = reduced less, none = above "
        f"{NEAR_PRIOR:g} of the prior: hardly estimated at all)",
        format_table(
            rows,
            [
                "state",
                "unit",
                "observable",
                "null weight",
                "sigma 0",
                "sigma end",
                "sigma end (lab)",
                "ratio",
                "degree",
            ],
            fmt=".4g",
        ),
        "",
        "unobservable combinations (moving the first state by 1 unit together with the "
        "others by their coefficients, SI, changes no measurement):",
    ]
    lines += [f"  {c}" for c in found.combinations] or ["  none: every state is observable"]
    weak = [s for s in found.states if s.degree in ("weak", "none")]
    if weak:
        lines += ["", "poorly observable (observable in rank, sigma above a tenth of the prior):"]
        lines += [
            f"  {s.name}: sigma end {s.sigma_ratio:.3g} of the prior"
            + (" - not estimated in practice" if s.degree == "none" else "")
            for s in weak
        ]
    lines += [
        "",
        f"rank tolerance {found.pwcs.tolerance:.3g} on the singular values of the "
        "SI-scaled matrix (rows normalised per measurement)",
    ]
    return "\n".join(lines)


def _practical_line(found):
    if found.covariance is None:
        return "observable in practice: n/a (covariance: false)"
    t = found.practically_observable_after_s
    if t is not None:
        return (
            f"observable in practice (every sigma down to {PRACTICAL_RATIO:g} of its prior): "
            f"after {t:g} s"
        )
    return (
        f"observable in practice (every sigma down to {PRACTICAL_RATIO:g} of its prior): "
        f"never; {_count(len(found.poorly_observable), 'state')} "
        f"({', '.join(found.poorly_observable)}) "
        + ("stays" if len(found.poorly_observable) == 1 else "stay")
        + " above"
    )


def _count(n, word):
    return f"{n} {word}" + ("" if n == 1 else "s")


def _compact(ranks):
    """``[9, 9, 9, 11, 12]`` -> ``9 x3, 11, 12`` (runs of equal ranks counted)."""
    out, k = [], 0
    ranks = list(ranks)
    while k < len(ranks):
        j = k
        while j + 1 < len(ranks) and ranks[j + 1] == ranks[k]:
            j += 1
        out.append(f"{ranks[k]}" + (f" x{j - k + 1}" if j > k else ""))
        k = j + 1
    return ", ".join(out)

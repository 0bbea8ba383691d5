"""The text report of a run-ekf post-processing run (``post:``)."""

import math
from typing import NamedTuple

import numpy as np

from inins.results import format_table


def null(v):
    """A finite value as float, else None (a summary number that was not computed)."""
    return None if v is None or not np.isfinite(v) else float(v)


def _sigma(v, unit):
    return "off" if v <= 0 else f"{v:g} {unit}"


def _fmt(v, spec=".3g"):
    return "n/a" if v is None else format(v, spec)


def _time_mapping(fit, out):
    """The time-mapping lines: the mapping at its reference instant, the rate test."""
    rate = "" if fit.model == "constant" else f" {fit.rate * 1e6:+.0f} ppm x (t - T)"
    lines = [
        f"time mapping (turn-rate fit, {fit.model}, {len(fit.lags)} windows): GNSS = IMU tick "
        f"+ {fit.offset:.4f} s{rate} (1-sigma {_fmt(out['post_time_offset_fit_sigma_s'])} s) "
        f"at GNSS time T = {fit.t_ref_gnss:.1f} s from the first epoch; window lags scatter "
        f"{1e3 * out['post_time_fit_residual_rms_s']:.0f} ms RMS about it"
    ]
    test = fit.rate_test
    if test is not None:
        verdict = "significant" if test.significant else "not significant"
        verdict += ", applied" if fit.model != "constant" else ", not applied"
        lines.append(
            f"clock rate of the line {test.rate * 1e6:.0f} ppm (1-sigma {test.sigma * 1e6:.0f}): "
            f"t = {test.t:.2f} against {test.threshold:.2f} (two-sided, false alarm "
            f"{test.alpha:g}, {test.dof} dof): {verdict}"
        )
    return lines


class Gated(NamedTuple):
    """What the outlier gate did: its ``limit`` on a fix's NIS (inf: no gate) and the
    times (s from the run start) of the epochs the filter ``rejected``, of those that
    re-initialised it (``reinit``), of the reference epochs not scored (``screened``) and
    of the position and velocity spikes left out before the filter (``spikes``,
    ``vel_spikes``)."""

    limit: float
    rejected: np.ndarray
    reinit: np.ndarray
    screened: np.ndarray
    spikes: np.ndarray
    vel_spikes: np.ndarray


def _times(t, most=12):
    shown = ", ".join(f"{v:.2f}" for v in t[:most])
    return shown + (f", ... ({len(t) - most} more)" if len(t) > most else "")


def _gate_lines(p, out, gated):
    g = p.outlier_gate
    if not math.isfinite(gated.limit):
        return ["outlier gate off (post.outlier_gate.probability: 1): every fix used"]
    when = lambda t: f" at {_times(t)} s" if len(t) else ""  # noqa: E731
    lines = [
        f"outlier gate: a fix fails when its NIS exceeds {gated.limit:.4g} (chi-square(3) at "
        f"{g.probability:g}, sigma x{g.sigma_scale:g}); {out['post_gnss_rejected']} epochs "
        "rejected: spikes (failing against the epochs before and after, left out before the "
        f"filter) {len(gated.spikes)}" + when(gated.spikes) + f", velocity spikes "
        f"{len(gated.vel_spikes)}" + when(gated.vel_spikes) + ", by the filter's innovation "
        f"{len(gated.rejected)}" + when(gated.rejected),
        f"re-initialisations from the solution (after {g.reinit_after} rejected epochs): "
        f"{out['post_gnss_reinit']}" + when(gated.reinit),
        "reference epochs not scored (they fail the gate): "
        f"{out['post_reference_screened']}" + when(gated.screened),
    ]
    return lines


def report(p, out, scores, fit, t0, wins, start=None, gated=None):
    """The report's text; ``start`` the :class:`~inins.ekf.gnss_time.AbsoluteTime` of the
    first epoch, or None; ``gated`` what the outlier gate did (:class:`Gated`), or None."""
    lines = [
        f"loosely coupled post-processing of {p.gnss.file.name} + {p.imu.file.name}: "
        f"{out['post_epochs']} epochs, {out['post_gnss_used']} GNSS updates, "
        f"{'24' if p.misalignments else '15'} states"
        f"{' + time offset' if p.time.state else ''}, {'FB' if p.feedback else 'FF'}, "
        f"smoother {p.smoother}",
        f"filter {out['post_filter_wall_s']:.3g} s, smoother {_fmt(out['post_smoother_wall_s'])} s"
        " (first run includes JIT compilation); position NIS mean "
        f"{_fmt(out['post_nis_pos_mean'])}",
        f"initial heading {out['post_initial_heading_deg']:.2f} deg ("
        + (
            "from the first motion)"
            if p.init == "motion"
            else "the reference's + init_heading_error_deg)"
        ),
        f"aiding: NHC {_sigma(p.aiding.nhc_sigma_mps, 'm/s')}, ZUPT "
        f"{_sigma(p.aiding.zupt_sigma_mps, 'm/s')}, ZARU {_sigma(p.aiding.zaru_sigma_dps, 'deg/s')}"
        f"; {out['post_stationary_epochs']} stationary epochs; mounting "
        f"{list(p.aiding.mounting_deg)} deg",
    ]
    if gated is not None:
        lines += _gate_lines(p, out, gated)
    if start is None:
        lines.append(
            "times are the solution file's from its first epoch (its tags are not absolute "
            "GPS time: no start date); every output is on them"
        )
    else:
        lines.append(
            f"times are GNSS time from the solution file's first epoch: GPS week {start.week}, "
            f"{start.sow:.3f} s of week = {start.utc or 'UTC unknown (leap seconds)'}; every "
            "output is on it"
        )
    if fit is not None:
        lines += _time_mapping(fit, out)
    if out["post_time_offset_state_s"] is not None:
        lines.append(
            f"residual time-offset state: {1e3 * out['post_time_offset_state_s']:.1f} ms "
            f"+- {1e3 * out['post_time_offset_state_sigma_s']:.2f} ms (a solution tagged t "
            "was taken at IMU time t + offset)"
        )
    if out["post_heading_diff_mean_deg"] is not None:
        lines.append(
            f"attitude against the reference from {p.score_from_s:g} s: heading "
            f"{out['post_heading_diff_mean_deg']:.3f} deg mean "
            f"(std {out['post_heading_diff_std_deg']:.3f}) forward, "
            f"{_fmt(out['post_sm_heading_diff_mean_deg'], '.3f')} deg "
            f"(std {_fmt(out['post_sm_heading_diff_std_deg'], '.3f')}) smoothed; "
            f"roll/pitch mean within {out['post_tilt_diff_max_deg']:.3f} deg"
        )
    lines.append(
        "sensor estimates: accel bias "
        + ", ".join(f"{out[f'post_accel_bias_{a}_ug']:.0f}" for a in "xyz")
        + " ug; gyro bias "
        + ", ".join(f"{out[f'post_gyro_bias_{a}_dph']:.1f}" for a in "xyz")
        + " deg/h"
    )
    if scores:
        rows = []
        f = scores["fwd"]
        sm = scores.get("sm")
        for i, (a, b) in enumerate(f.window):
            rows.append(
                [
                    f"{a - t0:.0f}-{b - t0:.0f}",
                    float(f.max_horizontal[i]),
                    float(f.max_3d[i]),
                    float(sm.max_horizontal[i]) if sm else math.nan,
                    float(sm.max_3d[i]) if sm else math.nan,
                ]
            )
        lines += [
            "",
            f"outages ({len(wins)}), max drift against the reference epochs (Q={p.reference_q}), m",
            format_table(rows, ["window s", "fwd hor", "fwd 3D", "sm hor", "sm 3D"]),
            f"RMS of the maxima: forward {out['post_fwd_drift_hor_rms_m']:.3g} m horizontal, "
            f"{out['post_fwd_drift_3d_rms_m']:.3g} m 3D; smoothed "
            f"{_fmt(out['post_sm_drift_hor_rms_m'])} m, {_fmt(out['post_sm_drift_3d_rms_m'])} m",
        ]
    return "\n".join(lines)

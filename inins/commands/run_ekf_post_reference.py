"""The ``post.reference`` part of a run-ekf post run: the reference trajectory read and
put on the solutions' clock, the forward and smoothed solutions scored against it
(:mod:`inins.ekf.reference_scoring`), its results, datasets and report lines.

Clock: the reference's tags (``time_scale_s``, then ``time_offset_s`` added, in its
``time_system``; UTC with the leap seconds of the date added) become GPS seconds, and
the run's time axis is GPS seconds from the solution file's first epoch; the solutions
are scored as labelled (:func:`inins.ekf.gnss_time.on_gnss_time`).
"""

import numpy as np

from inins.core.units import DEG
from inins.ekf import gnss_time, reference_scoring
from inins.io import reference_files
from inins.results import Series

SOLUTIONS = (("fwd", "forward"), ("sm", "smoothed"))
_ERRORS = (("hor", "m", 1.0), ("ver", "m", 1.0), ("vel", "mps", 1.0))
_ERRORS += (("heading", "deg", DEG), ("roll", "deg", DEG), ("pitch", "deg", DEG))
_STATS = ("rms", "p95", "max")
_DRIFT = ("drift_hor_rms_m", "drift_3d_rms_m", "drift_hor_max_m")


def _names(p):
    """The result names of solution ``p`` (fwd, sm)."""
    stats = [f"post_ref_{p}_{q}_{s}_{unit}" for q, unit, _ in _ERRORS for s in _STATS]
    return [*stats, f"post_ref_{p}_heading_mean_deg", *(f"post_ref_{p}_{d}" for d in _DRIFT)]


NAMES = ("post_ref_epochs", *_names("fwd"), *_names("sm"))
"""Results against ``post.reference`` (null without it; attitude and velocity null
where the reference has none; drift null without outages)."""


def read(r):
    """The :class:`~inins.io.reference_files.ReferenceFile` of a ``post.reference``
    section on GPS time (UTC tags moved by their leap seconds), or None."""
    if r is None:
        return None
    ref = reference_files.read_reference(r)
    sol = gnss_time.solution_on_gps_time(ref.solution, key="post.reference.time_system")
    return reference_files.ReferenceFile(sol, ref.euler)


def score(ref, r, gnss, prepared, done):
    """Dict ``fwd``/``sm`` -> :class:`~inins.ekf.reference_scoring.ReferenceScore` of the
    run ``done`` against the reference ``ref`` (section ``r``); empty without one."""
    if ref is None:
        return {}
    sols = {"fwd": done.forward} | ({"sm": done.smoothed} if done.smoothed else {})
    sols = {k: gnss_time.on_gnss_time(done.time, s) for k, s in sols.items()}
    s = ref.solution
    vel = None if np.isnan(s.vel_ned).all() else s.vel_ned
    arrays = (s.time - gnss.time[0], s.lla, vel, ref.euler)
    return reference_scoring.reference_scores(
        done.time,
        sols,
        np.asarray(r.lever_arm_m, float),
        arrays,
        prepared.outages,
        prepared.t0,
        str(r.file),
    )


def results(scores):
    """The flat results (lab units) of :func:`score`."""
    out = dict.fromkeys(NAMES)
    if not scores:
        return out
    out["post_ref_epochs"] = int(scores["fwd"].time.size)
    for p, _ in SOLUTIONS:
        if p not in scores:
            continue
        sc = scores[p]
        stats = sc.stats()
        for q, unit, scale in _ERRORS:
            if stats[q] is not None:
                for s in _STATS:
                    out[f"post_ref_{p}_{q}_{s}_{unit}"] = getattr(stats[q], s) / scale
        heading = sc.euler[:, 2]
        if np.isfinite(heading).any():
            out[f"post_ref_{p}_heading_mean_deg"] = float(np.nanmean(heading) / DEG)
        if sc.drift is not None:
            out[f"post_ref_{p}_drift_hor_rms_m"] = sc.drift.rms_horizontal
            out[f"post_ref_{p}_drift_3d_rms_m"] = sc.drift.rms_3d
            out[f"post_ref_{p}_drift_hor_max_m"] = float(sc.drift.max_horizontal.max())
    return out


def datasets(ref, r, gnss, scores):
    """The ``post/reference_trajectory/...`` datasets (empty without a reference)."""
    if not scores:
        return {}
    k = "post/reference_trajectory"
    s = ref.solution
    d = {
        f"{k}/time": Series(
            s.time - gnss.time[0], "s", "", "reference epochs on post/time's clock"
        ),
        f"{k}/lla": Series(s.lla, "rad, rad, m", "", f"reference trajectory ({r.file.name})"),
        f"{k}/lever_arm": Series(
            np.asarray(r.lever_arm_m, float), "m", "b", "reference point minus IMU"
        ),
    }
    for p, key in SOLUTIONS:
        if p not in scores:
            continue
        sc = scores[p]
        d[f"{k}/{key}/time"] = Series(sc.time, "s", "", "reference epochs scored (in the run)")
        d[f"{k}/{key}/pos_error_ned"] = Series(
            sc.pos_ned, "m", "n", f"{key} position minus the reference"
        )
        d[f"{k}/{key}/vel_error_ned"] = Series(
            sc.vel_ned, "m/s", "n", f"{key} velocity minus the reference (NaN: none)"
        )
        d[f"{k}/{key}/euler_error"] = Series(
            sc.euler, "rad", "", f"{key} roll, pitch, heading minus the reference (NaN: none)"
        )
    return d


def _f(v, spec=".3g"):
    return "n/a" if v is None else format(v, spec)


def report_lines(r, out):
    """The report's lines about the reference trajectory (none without one)."""
    if out["post_ref_epochs"] is None:
        return []
    lines = [
        "",
        f"against the reference trajectory {r.file.name} ({out['post_ref_epochs']} epochs in "
        f"the run; its point {list(r.lever_arm_m)} m from the IMU): RMS / p95 / max",
    ]
    for q, unit, _ in _ERRORS:
        cells = []
        for p, key in SOLUTIONS:
            v = [out[f"post_ref_{p}_{q}_{s}_{unit}"] for s in _STATS]
            if v[0] is not None:
                cells.append(f"{key} {' / '.join(_f(x) for x in v)}")
        if cells:
            shown = "m/s" if unit == "mps" else unit
            lines.append(f"  {q} error ({shown}): " + "; ".join(cells))
    if out["post_ref_fwd_heading_mean_deg"] is not None:
        lines.append(
            f"  heading error mean (solution minus reference): forward "
            f"{out['post_ref_fwd_heading_mean_deg']:+.3f} deg, smoothed "
            f"{_f(out['post_ref_sm_heading_mean_deg'], '+.3f')} deg"
        )
    if out["post_ref_fwd_drift_hor_rms_m"] is not None:
        lines.append(
            "  outages against the reference, RMS of the max drift: forward "
            f"{out['post_ref_fwd_drift_hor_rms_m']:.3g} m horizontal, "
            f"{out['post_ref_fwd_drift_3d_rms_m']:.3g} m 3D; smoothed "
            f"{_f(out['post_ref_sm_drift_hor_rms_m'])} m, {_f(out['post_ref_sm_drift_3d_rms_m'])} m"
        )
    return lines

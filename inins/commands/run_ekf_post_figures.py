"""run-ekf figures of a post-processing run (``post:``), each named for what it shows:
the track against the reference fixes (and the ``post.reference`` trajectory where the
scenario gives one), the horizontal error with its 3-sigma (and against that
trajectory), the
sensor estimates with their 3-sigma, the innovations with theirs, and the attitude
against a reference attitude where the solution file gives one. Outage windows are
shaded in every figure over time."""

import numpy as np

from inins.commands.figures import Skipped, pyplot
from inins.core import error_model
from inins.core.units import DEG, UG
from inins.ekf import loose

SOLUTIONS = (("forward", "-"), ("smoothed", "--"))
"""The solutions a figure draws, and their line styles."""
TO_SCALE_RATIO = 4.0
"""A track whose extent is longer than this many times its width is drawn with its
axes not to scale (equal axes would collapse a straight drive into a sliver)."""
ATT = slice(6, 9)
"""The attitude error states (phi N, E, D) among a solution's sigmas (LOOSE layouts)."""


def _local(lla, origin):
    """East, north (m) of positions about ``origin`` (flat-Earth at the origin)."""
    d = error_model.position_error_ned(lla, np.broadcast_to(origin, lla.shape))
    return d[:, 1], d[:, 0]


def _shade(ax, result):
    for k, (a, b) in enumerate(result.datasets["post/outage_windows"].data):
        ax.axvspan(a, b, color="0.88", lw=0, zorder=0, label="GNSS outage" if k == 0 else None)


def _antenna_of(ds, key, lever):
    """The antenna positions of solution ``key`` (on GNSS time as stored, so no
    time-offset shift: :mod:`inins.ekf.gnss_time`)."""
    return loose.antenna_positions(
        ds[f"post/{key}/quat_nb"].data,
        ds[f"post/{key}/lla"].data,
        lever,
        ds[f"post/{key}/vel_n"].data,
        None,
    )


def _finish(fig, ax, path, plt, legend=True):
    if legend:
        ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)


def trajectory(result, path):
    """The reference fixes and the forward and smoothed antenna tracks on a local map;
    equal axes unless the track is more than :data:`TO_SCALE_RATIO` times longer than
    wide (then labelled not to scale)."""
    plt = pyplot()
    ds = result.datasets
    ref = ds["post/reference/lla"].data
    origin = ref[0]
    fig, ax = plt.subplots(figsize=(7, 7), layout="constrained")
    e, n = _local(ref, origin)
    ax.plot(e, n, ".", ms=2, color="0.5", label="reference fixes")
    if REF_LLA in ds:
        e_r, n_r = _local(ds[REF_LLA].data, origin)
        ax.plot(e_r, n_r, "-", lw=0.8, color="k", label="reference trajectory")
    lever = ds["post/lever_arm"].data
    for key, style in SOLUTIONS:
        if f"post/{key}/lla" in ds:
            e_k, n_k = _local(_antenna_of(ds, key, lever), origin)
            ax.plot(e_k, n_k, style, lw=0.9, label=f"{key} antenna")
    extent = sorted((np.ptp(e), np.ptp(n)))
    if extent[1] <= TO_SCALE_RATIO * max(extent[0], 1.0):
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_title("track (equal axes)", fontsize=9)
    else:
        ax.set_title("track (axes NOT to scale: a long, narrow drive)", fontsize=9)
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    _finish(fig, ax, path, plt)


def beyond_3_sigma(err, sigma):
    """Fraction of epochs whose horizontal error exceeds 3 times the horizontal sigma
    (``hypot`` of the north and east sigmas): for an honest filter with equal north and
    east sigmas the error is Rayleigh-distributed and the fraction ``exp(-9)``, 0.01 %."""
    if err.size == 0:
        return float("nan")
    return float(np.mean(err > 3.0 * sigma))


REF_LLA = "post/reference_trajectory/lla"
"""The ``post.reference`` trajectory's positions, where the scenario gives one."""


def _against_reference(ax, ds, key, color):
    """The horizontal error of solution ``key`` against the ``post.reference``
    trajectory (its point), where the run has one."""
    name = f"post/reference_trajectory/{key}/pos_error_ned"
    if name not in ds:
        return
    d = ds[name].data
    t = ds[f"post/reference_trajectory/{key}/time"].data
    ax.plot(t, np.hypot(d[:, 0], d[:, 1]), "-.", color=color, lw=0.7,
            label=f"{key} against the reference trajectory")  # fmt: skip


def horizontal_error(result, path):
    """Horizontal antenna error against the reference fixes over time with the filter's
    3-sigma (from the north and east sigmas), outages shaded; the title gives the share
    of epochs beyond 3 sigma (:func:`beyond_3_sigma`: 0.01 % for an honest filter)."""
    plt = pyplot()
    ds = result.datasets
    t = ds["post/time"].data
    rt, ref = ds["post/reference/time"].data, ds["post/reference/lla"].data
    idx = np.clip(np.searchsorted(rt, t), 0, rt.size - 1)
    hit = np.abs(rt[idx] - t) < 1e-6
    lever = ds["post/lever_arm"].data
    fig, ax = plt.subplots(figsize=(10, 4.5), layout="constrained")
    _shade(ax, result)
    beyond = []
    for key, _ in SOLUTIONS:
        if f"post/{key}/lla" not in ds:
            continue
        ant = _antenna_of(ds, key, lever)
        d = error_model.position_error_ned(ant[hit], ref[idx[hit]])
        err = np.hypot(d[:, 0], d[:, 1])
        sig = ds[f"post/{key}/sigma"].data[hit]
        sig_h = np.hypot(sig[:, 0], sig[:, 1])
        (line,) = ax.plot(t[hit], err, lw=0.8, label=f"{key} error")
        ax.plot(t[hit], 3 * sig_h, ":", color=line.get_color(), lw=0.9, label=f"{key} 3 sigma")
        beyond.append(f"{key} {100 * beyond_3_sigma(err, sig_h):.1f} %")
        _against_reference(ax, ds, key, line.get_color())
    ax.set_yscale("log")
    ax.set_title(f"epochs beyond 3 sigma: {', '.join(beyond)} (0.01 % if honest)", fontsize=9)
    ax.set_xlabel("time from the first GNSS epoch (s)")
    ax.set_ylabel("horizontal antenna error (m)")
    _finish(fig, ax, path, plt)


def _sensors(result, path, lo, scale, unit, title):
    plt = pyplot()
    ds = result.datasets
    t = ds["post/time"].data
    fig, ax = plt.subplots(figsize=(10, 4.5), layout="constrained")
    _shade(ax, result)
    key = "smoothed" if "post/smoothed/sensors" in ds else "forward"
    est = ds[f"post/{key}/sensors"].data[:, lo : lo + 3] * scale
    sig = ds[f"post/{key}/sigma"].data[:, 9 + lo : 12 + lo] * scale
    for i, axis in enumerate("xyz"):
        (line,) = ax.plot(t, est[:, i], lw=0.9, label=axis)
        ax.fill_between(
            t, est[:, i] - 3 * sig[:, i], est[:, i] + 3 * sig[:, i], color=line.get_color(),
            alpha=0.15, lw=0,
        )  # fmt: skip
    ax.set_title(f"{title}, {key} estimate with its 3-sigma band", fontsize=9)
    ax.set_xlabel("time from the first GNSS epoch (s)")
    ax.set_ylabel(f"{title} ({unit})")
    _finish(fig, ax, path, plt)


def gyro_bias(result, path):
    """Gyro bias estimates (deg/h) with their 3-sigma bands."""
    _sensors(result, path, 3, 3600.0 / DEG, "deg/h", "gyro bias")


def accel_bias(result, path):
    """Accelerometer bias estimates (ug) with their 3-sigma bands."""
    _sensors(result, path, 0, 1.0 / UG, "ug", "accelerometer bias")


def robust_limit(values, quantile=0.99, margin=1.5):
    """A symmetric axis limit that shows the bulk of ``values`` (``margin`` times their
    ``quantile`` of magnitude), so that a few outage-exit jumps do not set the scale."""
    finite = np.abs(values[np.isfinite(values)])
    if finite.size == 0:
        return 1.0
    return float(margin * np.quantile(finite, quantile)) or 1.0


def innovations(result, path):
    """Position innovations (m) north, east, down with their 3-sigma (from the
    innovation variances); the axis shows 99 % of them, the rest are marked at the
    edge with their count."""
    plt = pyplot()
    ds = result.datasets
    t = ds["post/time"].data
    y = ds["post/innovation"].data[:, :3]
    sig = np.sqrt(ds["post/innovation_variance"].data[:, :3])
    fig, axes = plt.subplots(3, 1, figsize=(10, 7), sharex=True, layout="constrained")
    for i, (ax, axis) in enumerate(zip(axes, "NED", strict=True)):
        _shade(ax, result)
        lim = robust_limit(y[:, i])
        ax.fill_between(t, -3 * sig[:, i], 3 * sig[:, i], color="tab:orange", alpha=0.2, lw=0,
                        label="3 sigma")  # fmt: skip
        ax.plot(t, y[:, i], ".", ms=1.5, color="tab:blue", label=f"{axis} innovation")
        out = np.abs(y[:, i]) > lim
        if out.any():
            ax.plot(t[out], np.clip(y[out, i], -lim, lim), "^", ms=4, color="tab:red",
                    label=f"{int(out.sum())} beyond the axis")  # fmt: skip
        ax.set_ylim(-lim, lim)
        ax.set_ylabel(f"{axis} (m)")
        ax.legend(fontsize=7, loc="upper right")
        ax.grid(alpha=0.3)
    axes[0].set_title("GNSS position innovations with their 3-sigma", fontsize=9)
    axes[-1].set_xlabel("time from the first GNSS epoch (s)")
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)


def attitude(result, path):
    """Roll, pitch and heading minus the reference attitude (deg) with the filter's
    3-sigma of the matching attitude error, where the solution file gives a reference
    attitude."""
    ds = result.datasets
    keys = [k for k, _ in SOLUTIONS if f"post/{k}/attitude_minus_reference" in ds]
    if not keys:
        raise Skipped("no reference attitude (post.gnss.attitude_columns): nothing to compare")
    plt = pyplot()
    t = ds["post/time"].data
    fig, axes = plt.subplots(3, 1, figsize=(10, 7), sharex=True, layout="constrained")
    for key in keys:
        at = ds[f"post/{key}/attitude_time"].data
        diff = np.degrees(ds[f"post/{key}/attitude_minus_reference"].data)
        idx = np.clip(np.searchsorted(t, at), 0, t.size - 1)
        sig = np.degrees(ds[f"post/{key}/sigma"].data[idx, ATT])
        for i, ax in enumerate(axes):
            (line,) = ax.plot(at, diff[:, i], lw=0.8, label=f"{key}")
            ax.plot(at, 3 * sig[:, i], ":", color=line.get_color(), lw=0.8, label=f"{key} 3 sigma")
            ax.plot(at, -3 * sig[:, i], ":", color=line.get_color(), lw=0.8)
    for ax, name in zip(axes, ("roll", "pitch", "heading"), strict=True):
        _shade(ax, result)
        ax.set_ylabel(f"{name} (deg)")
        ax.legend(fontsize=7, loc="upper right")
        ax.grid(alpha=0.3)
    axes[0].set_title("attitude minus the reference attitude", fontsize=9)
    axes[-1].set_xlabel("time from the first GNSS epoch (s)")
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)


FIGURES = {
    "run-ekf-post-trajectory.png": trajectory,
    "run-ekf-post-horizontal-error.png": horizontal_error,
    "run-ekf-post-gyro-bias.png": gyro_bias,
    "run-ekf-post-accel-bias.png": accel_bias,
    "run-ekf-post-innovations.png": innovations,
    "run-ekf-post-attitude.png": attitude,
}
"""A post run's figures by file name."""

"""run-ekf figures of a post-processing run (``post:``), and run-ekf's figure table that
draws the tight figure or the post one under each name."""

import numpy as np

from inins.core import error_model
from inins.core.units import DEG, UG
from inins.ekf import loose


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _local(lla, origin):
    """East, north (m) of positions about ``origin`` (flat-Earth at the origin)."""
    d = error_model.position_error_ned(lla, np.broadcast_to(origin, lla.shape))
    return d[:, 1], d[:, 0]


def _shade(ax, result):
    for a, b in result.datasets["post/outage_windows"].data:
        ax.axvspan(a, b, color="0.85", lw=0)


def _antenna_of(ds, key, lever):
    off = ds.get(f"post/{key}/time_offset")
    return loose.antenna_positions(
        ds[f"post/{key}/quat_nb"].data,
        ds[f"post/{key}/lla"].data,
        lever,
        ds[f"post/{key}/vel_n"].data,
        None if off is None else off.data,
    )


def fig_trajectory(result, path):
    """Trajectory on a local map: reference, forward and smoothed antenna positions."""
    plt = _pyplot()
    ds = result.datasets
    ref = ds["post/reference/lla"].data
    origin = ref[0]
    fig, ax = plt.subplots(figsize=(7, 7), layout="constrained")
    e, n = _local(ref, origin)
    ax.plot(e, n, ".", ms=2, color="0.5", label="reference")
    lever = ds["post/lever_arm"].data
    for key, style in (("forward", "-"), ("smoothed", "--")):
        if f"post/{key}/lla" in ds:
            ant = _antenna_of(ds, key, lever)
            e, n = _local(ant, origin)
            ax.plot(e, n, style, lw=0.9, label=key)
    ax.set_aspect("equal")
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)


def fig_errors(result, path):
    """Horizontal position error against the reference vs time, with the filter's
    +-3 sigma (horizontal, from the north and east sigmas), outages shaded."""
    plt = _pyplot()
    ds = result.datasets
    t = ds["post/time"].data
    rt, ref = ds["post/reference/time"].data, ds["post/reference/lla"].data
    idx = np.clip(np.searchsorted(rt, t), 0, rt.size - 1)
    hit = np.abs(rt[idx] - t) < 1e-6
    lever = ds["post/lever_arm"].data
    fig, ax = plt.subplots(figsize=(10, 4.5), layout="constrained")
    _shade(ax, result)
    for key in ("forward", "smoothed"):
        if f"post/{key}/lla" not in ds:
            continue
        ant = _antenna_of(ds, key, lever)
        err = error_model.position_error_ned(ant[hit], ref[idx[hit]])
        sig = ds[f"post/{key}/sigma"].data[hit]
        (line,) = ax.plot(t[hit], np.hypot(err[:, 0], err[:, 1]), lw=0.8, label=f"{key} error")
        ax.plot(
            t[hit],
            3 * np.hypot(sig[:, 0], sig[:, 1]),
            ":",
            color=line.get_color(),
            lw=0.8,
            label=f"{key} 3 sigma",
        )
    ax.set_yscale("log")
    ax.set_xlabel("time from the first GNSS epoch (s); outages shaded")
    ax.set_ylabel("horizontal error (m)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)


def _sensor_figure(result, path, lo, scale, unit, title):
    plt = _pyplot()
    ds = result.datasets
    t = ds["post/time"].data
    fig, ax = plt.subplots(figsize=(10, 4.5), layout="constrained")
    _shade(ax, result)
    key = "smoothed" if "post/smoothed/sensors" in ds else "forward"
    est = ds[f"post/{key}/sensors"].data[:, lo : lo + 3] * scale
    sig = ds[f"post/{key}/sigma"].data[:, 9 + lo : 12 + lo] * scale
    for i, axis in enumerate("xyz"):
        (line,) = ax.plot(t, est[:, i], lw=0.9, label=f"{axis}")
        ax.fill_between(
            t,
            est[:, i] - 3 * sig[:, i],
            est[:, i] + 3 * sig[:, i],
            color=line.get_color(),
            alpha=0.15,
            lw=0,
        )
    ax.set_xlabel("time (s); outages shaded; bands +-3 sigma")
    ax.set_ylabel(f"{title} ({unit}), {key}")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)


def fig_gyro_bias(result, path):
    """Gyro bias estimates (deg/h) with +-3 sigma."""
    _sensor_figure(result, path, 3, 3600.0 / DEG, "deg/h", "gyro bias")


def fig_accel_bias(result, path):
    """Accelerometer bias estimates (ug) with +-3 sigma."""
    _sensor_figure(result, path, 0, 1.0 / UG, "ug", "accel bias")


def fig_innovations(result, path):
    """Position innovations (m) per axis over time."""
    plt = _pyplot()
    ds = result.datasets
    t = ds["post/time"].data
    y = ds["post/innovation"].data
    fig, ax = plt.subplots(figsize=(10, 4.5), layout="constrained")
    _shade(ax, result)
    for i, axis in enumerate("NED"):
        ax.plot(t, y[:, i], ".", ms=1.5, label=axis)
    ax.set_xlabel("time (s); outages shaded")
    ax.set_ylabel("position innovation (m)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)


POST_FIGURES = {
    "run-ekf-heading-error.png": fig_errors,
    "run-ekf-gyro-bias.png": fig_gyro_bias,
    "run-ekf-misalignment.png": fig_accel_bias,
    "run-ekf-fb-corrections.png": fig_innovations,
    "run-ekf-trajectory.png": fig_trajectory,
}
"""A post run's figure for each of run-ekf's figure names (the names are fixed per
command: a post run draws its own figure under each)."""


def _tight_trajectory(result, path):
    """Tight runs: the corrected trajectory on a local map."""
    plt = _pyplot()
    lla = result.datasets["nav/lla"].data
    e, n = _local(lla, lla[0])
    fig, ax = plt.subplots(figsize=(7, 7), layout="constrained")
    ax.plot(e, n, lw=0.9)
    ax.set_aspect("equal")
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    ax.grid(alpha=0.3)
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)


def with_post_figures(tight):
    """run-ekf's figure table: each name draws the tight figure or the post one."""

    def pick(name):
        def draw(result, path):
            if "post" in result.attrs:
                return POST_FIGURES[name](result, path)
            return tight.get(name, _tight_trajectory)(result, path)

        draw.__doc__ = (POST_FIGURES[name].__doc__ or "").strip()
        return draw

    return {name: pick(name) for name in (*tight, *(k for k in POST_FIGURES if k not in tight))}

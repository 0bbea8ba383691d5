"""run-ekf figures: of a tight run (003 Figs. 8-12: heading error or correction, gyro
bias and misalignment states, FB corrections, the trajectory) and of a post-processing
run (``post:``, :mod:`inins.commands.run_ekf_post_figures`), each under its own name
in the figure table :data:`FIGURES`."""

import numpy as np

from inins.commands import run_ekf_post_figures
from inins.commands.figures import NotThisRun, Skipped, pyplot
from inins.core import error_model
from inins.core.units import ARCSEC, DEG

# --------------------------------------------------------------------------- tight


def _ekf_states(result, names, path, title, scale, unit):
    """Estimates with 1-sigma of sensor states, and their truth (dashed) where known."""
    ds = result.datasets
    states = result.attrs["ekf"]["states"]
    shown = [n for n in names if n in states]
    est_all = ds["states/estimate"].data
    if not np.any(est_all[:, [states.index(n) for n in shown]]):
        raise Skipped(f"{title}: every estimate is zero (the states never moved)")
    truth = ds["truth/states"].data if "truth/states" in ds else None
    plt = pyplot()
    time = ds["nav/time"].data
    fig, ax = plt.subplots(figsize=(9, 4.5), layout="constrained")
    for k, name in enumerate(shown):
        i = states.index(name)
        color = plt.cm.tab10(k % 10)
        est = est_all[:, i] / scale
        sig = ds["states/sigma"].data[:, i] / scale
        ax.plot(time, est, color=color, lw=1.0, label=name)
        ax.plot(time, est + sig, color=color, lw=0.5, ls=":")
        ax.plot(time, est - sig, color=color, lw=0.5, ls=":")
        if truth is not None and np.isfinite(truth[i]):
            ax.axhline(truth[i] / scale, color=color, lw=1.2, ls="--")
    ax.set_xlabel("time (s)")
    ax.set_ylabel(unit)
    what = "dashed: truth" if truth is not None else "no truth: a recording"
    ax.set_title(f"{title} estimates (dotted: 1-sigma; {what})")
    ax.legend(fontsize=7, ncol=3)
    ax.grid(alpha=0.3)
    _shade_turns(ax, result)
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)


TURN_RATE_DPS = 1.0
"""Heading rate (deg/s) above which an epoch is shaded as turning."""


def turn_windows(result):
    """``[(start, end)]`` (s) where the body forward axis turns faster than
    :data:`TURN_RATE_DPS` (from ``nav/forward_heading``; the flight or drive alike)."""
    ds = result.datasets
    if "nav/forward_heading" not in ds or len(ds["nav/time"].data) < 3:
        return []
    time = ds["nav/time"].data
    heading = np.unwrap(ds["nav/forward_heading"].data)
    rate = np.abs(np.gradient(heading, time)) / DEG
    turning = rate > TURN_RATE_DPS
    edges = np.flatnonzero(np.diff(np.concatenate([[0], turning.astype(int), [0]])))
    return [(float(time[a]), float(time[min(b, len(time) - 1)])) for a, b in edges.reshape(-1, 2)]


def _shade_turns(ax, result):
    for k, (a, b) in enumerate(turn_windows(result)):
        ax.axvspan(a, b, color="0.85", lw=0, zorder=0, label="turning" if k == 0 else None)


def run_ekf_heading(result, path):
    """run-ekf, 003 Figs. 8, 12: heading error against the truth with the filter's
    +-3-sigma, turns shaded; on a recording (no truth) the filter's heading correction
    (cumulative in FB, the phi_D estimate in FF) with its +-3-sigma, labelled so."""
    plt = pyplot()
    ds = result.datasets
    time = ds["nav/time"].data
    i = result.attrs["ekf"]["states"].index("phi_D")
    sigma3 = 3.0 * np.degrees(ds["states/sigma"].data[:, i])
    fig, ax = plt.subplots(figsize=(9, 4.5), layout="constrained")
    _shade_turns(ax, result)
    if "truth/heading_error" in ds:
        err = np.degrees(ds["truth/heading_error"].data)
        ax.plot(time, err, lw=1.0, color="tab:blue", label="heading error (output - truth)")
        ax.fill_between(time, -sigma3, sigma3, color="tab:orange", alpha=0.25, lw=0)
        ax.plot(time, sigma3, color="tab:orange", lw=0.6, label="+-3 sigma (filter)")
        ax.plot(time, -sigma3, color="tab:orange", lw=0.6)
        ax.set_ylabel("heading error (deg)")
        ax.set_title("heading error against the truth")
    else:
        fb = result.attrs["ekf"]["coupling"] == "fb"
        data = ds["states/cumulative"].data if fb else ds["states/estimate"].data
        corr = np.degrees(data[:, i])
        what = "cumulative fed-back correction" if fb else "phi_D estimate"
        ax.plot(time, corr, lw=1.0, color="tab:blue", label=f"heading correction ({what})")
        ax.fill_between(time, corr - sigma3, corr + sigma3, color="tab:orange", alpha=0.25, lw=0)
        ax.plot([], [], color="tab:orange", lw=4, alpha=0.4, label="+-3 sigma (filter)")
        ax.set_ylabel("heading correction (deg)")
        ax.set_title(
            "recording without truth: the filter's heading correction, not an error", fontsize=10
        )
    ax.set_xlabel("time (s)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)


def run_ekf_gyro_bias(result, path):
    """run-ekf, 003 Figs. 9, 10: gyro bias states with 1-sigma (deg/h)."""
    _ekf_states(result, ("bg_x", "bg_y", "bg_z"), path, "gyro bias", np.pi / 180 / 3600, "deg/h")


def run_ekf_misalignment(result, path):
    """run-ekf, 003 Fig. 11: gyro misalignment states with 1-sigma (arcsec)."""
    names = ("mg_xy", "mg_xz", "mg_yx", "mg_yz", "mg_zx", "mg_zy")
    if "mg_yz" not in result.attrs["ekf"]["states"]:
        raise Skipped("gyro misalignment: EKF1 has no misalignment states")
    _ekf_states(result, names, path, "gyro misalignment", ARCSEC, "arcsec")


def run_ekf_corrections(result, path):
    """run-ekf, 003 §3.3.2: cumulative FB corrections of the attitude (deg)."""
    ds = result.datasets
    states = result.attrs["ekf"]["states"]
    index = [states.index(name) for name in ("phi_N", "phi_E", "phi_D")]
    cumulative = ds["states/cumulative"].data[:, index]
    if not np.any(cumulative):
        raise Skipped(
            f"feedback corrections: none ({result.attrs['ekf']['coupling']} coupling "
            "feeds nothing back; all zero)"
        )
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(9, 4.5), layout="constrained")
    _shade_turns(ax, result)
    for k, name in enumerate(("phi_N", "phi_E", "phi_D")):
        ax.plot(ds["nav/time"].data, np.degrees(cumulative[:, k]), label=name)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("cumulative correction (deg)")
    ax.set_title("attitude corrections fed back to the navigation (FB)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)


def _tight_trajectory(result, path):
    """The corrected trajectory on a local map."""
    plt = pyplot()
    lla = result.datasets["nav/lla"].data
    d = error_model.position_error_ned(lla, np.broadcast_to(lla[0], lla.shape))
    fig, ax = plt.subplots(figsize=(7, 7), layout="constrained")
    ax.plot(d[:, 1], d[:, 0], lw=0.9)
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    ax.grid(alpha=0.3)
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)


def only_in(kind, draw):
    """``draw`` for runs of ``kind`` (``"post"`` or ``"tight"``); in the other kind of
    run it raises :class:`~inins.commands.figures.NotThisRun` (no file, no note)."""

    def figure(result, path):
        if ("post" in result.attrs) != (kind == "post"):
            raise NotThisRun(kind)
        return draw(result, path)

    figure.__doc__ = f"({kind} runs) " + (draw.__doc__ or "").strip()
    return figure


TIGHT_FIGURES = {
    "run-ekf-heading-error.png": run_ekf_heading,
    "run-ekf-gyro-bias.png": run_ekf_gyro_bias,
    "run-ekf-misalignment.png": run_ekf_misalignment,
    "run-ekf-fb-corrections.png": run_ekf_corrections,
    "run-ekf-trajectory.png": _tight_trajectory,
}
"""A tight (or simulated) run's figures by file name."""

FIGURES = {name: only_in("tight", f) for name, f in TIGHT_FIGURES.items()} | {
    name: only_in("post", f) for name, f in run_ekf_post_figures.FIGURES.items()
}
"""run-ekf's figures by file name: each drawn by the kind of run it belongs to."""

"""import-flight figures: the SPP track, satellites, PDOP and residuals of every epoch,
and the sky plot."""

import numpy as np

from inins.commands.figures import Skipped, pyplot
from inins.core import earth
from inins.core.satellites import LETTERS


def _track_ned(result):
    """SPP positions as north, east, down (m) from the reference position (or the first
    fix), the origin's name, and the fix mask."""
    ds = result.datasets
    if "spp/pos_e" not in ds:
        raise Skipped("no SPP solution (a solution-file import): no track to draw")
    pos = ds["spp/pos_e"].data
    fixed = np.isfinite(pos[:, 0])
    if not fixed.any():
        raise Skipped("no epoch has a fix: no track to draw")
    ref = np.asarray(result.attrs[""]["reference_pos_e"], float)
    origin = "the reference position" if np.all(np.isfinite(ref)) else "the first fix"
    centre = ref if np.all(np.isfinite(ref)) else pos[fixed][0]
    lla = earth.llh_from_ecef(centre)
    ned = (pos - centre) @ earth.mat_en(lla[0], lla[1])
    ref = ds["spp/reference_pos_e"].data if "spp/reference_pos_e" in ds else None
    ref_ned = None if ref is None else (ref - centre) @ earth.mat_en(lla[0], lla[1])
    return ned, origin, fixed, ref_ned


def import_flight_track(result, path):
    """import-flight: the SPP track (north / east from the reference or the first fix)
    coloured by time, and the height change; the scenario's reference trajectory (grey)
    where it gives one."""
    ned, origin, fixed, ref = _track_ned(result)
    plt = pyplot()
    time = result.datasets["spp/time"].data
    t = time - time[0]
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.5), layout="constrained")
    if ref is not None:
        left.plot(ref[:, 1], ref[:, 0], "-", color="0.45", lw=1.2, label="reference trajectory")
        right.plot(t, -ref[:, 2], "-", color="0.45", lw=1.2, label="reference trajectory")
        left.legend(fontsize=8, loc="best")
    dots = left.scatter(ned[fixed, 1], ned[fixed, 0], c=t[fixed], s=4, cmap="viridis")
    fig.colorbar(dots, ax=left, label="time from the first epoch (s)")
    left.set_xlabel("east (m)")
    left.set_ylabel("north (m)")
    left.set_aspect("equal", adjustable="datalim")
    left.set_title(f"SPP track, from {origin}", fontsize=9)
    left.grid(alpha=0.3)
    right.plot(t[fixed], -ned[fixed, 2], ".", ms=2)
    right.set_xlabel("time from the first epoch (s)")
    right.set_ylabel("up (m)")
    right.set_title(f"height from {origin}", fontsize=9)
    right.grid(alpha=0.3)
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)


def import_flight_residuals(result, path):
    """import-flight: satellites used, PDOP and the pseudorange residuals of every epoch
    (used rows; the excluded ones marked)."""
    ds = result.datasets
    if "spp/residual" not in ds or not np.isfinite(ds["spp/residual"].data).any():
        raise Skipped("no residual: no epoch has a fix")
    plt = pyplot()
    time = ds["spp/time"].data
    t = time - time[0]
    fig, axes = plt.subplots(3, 1, figsize=(9, 7.5), sharex=True, layout="constrained")
    axes[0].plot(t, ds["spp/satellites_used"].data, ".", ms=2)
    axes[0].set_ylabel("satellites used")
    axes[1].semilogy(t, ds["spp/pdop"].data, ".", ms=2)
    axes[1].set_ylabel("PDOP")
    row_t = t[ds["spp/row_epoch"].data]
    res = ds["spp/residual"].data
    used = ds["spp/row_used"].data.astype(bool)
    axes[2].plot(row_t[used], res[used], ".", ms=1.5, color="tab:blue", label="used")
    span = 1.5 * float(np.percentile(np.abs(res[used]), 99.9)) if used.any() else 100.0
    out = ~used & np.isfinite(res)
    near = out & (np.abs(res) <= span)
    if near.any():
        axes[2].plot(row_t[near], res[near], "x", ms=3, color="tab:red", label="not used")
    axes[2].set_ylim(-span, span)
    far = int(np.count_nonzero(out & ~near))
    if far:
        axes[2].set_title(f"{far} unused rows beyond +-{span:.3g} m not shown", fontsize=8)
    axes[2].set_ylabel("pseudorange residual (m)")
    axes[2].set_xlabel("time from the first epoch (s)")
    axes[2].legend(fontsize=8, loc="upper right")
    for ax in axes:
        ax.grid(alpha=0.3)
    axes[0].set_title("single-point positioning of every epoch", fontsize=9)
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)


def import_flight_sky(result, path):
    """import-flight: sky plot, every satellite's track seen from the fixes."""
    ds = result.datasets
    el = ds["spp/row_elevation"].data if "spp/row_elevation" in ds else np.zeros(0)
    ok = np.isfinite(el) & (el >= 0)
    if not ok.any():
        raise Skipped("no satellite above the horizon of a fix")
    plt = pyplot()
    az = ds["spp/row_azimuth"].data
    prn = ds["spp/row_prn"].data
    fig = plt.figure(figsize=(6.5, 6.5), layout="constrained")
    ax = fig.add_subplot(projection="polar")
    ax.set_theta_zero_location("N")
    ax.set_theta_direction(-1)
    for k, p in enumerate(np.unique(prn[ok])):
        rows = ok & (prn == p)
        ax.plot(az[rows], 90.0 - np.degrees(el[rows]), ".", ms=1.5, color=plt.cm.tab20(k % 20))
        last = np.flatnonzero(rows)[-1]
        name = f"{LETTERS[int(p) // 100]}{int(p) % 100:02d}"  # R01 for GLONASS slot 1 (101)
        ax.annotate(name, (az[last], 90.0 - np.degrees(el[last])), fontsize=7)
    ax.set_rlim(0, 90)
    ax.set_yticks([0, 30, 60, 90], ["90", "60", "30", "0 deg"])
    ax.set_title("sky plot (elevation, azimuth from the fix)", fontsize=9)
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)

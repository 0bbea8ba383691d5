"""PNG figures (matplotlib, the optional ``plot`` extra), drawn from a CommandResult.

A figure function is ``f(result, path)``, or ``f(result, path, data)`` where ``data``
is the run's results file (still under its temporary name) for the series streamed
there rather than kept in the result.

calibrate-bias: roll and pitch through the 000 Table 1 sequence with the epoch
windows of the formulas marked, like 000 Figs. 5-12, the 1-sigma scatter of each
epoch window, and the formula chosen. 000's roll R is the tilt about the body axis
that points north at the first position, its pitch P the tilt about the axis that
points east.

simulate-table: table angles, angular rate and specific force (block means).
align-ett: the specific force at the two ETT positions and the heading estimates
with 1-sigma against the truth. import-log: block-mean rates with the holds, the
Earth rate seen in each block, and the Allan deviation of each gyro axis.
"""

import numpy as np

from inins.core import earth
from inins.core.satellites import LETTERS
from inins.core.units import ARCSEC, DEG, DPH

FORMULAS = {
    "roll": ("eq. 38: (R1 + R3 - R2 - R4) / 2T", ("eq38",)),
    "pitch": (
        "eq. 44: (P1 + P3 - P0 - P2) / 2T,  eq. 45: (P1 + P3 - P2 - P4) / 2T",
        ("eq44", "eq45"),
    ),
}


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _epoch_figure(result, kind, path):
    plt = _pyplot()
    ds, axes = result.datasets, result.attrs["geometry"]
    axis = axes["north_axis" if kind == "roll" else "east_axis"]
    column = "xyz".index(axis)
    letter = "R" if kind == "roll" else "P"
    minutes = ds["nav/time"].data / 60.0
    tilt = ds["nav/tilt"].data[:, column] / ARCSEC
    fig, ax = plt.subplots(figsize=(9, 4.5), layout="constrained")
    ax.plot(minutes, tilt, lw=0.8, color="tab:blue", label=f"{kind} tilt")
    time = ds["nav/time"].data
    for k, ((start, end), value) in enumerate(
        zip(ds["epochs/window"].data, ds["epochs/tilt"].data[:, column] / ARCSEC, strict=True)
    ):
        ax.axvspan(
            start / 60.0,
            end / 60.0,
            color="tab:orange",
            alpha=0.35,
            lw=0,
            label="epoch windows" if k == 0 else None,
        )
        inside = (time >= start) & (time <= end)
        spread = float(np.std(tilt[inside])) if inside.sum() > 1 else 0.0
        ax.fill_between(
            [start / 60.0, end / 60.0],
            value - spread,
            value + spread,
            color="tab:red",
            alpha=0.3,
            lw=0,
            label="epoch mean +/- 1-sigma scatter" if k == 0 else None,
        )
        below = k in (1, 4)  # epochs 3 and 4 are close in time: put them on opposite sides
        ax.annotate(
            f'{letter}({k}) = {value:.2f}"',
            (0.5 * (start + end) / 60.0, value),
            textcoords="offset points",
            xytext=(0, -22 if below else 14),
            ha="center",
            fontsize=8,
            arrowprops={"arrowstyle": "-", "lw": 0.5},
        )
    text, names = FORMULAS[kind]
    values = ", ".join(
        f"beta_{axis} ({n}) = {_fmt(result.results.get(f'beta_{axis}_{n}_dph'))}" for n in names
    )
    ax.set_title(
        f"{kind} (tilt about body {axis})  {text}\n{values} deg/h\n{_chosen_text(result)}",
        fontsize=9,
    )
    ax.legend(loc="best", fontsize=8)
    ax.set_xlabel("time (min)")
    ax.set_ylabel(f"{kind} tilt (arcsec)")
    ax.margins(y=0.22)
    ax.grid(alpha=0.3)
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)


def _fmt(value):
    return "n/a" if value is None or not np.isfinite(value) else f"{value:.5f}"


def calibrate_bias_roll(result, path):
    """000 Figs. 6, 7, 10, 11: roll through the sequence, R(0)..R(4) marked."""
    _epoch_figure(result, "roll", path)


def calibrate_bias_pitch(result, path):
    """000 Figs. 5, 8, 9, 12: pitch through the sequence, P(0)..P(4) marked."""
    _epoch_figure(result, "pitch", path)


_OBS_PANELS = (  # (title, state groups): at most ~8 curves per axis
    ("position", ("position",)),
    ("velocity", ("velocity",)),
    ("attitude", ("attitude",)),
    ("biases (solid accel, dashed gyro)", ("accel_bias", "gyro_bias")),
    ("scale factors (solid accel, dashed gyro)", ("accel_scale", "gyro_scale")),
    ("accelerometer misalignment", ("accel_misalignment",)),
    ("gyro misalignment", ("gyro_misalignment",)),
    ("receiver clock", ("clock",)),
)
_MAX_SEGMENT_BANDS = 40


def observability_sigma(result, path):
    """observability: 1-sigma of each state over time relative to its prior, one panel
    per state group; alternate segments (or, with many segments, the turns) shaded; the
    unobservable combinations in the title."""
    if "covariance/sigma" not in result.datasets:
        return _note_figure(path, "no covariance analysis (covariance: false)")
    from inins.core.error_model import GROUPS

    plt = _pyplot()
    time = result.datasets["covariance/time"].data
    sigma = result.datasets["covariance/sigma"].data
    info = result.attrs["observability"]
    names = list(info["states"])
    panels = []
    for title, groups in _OBS_PANELS:
        members = [(n, g) for g in groups for n in GROUPS[g] if n in names]
        if members:
            panels.append((title, members, groups))
    ncols = 2 if len(panels) > 1 else 1
    nrows = -(-len(panels) // ncols)
    fig, axes = plt.subplots(
        nrows,
        ncols,
        figsize=(11, 2.6 * nrows + 1.2),
        sharex=True,
        squeeze=False,
        layout="constrained",
    )
    ends = np.asarray(result.datasets["observability/segment_end"].data, float)
    starts = np.concatenate([[0.0], ends[:-1]])
    if len(ends) <= _MAX_SEGMENT_BANDS:
        bands, band_text = list(zip(starts[1::2], ends[1::2], strict=True)), "alternate segments"
    else:
        bands, band_text = [tuple(t) for t in info.get("turns_s", [])], "turns"
    for ax, (title, members, groups) in zip(axes.flat, panels, strict=False):
        for lo, hi in bands:
            ax.axvspan(lo, hi, color="0.5", alpha=0.08, lw=0)
        count = {}
        for name, group in members:
            i = names.index(name)
            style = "--" if len(groups) > 1 and group == groups[1] else "-"
            k = count.setdefault(style, 0)
            count[style] += 1
            ax.semilogy(
                time,
                sigma[:, i] / sigma[0, i],
                style,
                lw=1.3,
                label=name,
                color=plt.cm.tab10(k % 10),
            )
        ax.set_title(title, fontsize=9)
        ax.set_ylabel("1-sigma / prior")
        ax.grid(alpha=0.3, which="both", lw=0.4)
        ax.legend(fontsize=7, ncol=3, loc="lower left")
    for k in range(len(panels), nrows * ncols):  # an empty cell: the one above shows the time
        axes.flat[k].axis("off")
        if k >= ncols:
            axes.flat[k - ncols].xaxis.set_tick_params(labelbottom=True)
            axes.flat[k - ncols].set_xlabel("time (s)")
    for ax in axes[-1]:
        ax.set_xlabel("time (s)")
    from inins.observability.analysis import PRACTICAL_RATIO

    combos = list(info.get("combinations", []))
    lines = (
        ["full rank (observable in principle)"] if not combos else ["unobservable:", *combos[:3]]
    )
    if len(combos) > 3:
        lines.append(f"and {len(combos) - 3} more (see the report)")
    poor = [n for i, n in enumerate(names) if sigma[-1, i] > PRACTICAL_RATIO * sigma[0, i]]
    if poor:
        more = f" and {len(poor) - 8} more" if len(poor) > 8 else ""
        lines.append(
            f"poorly observable (sigma above {PRACTICAL_RATIO:g} of the prior at the end): "
            + ", ".join(poor[:8])
            + more
        )
    fig.suptitle(
        f"covariance analysis, model {info['model']} (shaded: {band_text})\n" + "\n".join(lines),
        fontsize=9,
    )
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)


def observability_singular_values(result, path):
    """observability: singular values of the stacked matrix after each segment; the
    smallest eight as lines (they decide the rank), the others as one grey band, the
    rank tolerance dashed."""
    plt = _pyplot()
    sv = np.maximum(result.datasets["observability/singular_values"].data, 1e-300)
    info = result.attrs["observability"]
    fig, ax = plt.subplots(figsize=(8, 4.5), layout="constrained")
    segments = np.arange(1, sv.shape[0] + 1)
    style = {"marker": "o", "ms": 3} if len(segments) <= 40 else {}
    n = sv.shape[1]
    shown = min(n, 8)
    if n > shown:
        ax.fill_between(
            segments,
            sv[:, : n - shown].min(axis=1),
            sv[:, 0],
            color="0.8",
            lw=0,
            label=f"the {n - shown} largest",
        )
    for j, k in enumerate(range(n - shown, n)):
        ax.semilogy(
            segments, sv[:, k], lw=1.1, color=plt.cm.tab10(j % 10), label=f"s{k + 1}", **style
        )
    if "tolerance" in info:
        ax.axhline(info["tolerance"], color="k", lw=0.8, ls="--", label="rank tolerance")
    ax.set_yscale("log")
    ax.set_xlabel("segments stacked")
    ax.set_ylabel("singular value (scaled, SI)")
    ax.set_title(f"observability matrix, model {info['model']}: singular values per segment")
    ax.legend(fontsize=7, ncol=2)
    ax.grid(alpha=0.3, which="both", lw=0.4)
    fig.savefig(path, dpi=120, format="png")
    plt.close(fig)


def _note_figure(path, text):
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6, 2))
    ax.axis("off")
    ax.text(0.5, 0.5, text, ha="center", va="center")
    fig.savefig(path, dpi=100, format="png")
    plt.close(fig)


class Skipped(Exception):
    """A figure not drawn, with the reason (all zero, nothing to show): the run writes no
    file for it and says why in its report."""


def _ekf_states(result, names, path, title, scale, unit):
    """Estimates with 1-sigma of sensor states, and their truth (dashed) where known."""
    ds = result.datasets
    states = result.attrs["ekf"]["states"]
    shown = [n for n in names if n in states]
    est_all = ds["states/estimate"].data
    if not np.any(est_all[:, [states.index(n) for n in shown]]):
        raise Skipped(f"{title}: every estimate is zero (the states never moved)")
    truth = ds["truth/states"].data if "truth/states" in ds else None
    plt = _pyplot()
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


def _chosen_text(result):
    """``chosen: beta_x = ... +/- ... deg/h (eq44); beta_y ...`` or "no valid formula"."""
    parts = []
    for axis in "xyz":
        value = result.results.get(f"beta_{axis}_dph", "absent")
        if value == "absent":
            continue
        sigma = result.results.get(f"beta_{axis}_sigma_dph")
        if value is None or not np.isfinite(value):
            parts.append(f"beta_{axis}: no valid formula")
            continue
        formula = next(
            (
                n
                for n in ("eq38", "eq44", "eq45")
                if result.results.get(f"beta_{axis}_{n}_dph") == value
            ),
            "?",
        )
        parts.append(f"beta_{axis} = {value:.5f} +/- {_fmt(sigma)} deg/h ({formula})")
    return "chosen: " + ("; ".join(parts) or "no valid formula")


def _block_means(data_path, points=2000):
    """Block means of the IMU rates of a table-data file: time (s), rate (rad/s, k x 3),
    specific force (m/s^2, k x 3), with about ``points`` blocks."""
    from inins.io.tabledata import read_table_data

    record = read_table_data(data_path)
    n = record.n_samples
    block = max(1, n // points)
    times, rates, forces = [], [], []
    for k0, dtheta, dv in record.imu_chunks(0, n - n % block or n):
        m = dtheta.shape[0] // block * block
        if m == 0:
            continue
        times.append(record.t0 + (k0 + block * (np.arange(m // block) + 0.5)) * record.dt)
        rates.append(dtheta[:m].reshape(-1, block, 3).mean(axis=1) / record.dt)
        forces.append(dv[:m].reshape(-1, block, 3).mean(axis=1) / record.dt)
    return record, np.concatenate(times), np.concatenate(rates), np.concatenate(forces)


def simulate_table_motion(result, path, data):
    """Table angles, angular rate and specific force of the simulated IMU."""
    plt = _pyplot()
    record, t, rate, force = _block_means(data)
    fig, axes = plt.subplots(3, 1, figsize=(9, 8), sharex=True, layout="constrained")
    for g, name in enumerate(record.gimbals):
        axes[0].plot(record.encoder_time / 60.0, record.encoder[:, g] / DEG, label=name)
    axes[0].set_ylabel("table angle (deg)")
    for i, axis in enumerate("xyz"):
        axes[1].plot(t / 60.0, rate[:, i] / DEG, lw=0.8, label=f"omega_{axis}")
        axes[2].plot(t / 60.0, force[:, i], lw=0.8, label=f"f_{axis}")
    axes[1].set_ylabel("angular rate, b (deg/s)")
    axes[2].set_ylabel("specific force, b (m/s^2)")
    axes[2].set_xlabel("time (min)")
    for ax in axes:
        ax.grid(alpha=0.3)
        ax.legend(loc="upper right", fontsize=8)
    axes[0].set_title(f"simulate-table: {result.results.get('samples')} samples", fontsize=9)
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)


def run_ekf_heading(result, path):
    """run-ekf, 003 Figs. 8, 12: heading error against the truth with the filter's
    +-3-sigma, turns shaded; on a recording (no truth) the filter's heading correction
    (cumulative in FB, the phi_D estimate in FF) with its +-3-sigma, labelled so."""
    plt = _pyplot()
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


def align_ett_geometry(result, path):
    """The specific force at the vertical and level positions, and the ETT and
    gyrocompass headings with 1-sigma (and the truth where known)."""
    plt = _pyplot()
    r = result.results
    f_b = result.datasets["ett/f_b"].data
    fig, (left, right) = plt.subplots(1, 2, figsize=(10, 4.2), layout="constrained")
    x = np.arange(3)
    for row, (name, shift) in enumerate((("vertical", -0.18), ("level", 0.18))):
        left.bar(x + shift, f_b[row], width=0.35, label=f"{name} position")
    left.set_xticks(x, ["f_x", "f_y", "f_z"])
    left.set_ylabel("mean specific force, b (m/s^2)")
    left.set_title("ETT positions (000 §3.1)", fontsize=9)
    left.legend(fontsize=8)
    left.grid(alpha=0.3, axis="y")
    names = [
        ("ETT", "heading_deg", "heading_sigma_deg"),
        ("gyrocompass", "gyrocompass_heading_deg", "gyrocompass_heading_sigma_deg"),
    ]
    for k, (label, key, sigma) in enumerate(names):
        right.errorbar(k, r[key], yerr=r[sigma], fmt="o", capsize=6, label=f"{label} +/- 1-sigma")
    truth = result.truth.get("heading_deg")
    if truth is not None:
        right.axhline(truth, color="k", lw=0.8, ls="--", label="truth")
    right.set_xticks([0, 1], ["ETT", "gyrocompass"])
    right.set_xlim(-0.6, 1.6)
    right.set_ylabel("IMU heading at the level position (deg)")
    right.set_title("heading estimates", fontsize=9)
    right.legend(fontsize=8)
    right.grid(alpha=0.3)
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
    plt = _pyplot()
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


def allan_deviation(rate, dt, points=20):
    """Non-overlapping Allan deviation of a rate series (IEEE Std 952 eq. C.1).

    Parameters
    ----------
    rate : ndarray, shape (n,)
        Rate samples (any unit).
    dt : float
        Sample interval (s).

    Returns
    -------
    tau : ndarray, shape (m,)
        Cluster times (s), log-spaced, at least 3 clusters each.
    adev : ndarray, shape (m,)
        sigma(tau) = sqrt(mean((ybar_{k+1} - ybar_k)^2) / 2), same unit as ``rate``.
    """
    n = rate.shape[0]
    sizes = np.unique(np.logspace(0, np.log10(max(1, n // 3)), points).astype(int))
    out = []
    for m in sizes:
        means = rate[: n // m * m].reshape(-1, m).mean(axis=1)
        out.append(np.sqrt(0.5 * np.mean(np.diff(means) ** 2)) if means.size > 2 else np.nan)
    return sizes * dt, np.array(out)


def import_log_checks(result, path, data):
    """Block-mean rates with the holds shaded, the Earth rate of each block against the
    WGS84 rate, and the Allan deviation of each gyro axis."""
    from inins.io.tabledata import read_table_data

    plt = _pyplot()
    ds = result.datasets
    t, omega = ds["check/time"].data, ds["check/omega_b"].data
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.2), layout="constrained")
    for i, axis in enumerate("xyz"):
        axes[0].plot(t, omega[:, i] / DPH, lw=0.8, label=f"omega_{axis}")
    kinds = ds["steps/kind"].data
    for k, (a, b) in enumerate(
        zip(ds["steps/start_time"].data, ds["steps/end_time"].data, strict=True)
    ):
        if (kinds[k].decode() if isinstance(kinds[k], bytes) else str(kinds[k])) == "hold":
            axes[0].axvspan(
                a, b, color="tab:green", alpha=0.12, lw=0, label="holds" if k == 0 else None
            )
    axes[0].set(xlabel="time (s)", ylabel="block-mean rate, b (deg/h)", title="per-block means")
    axes[1].plot(t, np.linalg.norm(omega, axis=1) / DPH, lw=0.8, label="|omega| per block")
    axes[1].axhline(earth.RATE / DPH, color="k", ls="--", lw=0.8, label="Earth rate (WGS84)")
    axes[1].set(xlabel="time (s)", ylabel="deg/h", title="Earth rate seen at rest")
    record = read_table_data(data)
    k1 = min(record.n_samples, 1 << 21)
    dtheta, _ = record.imu(0, k1)
    for i, axis in enumerate("xyz"):
        tau, adev = allan_deviation(dtheta[:, i] / record.dt / DPH, record.dt)
        axes[2].loglog(tau, adev, label=f"gyro {axis}")
    axes[2].set(xlabel="tau (s)", ylabel="Allan deviation (deg/h)", title="Allan deviation")
    for ax in axes:
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=8)
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)


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
    return ned, origin, fixed


def import_flight_track(result, path):
    """import-flight: the SPP track (north / east from the reference or the first fix)
    coloured by time, and the height change."""
    ned, origin, fixed = _track_ned(result)
    plt = _pyplot()
    time = result.datasets["spp/time"].data
    t = time - time[0]
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.5), layout="constrained")
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
    plt = _pyplot()
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
    plt = _pyplot()
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

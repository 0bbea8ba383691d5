"""PNG figures (matplotlib, the optional ``plot`` extra), drawn from a CommandResult.

calibrate-bias: roll and pitch through the 000 Table 1 sequence with the epoch
windows of the formulas marked, like 000 Figs. 5-12. 000's roll R is the tilt
about the body axis that points north at the first position, its pitch P the
tilt about the axis that points east.
"""

import numpy as np

from inins.core.units import ARCSEC

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
    ax.plot(minutes, tilt, lw=0.8, color="tab:blue")
    for k, ((start, end), value) in enumerate(
        zip(ds["epochs/window"].data, ds["epochs/tilt"].data[:, column] / ARCSEC, strict=True)
    ):
        ax.axvspan(start / 60.0, end / 60.0, color="tab:orange", alpha=0.35, lw=0)
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
    ax.set_title(f"{kind} (tilt about body {axis})  {text}\n{values} deg/h", fontsize=9)
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


def observability_sigma(result, path):
    """observability: 1-sigma of each state over time, relative to its prior."""
    if "covariance/sigma" not in result.datasets:
        return _note_figure(path, "no covariance analysis (covariance: false)")
    plt = _pyplot()
    time = result.datasets["covariance/time"].data
    sigma = result.datasets["covariance/sigma"].data
    names = result.attrs["observability"]["states"]
    fig, ax = plt.subplots(figsize=(9, 5), layout="constrained")
    for i, name in enumerate(names):
        ax.semilogy(time, sigma[:, i] / sigma[0, i], label=name, lw=1.2, color=plt.cm.tab20(i % 20))
    for t in result.datasets["observability/segment_end"].data[:-1]:
        ax.axvline(t, color="0.7", lw=0.8, ls=":")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("1-sigma / prior")
    ax.set_title(f"covariance analysis, model {result.attrs['observability']['model']}")
    ax.legend(ncol=4, fontsize=7)
    fig.savefig(path, dpi=120, format="png")
    plt.close(fig)


def observability_singular_values(result, path):
    """observability: singular values of the stacked matrix after each segment."""
    plt = _pyplot()
    sv = result.datasets["observability/singular_values"].data
    fig, ax = plt.subplots(figsize=(7, 4.5), layout="constrained")
    segments = np.arange(1, sv.shape[0] + 1)
    for k in range(sv.shape[1]):
        ax.semilogy(segments, np.maximum(sv[:, k], 1e-300), "o-", ms=3, lw=0.8)
    ax.set_xlabel("segments stacked")
    ax.set_ylabel("singular value (scaled, SI)")
    ax.set_title("observability matrix: singular values per segment")
    fig.savefig(path, dpi=120, format="png")
    plt.close(fig)


def _note_figure(path, text):
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6, 2))
    ax.axis("off")
    ax.text(0.5, 0.5, text, ha="center", va="center")
    fig.savefig(path, dpi=100, format="png")
    plt.close(fig)


def _ekf_states(result, names, path, title, scale, unit):
    plt = _pyplot()
    ds = result.datasets
    states = result.attrs["ekf"]["states"]
    time = ds["nav/time"].data
    fig, ax = plt.subplots(figsize=(9, 4.5), layout="constrained")
    for k, name in enumerate(n for n in names if n in states):
        i = states.index(name)
        color = plt.cm.tab10(k % 10)
        est = ds["states/estimate"].data[:, i] / scale
        sig = ds["states/sigma"].data[:, i] / scale
        ax.plot(time, est, color=color, lw=1.0, label=name)
        ax.plot(time, est + sig, color=color, lw=0.5, ls=":")
        ax.plot(time, est - sig, color=color, lw=0.5, ls=":")
    ax.set_xlabel("time (s)")
    ax.set_ylabel(unit)
    ax.set_title(title + " (dotted: 1-sigma)")
    ax.legend(fontsize=7, ncol=3)
    ax.grid(alpha=0.3)
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)


def run_ekf_heading(result, path):
    """run-ekf, 003 Figs. 8, 12: heading error against truth (or the estimated phi_D)."""
    plt = _pyplot()
    ds = result.datasets
    time = ds["nav/time"].data
    fig, ax = plt.subplots(figsize=(9, 4.5), layout="constrained")
    if "truth/heading_error" in ds:
        ax.plot(time, np.degrees(ds["truth/heading_error"].data), lw=1.0, label="output - truth")
    i = result.attrs["ekf"]["states"].index("phi_D")
    ax.plot(time, np.degrees(ds["states/estimate"].data[:, i]), lw=0.8, label="phi_D estimate")
    ax.set_xlabel("time (s)")
    ax.set_ylabel("heading error (deg)")
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
        return _note_figure(path, "EKF1: no misalignment states")
    _ekf_states(result, names, path, "gyro misalignment", ARCSEC, "arcsec")


def run_ekf_corrections(result, path):
    """run-ekf, 003 §3.3.2: cumulative FB corrections of the attitude (deg)."""
    plt = _pyplot()
    ds = result.datasets
    states = result.attrs["ekf"]["states"]
    fig, ax = plt.subplots(figsize=(9, 4.5), layout="constrained")
    for name in ("phi_N", "phi_E", "phi_D"):
        i = states.index(name)
        ax.plot(ds["nav/time"].data, np.degrees(ds["states/cumulative"].data[:, i]), label=name)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("cumulative correction (deg)")
    ax.set_title(f"feedback corrections ({result.attrs['ekf']['coupling']}; zero in ff)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)

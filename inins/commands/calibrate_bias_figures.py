"""calibrate-bias figures: roll and pitch through the 000 Table 1 sequence with the epoch
windows of the formulas marked, like 000 Figs. 5-12, the 1-sigma scatter of each epoch
window, and the formula chosen. 000's roll R is the tilt about the body axis that
points north at the first position, its pitch P the tilt about the axis that points
east."""

import numpy as np

from inins.commands.figures import pyplot
from inins.core.units import ARCSEC

FORMULAS = {
    "roll": ("eq. 38: (R1 + R3 - R2 - R4) / 2T", ("eq38",)),
    "pitch": (
        "eq. 44: (P1 + P3 - P0 - P2) / 2T,  eq. 45: (P1 + P3 - P2 - P4) / 2T",
        ("eq44", "eq45"),
    ),
}


def _epoch_figure(result, kind, path):
    plt = pyplot()
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

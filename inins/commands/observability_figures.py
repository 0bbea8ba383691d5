"""observability figures: the covariance analysis (1-sigma over time relative to the
prior, per state group) and the singular values of the stacked observability matrix."""

import numpy as np

from inins.commands.figures import note_figure, pyplot

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
        return note_figure(path, "no covariance analysis (covariance: false)")
    from inins.core.error_model import GROUPS

    plt = pyplot()
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
    plt = pyplot()
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

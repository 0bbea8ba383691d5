"""``inins sweep --plot``: a result against one or two swept keys (matplotlib, the
optional ``plot`` extra).

One key: the mean over the points at each value (other keys and seeds pooled)
with a ±1 sample-std bar. Two keys: a colour map of the mean over the grid.
"""

import numpy as np

from inins.exceptions import InputError


def check_plot_request(plan, results, against) -> tuple:
    """The keys to plot against (default: the first one or two swept keys); bad input
    if a key is not swept, more than two are given, or matplotlib is missing."""
    keys = tuple(against) or plan.axis_keys[:2]
    if not keys:
        raise InputError(
            "--plot needs a swept key to plot against; this sweep has none", key="--plot"
        )
    if len(keys) > 2:
        raise InputError("--against takes one or two keys", key="--against")
    for key in keys:
        if key not in plan.axis_keys:
            raise InputError(
                f"{key!r} is not a swept key (swept: {', '.join(plan.axis_keys)})", key="--against"
            )
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        raise InputError(
            "--plot needs matplotlib, which is not installed: pip install 'inins[plot]'",
            key="--plot",
        ) from None
    return keys


def _levels(values) -> tuple[list, list]:
    labels = [v if isinstance(v, int | float) else str(v) for v in values]
    levels = list(dict.fromkeys(labels))
    numeric = all(isinstance(v, int | float) and not isinstance(v, bool) for v in levels)
    return (sorted(levels) if numeric else levels), labels


def plot_result(table, result: str, keys: tuple, path) -> None:
    """Draw ``result`` of ``table`` against ``keys`` (one or two) into PNG ``path``."""
    if result not in table.result_names:
        raise InputError(
            f"unknown result {result!r} (results: {', '.join(table.result_names)})", key="--plot"
        )
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    y = table.result(result)
    fig, ax = plt.subplots(figsize=(7, 4.5), layout="constrained")
    if len(keys) == 1:
        levels, labels = _levels(table.axis(keys[0]))
        groups = [y[[lab == lev for lab in labels]] for lev in levels]
        mean = [np.nanmean(g) if np.isfinite(g).any() else np.nan for g in groups]
        std = [np.nanstd(g, ddof=1) if np.isfinite(g).sum() > 1 else 0.0 for g in groups]
        x = levels if all(isinstance(v, int | float) for v in levels) else range(len(levels))
        ax.errorbar(x, mean, yerr=std, marker="o", capsize=3)
        if x is not levels:
            ax.set_xticks(list(x), [str(v) for v in levels])
        ax.set_xlabel(keys[0])
        ax.set_ylabel(f"{result} (mean ± 1 std)")
    else:
        lx, labx = _levels(table.axis(keys[0]))
        ly, laby = _levels(table.axis(keys[1]))
        grid = np.full((len(ly), len(lx)), np.nan)
        for i, vy in enumerate(ly):
            for j, vx in enumerate(lx):
                sel = y[[a == vx and b == vy for a, b in zip(labx, laby, strict=True)]]
                if np.isfinite(sel).any():
                    grid[i, j] = np.nanmean(sel)
        image = ax.imshow(grid, origin="lower", aspect="auto", cmap="viridis")
        ax.set_xticks(range(len(lx)), [f"{v:g}" if isinstance(v, float) else str(v) for v in lx])
        ax.set_yticks(range(len(ly)), [f"{v:g}" if isinstance(v, float) else str(v) for v in ly])
        ax.set_xlabel(keys[0])
        ax.set_ylabel(keys[1])
        fig.colorbar(image, ax=ax, label=f"{result} (mean)")
    ax.set_title(f"{result}: {len(table.records)} points")
    fig.savefig(path, dpi=110)
    plt.close(fig)

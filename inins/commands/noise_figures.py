"""Figure of ``inins noise``: log-log Allan deviation per axis with its confidence band,
the fitted model and each fitted term as its asymptote (slopes -1, -1/2, 0, +1/2, +1)
with its value annotated."""

import numpy as np

from inins.calibration import allan
from inins.commands.noise_report import DISPLAY, LAB
from inins.core.units import DPH, UG

COLORS = ("tab:purple", "tab:blue", "tab:green", "tab:orange", "tab:red")


def deviation_figure(result, path):
    """Six panels (gyro x y z, accel x y z) into ``path`` (PNG)."""
    from inins.commands.figures import _pyplot

    plt = _pyplot()
    ds = result.datasets
    tau = ds["adev/tau"].data
    terms = ds["fit/terms"].data
    fig, axes = plt.subplots(2, 3, figsize=(15, 8.5), layout="constrained")
    conf = result.attrs["noise"]["band_confidence"]
    for s, sensor in enumerate(("gyro", "accel")):
        unit, factor = ("deg/h", DPH) if sensor == "gyro" else ("ug", UG)
        dev = ds[f"adev/{sensor}"].data / factor
        lo = ds[f"adev/{sensor}_lo"].data / factor
        hi = ds[f"adev/{sensor}_hi"].data / factor
        model = ds[f"adev/{sensor}_model"].data / factor
        for a in range(3):
            ax = axes[s, a]
            ax.fill_between(
                tau, lo[:, a], hi[:, a], color="0.7", alpha=0.6, lw=0, label=f"{conf:g} band"
            )
            ax.loglog(tau, dev[:, a], "k.-", lw=1.0, ms=4, label="overlapping ADEV")
            ok = np.isfinite(model[:, a])
            ax.loglog(tau[ok], model[ok, a], color="0.35", lw=1.6, ls=":", label="fitted model")
            values = terms[3 * s + a]
            basis = allan.basis(tau)
            floor = np.nanmin(dev[:, a]) / 30.0
            for k, name in enumerate(allan.TERMS):
                v = values[k]
                if not v > 0:
                    continue
                line = np.sqrt(basis[:, k]) * v / factor
                show = line >= floor
                lab_unit, lab_factor, _ = LAB[sensor][name]
                text = f"{name.replace('_', ' ')} {v / lab_factor:.3g} {DISPLAY[lab_unit]}"
                if name == "bias_instability":
                    text += " (flat = 0.664 B)"
                ax.loglog(
                    tau[show],
                    line[show],
                    "--",
                    color=COLORS[k],
                    lw=1.1,
                    label=f"slope {_slope(k)}: {text}",
                )
            ax.set_ylim(floor, np.nanmax(hi[:, a]) * 2.0)
            ax.set(
                xlabel="tau (s)",
                ylabel=f"Allan deviation ({unit})",
                title=f"{sensor} {'xyz'[a]}",
            )
            ax.grid(True, which="both", lw=0.3, alpha=0.5)
            ax.legend(fontsize=6.5, loc="best")
    fig.suptitle("inins noise: Allan deviation, fitted IEEE 952 terms as asymptotes")
    fig.savefig(path, dpi=110, format="png")
    plt.close(fig)


def _slope(k):
    s = allan.SLOPES[k]
    return {-1.0: "-1", -0.5: "-1/2", 0.0: "0", 0.5: "+1/2", 1.0: "+1"}.get(s, f"{s:g}")

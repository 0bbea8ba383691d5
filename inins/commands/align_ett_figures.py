"""align-ett figure: the specific force at the two ETT positions and the heading
estimates with 1-sigma against the truth."""

import numpy as np

from inins.commands.figures import pyplot


def align_ett_geometry(result, path):
    """The specific force at the vertical and level positions, and the ETT and
    gyrocompass headings with 1-sigma (and the truth where known)."""
    plt = pyplot()
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

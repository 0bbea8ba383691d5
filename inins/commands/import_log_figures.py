"""import-log figure: block-mean rates with the holds, the Earth rate seen in each block,
and the Allan deviation of each gyro axis."""

import numpy as np

from inins.commands.figures import pyplot
from inins.core import earth
from inins.core.units import DPH


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

    plt = pyplot()
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

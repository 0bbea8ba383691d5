"""simulate-table figure: table angles, angular rate and specific force (block means)."""

import numpy as np

from inins.commands.figures import pyplot
from inins.core.units import DEG


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
    plt = pyplot()
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

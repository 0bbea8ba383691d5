"""Epoch streams for :func:`inins.ekf.filter.run_filter`: a simulated flight through the
GNSS layer's receiver simulation, or a recording; and the initial attitude of a
recording (levelling, velocity-heading initialisation).

Both streams go through the same path from the GNSS layer to the filter
(:func:`filter_epochs`): :func:`inins.gnss.measurements.attach_satellites` gives the
satellite states at transmit time (transmit-time ECEF frame); each epoch's SPP fix
(:func:`inins.gnss.spp.solve`, the last fix carried over epochs without one) gives
the travel time that rotates them into the receive-time frame
(:func:`inins.gnss.propagation.sagnac_rotate`; 10 m of position error moves a
satellite by < 0.1 mm) and the Saastamoinen delay. The simulated stream yields
blocks of epochs so that memory stays flat in flight length (the 200 Hz increments
exist one epoch at a time).
"""

import math
from dataclasses import dataclass

import numpy as np

from inins.core import earth, rotation, strapdown
from inins.core.satellites import LETTERS
from inins.ekf.config import EpochInput, TruthEpoch
from inins.ekf.flight import imu_stream
from inins.ekf.measurements import GnssEpoch
from inins.exceptions import InputError
from inins.gnss import measurements, propagation, simulate, spp
from inins.gnss.orbit import C

BLOCK_EPOCHS = 300
"""Epochs simulated together (GNSS rows vectorised over a block)."""


def _fill_fixes(pos, fallback):
    """SPP positions (n, 3) with NaN rows replaced by the last fix (or ``fallback``)."""
    out = np.array(pos, dtype=float)
    last = np.asarray(fallback, dtype=float)
    for k in range(len(out)):  # per epoch, not per sample
        if np.isfinite(out[k, 0]):
            last = out[k]
        else:
            out[k] = last
    return out


def filter_epochs(
    epochs,
    times,
    arrival,
    sigma_pr,
    sigma_rr,
    mask,
    fallback_pos,
    klobuchar=None,
    sigma_scale=None,
):
    """:class:`~inins.ekf.measurements.GnssEpoch` per epoch of a :class:`GnssEpochs`.

    Parameters
    ----------
    epochs : inins.gnss.measurements.GnssEpochs
    times, arrival : ndarray, shape (n,)
        1PPS time and data arrival of each epoch on the IMU time axis (s).
    sigma_pr, sigma_rr : float
        Measurement 1-sigma the filter uses (m, m/s).
    mask : float
        Elevation mask (rad).
    fallback_pos : ndarray, shape (3,)
        ECEF position (m) used before the first SPP fix.
    klobuchar : tuple of two (4,) arrays, optional
    sigma_scale : ndarray, shape (6,), optional
        Factor on ``sigma_pr`` per system index (GLONASS's inter-frequency biases: a
        larger sigma); default 1.

    Returns
    -------
    list of GnssEpoch, and the last position used (for the next block).
    """
    obs = epochs.obs
    fix = spp.solve(epochs, spp.SppOptions(mask_rad=mask, klobuchar=klobuchar))
    approx = _fill_fixes(fix.pos, fallback_pos)
    rx = approx[obs.epoch]
    rng, _, _, _ = propagation.geometry(epochs.sat_pos, epochs.sat_vel, rx)
    pos = propagation.sagnac_rotate(epochs.sat_pos, rng / C)
    vel = propagation.sagnac_rotate(epochs.sat_vel, rng / C)
    pred = measurements.predict(epochs, rx, 0.0, 0.0, 0.0, klobuchar=klobuchar)
    keep = np.flatnonzero((pred.elevation >= mask) & np.isfinite(obs.range_rate))
    bounds = np.searchsorted(keep, obs.start)  # epoch k: kept rows bounds[k]:bounds[k + 1]
    row_sigma = np.full(keep.size, float(sigma_pr))
    if sigma_scale is not None:
        row_sigma = row_sigma * np.asarray(sigma_scale, float)[obs.prn[keep] // 100]
    columns = (
        obs.prn[keep],
        pos[keep],
        vel[keep],
        epochs.sat_clock[keep],
        epochs.sat_drift[keep],
        obs.pseudorange[keep],
        obs.range_rate[keep],
        row_sigma,
        np.full(keep.size, float(sigma_rr)),
        pred.delay[keep],
    )
    # one check of the whole block (finite, sigmas > 0; shapes hold by construction);
    # a block that fails goes through GnssEpoch's own per-epoch checks and messages
    checked = all(np.isfinite(c).all() for c in columns[1:])
    checked = checked and np.all(row_sigma > 0.0) and sigma_rr > 0.0
    make = GnssEpoch.unchecked if checked else GnssEpoch
    for column in columns:
        column.flags.writeable = False  # and so every epoch's slice of it
    out = []
    for k in range(obs.n_epochs):
        a, b = bounds[k], bounds[k + 1]
        out.append(
            make(
                float(times[k]),
                *(c[a:b] for c in columns[:9]),
                delay=columns[9][a:b],
                arrival=float(arrival[k]),
            )
        )
    return out, approx[-1] if len(approx) else fallback_pos


@dataclass(frozen=True)
class Receiver:
    """Simulated receiver (SI): antenna lever arm (3,) m in body axes, mask (rad),
    white noise 1-sigma (m, m/s), TCXO Allan ``h0`` (s) and ``h_2`` (1/s), initial
    clock bias (m) and drift (m/s), data latency (s), the sigmas the filter uses, and
    ``system_bias``: (system index, m) pairs, the inter-system bias the receiver adds
    to that system's pseudoranges (constant); ``filter_sigma_scale`` the filter's factor
    on its pseudorange sigma per system index (None: 1); ``glonass_ifb`` the GLONASS
    inter-frequency bias, m per frequency channel."""

    lever_arm: tuple
    mask: float
    sigma_pr: float
    sigma_rr: float
    h0: float
    h_2: float
    clock_bias: float
    clock_drift: float
    latency: float
    filter_sigma_pr: float
    filter_sigma_rr: float
    system_bias: tuple = ()
    filter_sigma_scale: tuple | None = None
    glonass_ifb: float = 0.0


def simulated_epochs(truth, base, errors, dt, duration, eph, week, sow0, rx, seed, *, nodes=3):
    """EpochInput per second from t = 1 s to ``duration`` (generator, memory flat).

    Parameters
    ----------
    truth, base : Trajectory
        The dithered IMU trajectory and the airframe (antenna) one.
    errors : inins.core.imu.SensorErrors
    dt, duration : float
        IMU interval and flight length (s).
    eph : inins.gnss.ephemeris.Ephemeris
    week, sow0 : int, float
        GPS time of IMU t = 0.
    rx : Receiver
    seed : int
    nodes : int
        Gauss-Legendre nodes per IMU sample.

    Yields
    ------
    EpochInput (with truth)
    """
    seeds = np.random.SeedSequence(seed).spawn(3)
    rng_imu, rng_gnss, rng_clock = (np.random.default_rng(s) for s in seeds)
    count = math.floor(duration + 1e-9)
    pps = np.arange(1, count + 1, dtype=float)
    clock, drift = simulate.clock_random_walk(
        np.concatenate([[0.0], pps]),
        rx.h0,
        rx.h_2,
        rng_clock,
        bias0=rx.clock_bias,
        drift0=rx.clock_drift,
    )
    clock, drift = clock[1:], drift[1:]
    lat_samples = round(rx.latency / dt)
    edges = np.concatenate([[0], np.round(pps / dt).astype(np.int64) + lat_samples])
    edges = np.minimum(edges, round(duration / dt))
    chunks = imu_stream(truth, errors, dt, edges, rng_imu, nodes=nodes, ahead=True)
    options = simulate.SimulationOptions(
        mask_rad=rx.mask,
        sigma_pr_m=rx.sigma_pr,
        sigma_rate_mps=rx.sigma_rr,
        troposphere=True,
        system_bias_m=tuple(rx.system_bias),
        glonass_ifb_m=rx.glonass_ifb,
    )
    true_bias = None
    if rx.system_bias:
        true_bias = np.zeros(len(LETTERS))
        for system, value in rx.system_bias:
            true_bias[system] = value
    _, _, lla0 = base.state([0.0])
    last = earth.ecef_from_llh(*lla0[0])
    for lo in range(0, count, BLOCK_EPOCHS):
        sel = slice(lo, min(lo + BLOCK_EPOCHS, count))
        t = pps[sel]
        pos_e, vel_e = simulate.antenna_from_trajectory(base, t, rx.lever_arm)
        obs, _ = simulate.simulate(
            eph, week, sow0 + t, pos_e, vel_e, clock[sel], drift[sel], rng_gnss, options
        )
        gnss = _attach(obs, eph)
        if gnss is None:
            gnss_list = [_empty_epoch(tk, tk + rx.latency) for tk in t]
        else:
            gnss_list, last = filter_epochs(
                gnss,
                t,
                t + rx.latency,
                rx.filter_sigma_pr,
                rx.filter_sigma_rr,
                rx.mask,
                last,
                sigma_scale=rx.filter_sigma_scale,
            )
        mat, vel, lla = truth.state(t)
        late = truth.state(t + rx.latency)
        for j, epoch in enumerate(gnss_list):
            k = lo + j
            dtheta, dv = next(chunks)
            yield EpochInput(
                dtheta,
                dv,
                round(t[j] / dt) - int(edges[k]),
                epoch,
                TruthEpoch(
                    mat[j],
                    vel[j],
                    lla[j],
                    clock[k],
                    drift[k],
                    at_arrival=(late[0][j], late[1][j], late[2][j]),
                    system_bias=true_bias,
                ),
            )


def _attach(obs, eph):
    if obs.prn.size == 0:
        return None
    return measurements.attach_satellites(obs, eph)


def _empty_epoch(time, arrival):
    z = np.zeros(0)
    return GnssEpoch(time, z, z.reshape(0, 3), z.reshape(0, 3), z, z, z, z, z, z, arrival=arrival)


def check_imu_time(time, nominal_dt, source, key="imu/time"):
    """Reject IMU time tags that run backwards or skip samples.

    A step of more than 2.5 nominal intervals is a gap (the PSINS recording has a few
    2 ms / 8 ms pairs around its 5 ms, which are jitter, not lost samples).
    """
    step = np.diff(np.asarray(time, dtype=float))
    back = np.flatnonzero(step <= 0.0)
    if back.size:
        i = int(back[0])
        raise InputError(
            f"IMU time runs backwards at sample {i + 1} ({time[i]:.6f} -> {time[i + 1]:.6f} s)",
            source=source,
            key=key,
        )
    gap = np.flatnonzero(step > 2.5 * nominal_dt)
    if gap.size:
        i = int(gap[0])
        raise InputError(
            f"IMU gap of {step[i]:.4g} s at t = {time[i]:.6f} s ({gap.size} gaps; nominal "
            f"interval {nominal_dt:.4g} s)",
            source=source,
            key=key,
        )


def recorded_epochs(imu_time, dtheta, dv, t_start, gnss_list):
    """EpochInput per recorded epoch: the IMU samples up to each data arrival.

    Parameters
    ----------
    imu_time : ndarray, shape (n,)
        End time of each increment (s, IMU axis).
    dtheta, dv : ndarray, shape (n, 3)
    t_start : float
        Time of the initial state (s): samples ending after it are used.
    gnss_list : list of GnssEpoch
        Epochs (PPS time and arrival on the IMU axis), increasing.

    Yields
    ------
    EpochInput (no truth)
    """
    first = int(np.searchsorted(imu_time, t_start, side="right"))
    lo = first
    for epoch in gnss_list:
        if epoch.time <= t_start or epoch.arrival > imu_time[-1]:
            continue
        hi = int(np.searchsorted(imu_time, epoch.arrival, side="right"))
        pps = int(np.searchsorted(imu_time, epoch.time, side="right")) - lo
        yield EpochInput(dtheta[lo:hi], dv[lo:hi], min(max(pps, 0), hi - lo), epoch)
        lo = hi


def level_attitude(f_b, heading):
    """``mat_nb`` from the mean specific force (3,) m/s^2 (levelling) and a heading (rad):
    ``roll = atan2(-f_y, -f_z)``, ``pitch = atan2(f_x, hypot(f_y, f_z))``."""
    roll = math.atan2(-f_b[1], -f_b[2])
    pitch = math.atan2(f_b[0], math.hypot(f_b[1], f_b[2]))
    return rotation.axis_rotation(2, heading) @ rotation.mat_from_euler(roll, pitch, 0.0)


def _mean_force(imu_time, dv, dt, window):
    sel = (imu_time > window[0]) & (imu_time <= window[1])
    if not sel.any():
        raise InputError(f"no IMU sample in the window {window} s", key="data.static_window_s")
    return dv[sel].mean(axis=0) / dt


def _free_run(mat_nb, lla, imu_time, dtheta, dv, dt, lo, hi):
    """Free-inertial run of samples ``lo:hi`` from rest; (quat, vel) after each sample."""
    nav = strapdown.FreeInertial(strapdown.NavState.from_attitude(mat_nb, np.zeros(3), lla))
    _, (quat, vel, _) = nav.run(dtheta[lo:hi], dv[lo:hi], dt)
    return quat, vel


@dataclass(frozen=True)
class HeadingInit:
    """Outcome of :func:`velocity_heading`: the attitude at ``t_start``, the heading (rad),
    the heading correction found (rad) and the epochs used (s, IMU axis)."""

    mat_nb: np.ndarray
    heading: float
    correction: float
    epochs: np.ndarray


def velocity_heading(imu_time, dtheta, dv, dt, lla, static_window, fix_time, vel_n, min_speed):
    """Level on the static window, take the heading from the first motion.

    1. Level: ``mat_nb`` at the window start from the window's mean specific force,
       heading 0.
    2. Integrate the attitude through the window; at its end re-level on the last 5 s
       (the heading integrated by the gyros kept) and run free-inertial from rest.
    3. The first epochs (up to 5) whose SPP ground speed exceeds ``min_speed`` give the
       rotation about the vertical that takes the inertial horizontal velocity onto the
       SPP one, ``dpsi = atan2(sum v_ins x v_gps, sum v_ins . v_gps)`` (the free run
       spans from the window end to the last of those epochs); the attitude at
       the start is turned by it (a rotation about the vertical commutes with the
       attitude integration to first order over this minute: Earth rate 0.4 deg).

    Parameters
    ----------
    imu_time, dtheta, dv : ndarray, shapes (n,), (n, 3), (n, 3)
    dt : float
    lla : ndarray, shape (3,)
    static_window : (float, float)
        The vehicle stands still (s, IMU axis).
    fix_time : ndarray, shape (m,)
        SPP epochs (s, IMU axis).
    vel_n : ndarray, shape (m, 3)
        SPP NED velocity (m/s), NaN without a fix.
    min_speed : float
        m/s.

    Returns
    -------
    HeadingInit
    """
    start, end = static_window
    level = level_attitude(_mean_force(imu_time, dv, dt, static_window), 0.0)
    lo = int(np.searchsorted(imu_time, start, side="right"))
    hi = int(np.searchsorted(imu_time, end, side="right"))
    quat, _ = _free_run(level, lla, imu_time, dtheta, dv, dt, lo, hi)
    heading_end = rotation.euler_from_mat(rotation.mat_from_quat(quat[-1]))[2]
    mat_end = level_attitude(_mean_force(imu_time, dv, dt, (end - 5.0, end)), heading_end)
    speed = np.hypot(vel_n[:, 0], vel_n[:, 1])
    moving = np.flatnonzero((fix_time > end) & (speed > min_speed))[:5]
    if moving.size == 0:
        raise InputError(
            f"no epoch after the static window faster than {min_speed} m/s: no heading "
            "from the motion",
            key="data.motion_speed_mps",
        )
    moving = moving[fix_time[moving] <= fix_time[moving[0]] + 10.0]
    stop = int(np.searchsorted(imu_time, fix_time[moving[-1]], side="right"))
    _, vel = _free_run(mat_end, lla, imu_time, dtheta, dv, dt, hi, stop)
    at = np.searchsorted(imu_time, fix_time[moving], side="right") - 1 - hi
    ok = (at >= 0) & (at < len(vel))
    if not ok.any():
        raise InputError("no IMU data at the first moving epochs", key="data.static_window_s")
    v_ins, v_gps = vel[at[ok]], vel_n[moving[ok]]
    cross = np.sum(v_ins[:, 0] * v_gps[:, 1] - v_ins[:, 1] * v_gps[:, 0])
    dot = np.sum(v_ins[:, 0] * v_gps[:, 0] + v_ins[:, 1] * v_gps[:, 1])
    correction = math.atan2(cross, dot)
    mat0 = rotation.axis_rotation(2, correction) @ level
    return HeadingInit(
        mat0,
        float(rotation.euler_from_mat(mat0)[2]),
        correction,
        fix_time[moving[ok]],
    )

"""A recorded flight made ready for :func:`inins.ekf.filter.run_filter`: the GNSS epochs
during the IMU record, their SPP fixes, the initial attitude (levelling and the
velocity heading, :func:`inins.ekf.sources.velocity_heading`) and the initial
position, the IMU's (the first fix is the antenna's: the lever arm is taken off).

Pure numerics: the caller reads the file (:mod:`inins.io`) and passes arrays and
records; the time axis is the IMU's (``gps seconds of week - imu_t0_sow``).
"""

from dataclasses import dataclass

import numpy as np

from inins.core import earth, rotation, strapdown
from inins.ekf import sources
from inins.exceptions import InputError
from inins.gnss import broadcast, ephemeris, measurements, simulate, spp


def imu_position(antenna_ecef, mat_nb, lever_b):
    """ECEF position (3,) m of the IMU whose antenna is at ``antenna_ecef`` (3,) m.

    The inverse of :func:`inins.gnss.simulate.antenna_states` for the position,
    ``r_imu = r_ant - mat_en mat_nb l_b`` with ``mat_en`` at the antenna (the
    lever arm, within 100 m, turns ``mat_en`` by < 2e-5 rad: < 2 mm).
    """
    r_ant = np.asarray(antenna_ecef, dtype=float)
    lla = earth.llh_from_ecef(r_ant)
    offset, _ = simulate.antenna_states(
        lla[None, :], np.zeros((1, 3)), np.asarray(mat_nb, float)[None], None, lever_b
    )
    return r_ant - (offset[0] - earth.ecef_from_llh(*lla))


@dataclass(frozen=True, eq=False)
class RecordedStart:
    """What a recorded run starts from (IMU time axis, SI).

    Attributes
    ----------
    initial : inins.core.strapdown.NavState
        At rest, the attitude of :attr:`heading`, the IMU below the first fix.
    t_start : float
        Time of ``initial`` (s): one sample before the first increment.
    heading : inins.ekf.sources.HeadingInit
    epochs : inins.gnss.measurements.GnssEpochs
        GNSS epochs during the IMU record, with satellite states.
    time : ndarray, shape (m,)
        Their times on the IMU axis (s).
    fix_pos : ndarray, shape (m, 3)
        SPP antenna ECEF position per epoch (m), NaN without a fix.
    fix_vel_n : ndarray, shape (m, 3)
        SPP NED velocity per epoch (m/s, NED at the first fix).
    first_fix : ndarray, shape (3,)
        The first SPP fix (ECEF m).
    klobuchar : tuple of two (4,) arrays or None
    mask : float
        Elevation mask (rad).
    """

    initial: strapdown.NavState
    t_start: float
    heading: sources.HeadingInit
    epochs: measurements.GnssEpochs
    time: np.ndarray
    fix_pos: np.ndarray
    fix_vel_n: np.ndarray
    first_fix: np.ndarray
    klobuchar: tuple | None
    mask: float


def prepare(
    imu_time,
    dtheta,
    dv,
    dt,
    obs,
    eph_columns,
    imu_t0_sow,
    *,
    mask,
    klobuchar,
    static_window,
    motion_speed,
    lever_arm,
    source=None,
    glonass=None,
):
    """Epochs, SPP fixes and the initial state of a recording (module docstring).

    Parameters
    ----------
    imu_time, dtheta, dv : ndarray, shapes (n,), (n, 3), (n, 3)
        IMU sample end times (s) and increments (rad, m/s).
    dt : float
        Nominal IMU interval (s).
    obs : inins.gnss.measurements.Observations
    eph_columns : mapping or structured array
        Broadcast ephemeris columns (:func:`inins.gnss.ephemeris.from_columns`).
    imu_t0_sow : float
        GPS seconds of week of IMU time 0.
    mask : float
        Elevation mask (rad).
    klobuchar : tuple of two (4,) arrays or None
    static_window : (float, float)
        Levelling window (s, IMU axis).
    motion_speed : float
        SPP ground speed (m/s) above which the motion gives the heading.
    lever_arm : array_like, shape (3,)
        Antenna minus IMU, body axes (m).
    source : str, optional
        File name for the messages.
    glonass : inins.gnss.glonass.GlonassEphemeris, optional
        GLONASS sets for GLONASS rows of ``obs`` (the Keplerian sets of every other
        system are in ``eph_columns``).

    Returns
    -------
    RecordedStart

    Raises
    ------
    inins.exceptions.InputError
        No GNSS epoch during the IMU record, no SPP fix, no motion for the heading.
    """
    t = obs.time - imu_t0_sow
    inside = np.flatnonzero((t > imu_time[0] - 1.0) & (t < imu_time[-1] + 1.0))
    if inside.size == 0:
        raise InputError("no GNSS epoch during the IMU record", source=source, key="gnss")
    eph = ephemeris.from_columns(eph_columns)
    if glonass is not None:
        eph = broadcast.Navigation(kepler=eph, glonass=glonass)
    epochs = measurements.attach_satellites(obs.take_epochs(inside), eph, source=source)
    t = epochs.obs.time - imu_t0_sow
    fix = spp.solve(epochs, spp.SppOptions(mask_rad=mask, klobuchar=klobuchar))
    fixed = np.flatnonzero(np.isfinite(fix.pos[:, 0]))
    if fixed.size == 0:
        raise InputError("no SPP fix in the record", source=source, key="data.mask_deg")
    first = fix.pos[fixed[0]]
    lla0 = earth.llh_from_ecef(first)
    vel_n = np.einsum("ji,nj->ni", earth.mat_en(lla0[0], lla0[1]), fix.vel)
    init = sources.velocity_heading(
        imu_time, dtheta, dv, dt, lla0, static_window, t, vel_n, motion_speed
    )
    lla_imu = earth.llh_from_ecef(imu_position(first, init.mat_nb, lever_arm))
    initial = strapdown.NavState.from_attitude(init.mat_nb, np.zeros(3), lla_imu)
    return RecordedStart(
        initial, float(imu_time[0] - dt), init, epochs, t, fix.pos, vel_n, first, klobuchar, mask
    )


def epoch_stream(start, imu_time, dtheta, dv, latency, sigma_pr, sigma_rr, sigma_scale=None):
    """The :class:`~inins.ekf.config.EpochInput` stream of a prepared recording.

    Parameters
    ----------
    start : RecordedStart
    imu_time, dtheta, dv : ndarray
        As given to :func:`prepare`.
    latency : float
        Data arrival after the epoch (s).
    sigma_pr, sigma_rr : float
        Measurement 1-sigma the filter uses (m, m/s).
    sigma_scale : ndarray, shape (6,), optional
        Factor on ``sigma_pr`` per system index.
    """
    gnss_list, _ = sources.filter_epochs(
        start.epochs,
        start.time,
        start.time + latency,
        sigma_pr,
        sigma_rr,
        start.mask,
        start.first_fix,
        start.klobuchar,
        sigma_scale,
    )
    return sources.recorded_epochs(imu_time, dtheta, dv, start.t_start, gnss_list)


def antenna_positions(lla, quat_nb, lever_b):
    """ECEF antenna position (m, 3) of a filter solution ``lla`` (m, 3), ``quat_nb`` (m, 4)."""
    mat_nb = rotation.mat_from_quat(quat_nb)
    pos, _ = simulate.antenna_states(lla, np.zeros_like(lla), mat_nb, None, lever_b)
    return pos

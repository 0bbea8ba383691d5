"""Receiver measurement simulation: pseudorange and range rate on any trajectory.

Per epoch (true GPS time ``t`` of reception) and satellite above the mask:

``P = rho + b(t) - c dt_sv(t_tx) + T + I + e_P``,
``rdot = drho/dt + d(t) - c dt_sv_dot + e_R``,

with ``rho`` the geometric range with Earth rotation during travel
(:func:`inins.gnss.propagation.geometry`), ``t_tx = t - (rho + T + I) / c``
the true emission time, ``b = c dt_rx``, ``d = c dt_rx_dot`` the receiver clock
(:func:`clock_random_walk`), ``T`` Saastamoinen, ``I`` Klobuchar for L1 when
coefficients are given (zero for the ionosphere-free signal). The measurement is
tagged with the receiver's clock, ``t + b / c``, as a receiver does.
"""

from dataclasses import dataclass

import numpy as np

from inins.core import earth
from inins.core.units import DEG
from inins.gnss import broadcast, ephemeris, orbit, propagation, systems
from inins.gnss.measurements import Signal, make_observations
from inins.gnss.orbit import C


@dataclass(frozen=True)
class ReceiverTruth:
    """True receiver states at the simulated epochs.

    pos, vel : (n, 3) ECEF antenna position (m) and velocity (m/s);
    clock : (n,) m, ``c dt_rx``; drift : (n,) m/s, ``c dt_rx_dot``; time : (n,) s, true GPS sow.
    """

    time: np.ndarray
    pos: np.ndarray
    vel: np.ndarray
    clock: np.ndarray
    drift: np.ndarray


def clock_random_walk(time, h0, h_2, rng, *, bias0=0.0, drift0=0.0):
    """Receiver clock bias and drift, two-state random walk from Allan parameters.

    ``x = [dt, dt_dot]``, ``x_k+1 = [[1, T], [0, 1]] x_k + w_k``, with
    ``Q = [[h0 T / 2 + 2 pi^2 h_-2 T^3 / 3, pi^2 h_-2 T^2], [pi^2 h_-2 T^2, 2 pi^2 h_-2 T]]``
    (Brown & Hwang, Introduction to Random Signals, §9.3; flicker h_-1 left out).
    TCXO: h0 ~ 2e-19 s, h_-2 ~ 2e-20 1/s.

    Parameters
    ----------
    time : ndarray, shape (n,), s (increasing)
    h0 : float, s (white frequency noise)
    h_2 : float, 1/s (random-walk frequency noise)
    rng : numpy.random.Generator
    bias0 : float, m;  drift0 : float, m/s
        ``c dt`` and ``c dt_dot`` at ``time[0]``.

    Returns
    -------
    bias : ndarray, shape (n,), m
    drift : ndarray, shape (n,), m/s
    """
    step = np.diff(np.asarray(time, float))
    q11 = h0 / 2.0 * step + 2.0 * np.pi**2 * h_2 * step**3 / 3.0
    q12 = np.pi**2 * h_2 * step**2
    q22 = 2.0 * np.pi**2 * h_2 * step
    l11 = np.sqrt(q11)
    l21 = np.where(l11 > 0, q12 / np.where(l11 > 0, l11, 1.0), 0.0)
    l22 = np.sqrt(np.maximum(q22 - l21**2, 0.0))
    z = rng.standard_normal((len(step), 2))
    w1, w2 = l11 * z[:, 0], l21 * z[:, 0] + l22 * z[:, 1]
    drift = drift0 / C + np.concatenate([[0.0], np.cumsum(w2)])
    bias = bias0 / C + np.concatenate([[0.0], np.cumsum(step * drift[:-1] + w1)])
    return C * bias, C * drift


def antenna_states(lla, vel_n, mat_nb=None, omega_eb_b=None, lever_arm_b=None):
    """ECEF position and velocity of an antenna on a body.

    ``r_e = r_e(lla) + C_en C_nb l_b``, ``v_e = C_en (v_n + C_nb (omega_eb_b x l_b))``
    (spec §6a lever arm).

    Parameters
    ----------
    lla : ndarray, shape (n, 3), [rad, rad, m]
    vel_n : ndarray, shape (n, 3), m/s NED
    mat_nb : ndarray, shape (n, 3, 3), optional (needed with a lever arm)
    omega_eb_b : ndarray, shape (n, 3), rad/s, optional (zero)
    lever_arm_b : array_like, shape (3,), m, optional (zero)

    Returns
    -------
    pos_e, vel_e : ndarray, shape (n, 3)
    """
    lla = np.asarray(lla, float)
    c_en = earth.mat_en(lla[:, 0], lla[:, 1])
    pos_e = earth.ecef_from_llh(lla[:, 0], lla[:, 1], lla[:, 2])
    vel = np.asarray(vel_n, float).copy()
    if lever_arm_b is not None:
        lever = np.asarray(lever_arm_b, float)
        pos_e = pos_e + np.einsum("nij,nj->ni", c_en, mat_nb @ lever)
        if omega_eb_b is not None:
            vel = vel + np.einsum("nij,nj->ni", mat_nb, np.cross(omega_eb_b, lever))
    return pos_e, np.einsum("nij,nj->ni", c_en, vel)


def antenna_from_trajectory(trajectory, time, lever_arm_b=None):
    """Antenna ECEF position and velocity along a core trajectory (``state``, ``rates``).

    ``omega_eb_b = omega_ib_b - C_bn omega_ie_n``.
    """
    mat_nb, vel_n, lla = trajectory.state(time)
    omega_ib_b, _ = trajectory.rates(time)
    omega_ie_n = earth.rate_ie_n(lla[:, 0])
    omega_eb_b = omega_ib_b - np.einsum("nji,nj->ni", mat_nb, omega_ie_n)
    return antenna_states(lla, vel_n, mat_nb, omega_eb_b, lever_arm_b)


@dataclass(frozen=True)
class SimulationOptions:
    """Settings of :func:`simulate`.

    mask_rad (rad), sigma_pr_m (m), sigma_rate_mps (m/s): 1-sigma white noise,
    divided by sin(elevation) when ``elevation_noise``; ``signal``: L1 (TGD and
    Klobuchar apply) or IONO_FREE; ``troposphere``: Saastamoinen delay on;
    ``klobuchar``: (alpha, beta) or None (scaled by ``(f_L1 / f)^2`` for other systems'
    band-1 signals); ``system_bias_m``: (system index, m) pairs, an inter-system bias the
    receiver adds to that system's pseudoranges (GLONASS-GPS time offset and receiver
    code biases); ``glonass_ifb_m``: a GLONASS inter-frequency code bias of
    ``glonass_ifb_m * k`` (m) on the pseudoranges of channel ``k`` (a receiver's delay
    varying across the G1 band, linear in frequency).
    """

    mask_rad: float = 10.0 * DEG
    sigma_pr_m: float = 1.0
    sigma_rate_mps: float = 0.05
    elevation_noise: bool = False
    signal: Signal = Signal.L1
    troposphere: bool = True
    klobuchar: tuple | None = None
    system_bias_m: tuple = ()
    glonass_ifb_m: float = 0.0


_MASK_MARGIN = 1.0 * DEG
"""Satellites further below the mask after the first light-time iteration (rad) are not
iterated again (they stay below it)."""


def _delays(los, lla, mat_en, sow, options, sat=None):
    """Elevation (rad) and modelled delay (m) of lines of sight ``los`` (ECEF unit
    vectors) from receivers at ``lla`` with NED-to-ECEF ``mat_en``: the elevation and
    azimuth of :func:`inins.gnss.propagation.elevation_azimuth` with the receiver's
    geodetic position and frame computed once per epoch, not per satellite."""
    los_n = propagation.ned_of_ecef(mat_en, los)
    el = np.arcsin(np.clip(-los_n[..., 2], -1.0, 1.0))
    delay = np.zeros_like(el)
    if options.troposphere:
        delay += propagation.troposphere_saastamoinen(lla[..., 2], lla[..., 0], el)
    if options.klobuchar is not None and options.signal == Signal.L1:
        az = np.mod(np.arctan2(los_n[..., 1], los_n[..., 0]), 2.0 * np.pi)
        alpha, beta = options.klobuchar
        iono = propagation.ionosphere_klobuchar(sow, lla[..., 0], lla[..., 1], el, az, alpha, beta)
        delay += iono if sat is None else iono * systems.iono_scale(sat)
    return el, delay


def simulate(eph, week, time, pos_e, vel_e, clock, drift, rng, options=SimulationOptions()):
    """Pseudoranges and range rates a receiver on the given track would measure.

    Parameters
    ----------
    eph : Ephemeris or inins.gnss.broadcast.Navigation
        Constellation (a navigation file or :func:`inins.gnss.constellation.walker`); a
        Navigation of a mixed file simulates every system in it (GLONASS within the 15 min
        of its sets).
    week : int
    time : ndarray, shape (n,), s
        True GPS seconds of week of reception.
    pos_e, vel_e : ndarray, shape (n, 3), m, m/s
        True antenna position and velocity, ECEF (:func:`antenna_states`).
    clock, drift : ndarray, shape (n,), m, m/s
        Receiver clock ``c dt_rx`` and ``c dt_rx_dot`` (:func:`clock_random_walk`).
    rng : numpy.random.Generator
    options : SimulationOptions

    Returns
    -------
    obs : Observations
        Time tags ``t + dt_rx``; ``sigma`` the pseudorange noise 1-sigma used.
    truth : ReceiverTruth
    """
    time = np.asarray(time, float)
    nav = eph if isinstance(eph, broadcast.Navigation) else None
    if nav is None:
        prns = np.unique(eph.prn[eph.health == 0])
    else:
        prns = np.unique(
            np.concatenate(
                [nav.kepler.prn[nav.kepler.health == 0], nav.glonass.sat[nav.glonass.health == 0]]
            )
        )
    shape = (len(time), len(prns))
    t = np.broadcast_to(time[:, None], shape)
    prn = np.broadcast_to(prns[None, :], shape)
    rx, rx_vel = np.asarray(pos_e, float)[:, None, :], np.asarray(vel_e, float)[:, None, :]
    tau = np.full(shape, 0.075)
    if nav is None:
        index = ephemeris.select(eph, prn, week, t - tau)
    else:
        index = broadcast.select(nav, prn.ravel(), week, (t - tau).ravel()).reshape(shape)
    have = index >= 0
    single = options.signal == Signal.L1
    index = np.where(have, index, 0)
    rx_lla = earth.llh_from_ecef(rx)  # (n, 1, 3): per epoch
    rx_mat = earth.mat_en(rx_lla[..., 0], rx_lla[..., 1])
    sat = _states(eph, nav, prn, index, week, t - tau, single, have)
    rho, rate, los, _ = propagation.geometry(sat.pos, sat.vel, rx, rx_vel)
    el, delay = _delays(los, rx_lla, rx_mat, t, options, None if nav is None else prn)
    # two more light-time iterations, for the satellites that can be above the mask
    # (a second iteration moves the elevation by ~1e-5 rad; the others stay masked)
    near = np.nonzero(have & (el > options.mask_rad - _MASK_MARGIN))
    rx_n = np.broadcast_to(rx, (*shape, 3))[near]
    rv_n = np.broadcast_to(rx_vel, (*shape, 3))[near]
    lla_n = np.broadcast_to(rx_lla, (*shape, 3))[near]
    mat_n = np.broadcast_to(rx_mat, (*shape, 3, 3))[near]
    t_n, prn_n, index_n = t[near], prn[near], index[near]
    tau_n = (rho[near] + delay[near]) / C
    for _ in range(2):
        sat_n = _states(eph, nav, prn_n, index_n, week, t_n - tau_n, single, have[near])
        rho_n, rate_n, los_n, _ = propagation.geometry(sat_n.pos, sat_n.vel, rx_n, rv_n)
        sys_n = None if nav is None else prn_n
        el_n, delay_n = _delays(los_n, lla_n, mat_n, t_n, options, sys_n)
        tau_n = (rho_n + delay_n) / C
    clock_sat, drift_sat = sat.clock.copy(), sat.drift.copy()
    for full, part in ((rho, rho_n), (rate, rate_n), (el, el_n), (delay, delay_n)):
        full[near] = part
    clock_sat[near], drift_sat[near] = sat_n.clock, sat_n.drift
    seen = have & (el >= options.mask_rad)
    scale = 1.0 / np.sin(np.clip(el, 1e-3, None)) if options.elevation_noise else 1.0
    sigma = np.broadcast_to(options.sigma_pr_m * scale, shape)
    sigma_rate = options.sigma_rate_mps * scale
    pr = rho + clock[:, None] - clock_sat + delay + sigma * rng.standard_normal(shape)
    if options.system_bias_m:
        bias = np.zeros(systems.SBAS + 1)
        for system, value in options.system_bias_m:
            bias[system] = value
        pr = pr + bias[systems.system_of(prn)]
    if options.glonass_ifb_m and nav is not None:
        channel = broadcast.glonass_channels(nav, prn)
        pr = pr + options.glonass_ifb_m * np.where(np.isfinite(channel), channel, 0.0)
    rr = rate + drift[:, None] - drift_sat + sigma_rate * rng.standard_normal(shape)
    counts = seen.sum(axis=1)
    obs = make_observations(
        week,
        time + np.asarray(clock) / C,
        np.concatenate([[0], np.cumsum(counts)]),
        prn[seen],
        pr[seen],
        range_rate=rr[seen],
        sigma=sigma[seen],
        signal=options.signal,
    )
    truth = ReceiverTruth(
        time=time,
        pos=np.asarray(pos_e, float),
        vel=np.asarray(vel_e, float),
        clock=np.asarray(clock, float),
        drift=np.asarray(drift, float),
    )
    return obs, truth


def _states(eph, nav, prn, index, week, t_tx, single, have):
    """Satellite states (shape of ``index``) of GPS sets, or of any system's (computed where
    ``have``; elsewhere a placeholder far below the horizon of nothing, masked later)."""
    if nav is None:
        return orbit.satellite_states(eph, index, week, t_tx, tgd=single)
    shape = index.shape
    pos = np.tile([2.6e7, 0.0, 0.0], (*shape, 1))
    vel, clock, drift = np.zeros((*shape, 3)), np.zeros(shape), np.zeros(shape)
    flat = broadcast.satellite_states(
        nav, prn[have], index[have], week, np.broadcast_to(t_tx, shape)[have]
    )
    pos[have], vel[have], drift[have] = flat.pos, flat.vel, flat.drift
    clock[have] = flat.clock
    delay = C * broadcast.group_delay(nav, prn[have], index[have])
    if single:
        clock[have] -= delay
    else:  # the ionosphere-free pair's group delay (BeiDou B1I/B3I: 2.94 TGD1)
        dual = systems.dual_group_delay_factor(prn[have])
        clock[have] -= np.where(dual != 0.0, dual * delay, 0.0)
    return orbit.SatelliteStates(pos=pos, vel=vel, clock=clock, drift=drift)


def static_receiver(lat, lon, height, n):
    """(pos_e, vel_e), shape (n, 3): a receiver at rest at one place (rad, rad, m)."""
    pos = earth.ecef_from_llh(np.float64(lat), np.float64(lon), np.float64(height))
    return np.tile(pos, (n, 1)), np.zeros((n, 3))

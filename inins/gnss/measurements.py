"""Per-epoch GNSS measurements, with and without satellite states.

Rows of all epochs are stacked on one axis, those of epoch ``k`` being
``start[k]:start[k + 1]`` (compressed rows: epochs may have any number of
satellites, including none). :class:`Observations` is what a receiver
reports; :func:`attach_satellites` adds the satellite states the models
need and gives :class:`GnssEpochs`, the structure SPP and the EKF consume.
"""

import enum
from dataclasses import dataclass, field, fields, replace

import numpy as np

from inins.core import earth
from inins.exceptions import InputError
from inins.gnss import broadcast, propagation, systems
from inins.gnss.orbit import C
from inins.gnss.propagation import LAMBDA_L1, ionosphere_free


class Signal(enum.IntEnum):
    """What a pseudorange row is: decides TGD and the ionosphere model."""

    L1 = 1
    """Single-frequency L1 (C/A or P1): satellite clock with TGD, ionosphere modelled."""
    IONO_FREE = 2
    """Ionosphere-free P1/P2 combination: no TGD, no ionosphere model."""


@dataclass(frozen=True)
class Observations:
    """Receiver measurements per epoch (no satellite states).

    Attributes
    ----------
    week : ndarray of int64, shape (n_epochs,)
        GPS week of each epoch.
    time : ndarray, shape (n_epochs,), s
        Receive time tag, GPS seconds of week as the receiver clock reads it.
    start : ndarray of int64, shape (n_epochs + 1,)
        Rows of epoch ``k`` are ``start[k]:start[k + 1]``.
    prn : ndarray of int64, shape (m,)
    pseudorange : ndarray, shape (m,), m
    range_rate : ndarray, shape (m,), m/s
        Positive when the range grows (Doppler Hz = -range_rate / LAMBDA_L1); NaN if absent.
    sigma : ndarray, shape (m,), m
        Pseudorange 1-sigma as the source states it (NaN if it does not).
    snr : ndarray, shape (m,), dB-Hz (NaN if absent)
    signal : ndarray of int8, shape (m,)
        :class:`Signal` of the pseudorange.
    """

    week: np.ndarray
    time: np.ndarray
    start: np.ndarray
    prn: np.ndarray
    pseudorange: np.ndarray
    range_rate: np.ndarray
    sigma: np.ndarray
    snr: np.ndarray
    signal: np.ndarray

    @property
    def n_epochs(self):
        return len(self.time)

    @property
    def epoch(self):
        """Epoch index of every row, shape (m,)."""
        return np.repeat(np.arange(self.n_epochs), np.diff(self.start))

    def epoch_rows(self, index):
        """Row numbers of the epochs ``index`` (int array), in order."""
        index = np.asarray(index, dtype=np.int64)
        counts = self.start[index + 1] - self.start[index]
        offsets = np.repeat(
            self.start[index] - np.concatenate([[0], np.cumsum(counts)[:-1]]), counts
        )
        return np.arange(counts.sum()) + offsets

    def take_epochs(self, index):
        """The epochs ``index`` (int array) with their rows, as new Observations."""
        index = np.asarray(index, dtype=np.int64)
        rows = self.epoch_rows(index)
        counts = self.start[index + 1] - self.start[index]
        per_row = {
            f.name: getattr(self, f.name)[rows]
            for f in fields(Observations)
            if f.name not in ("week", "time", "start")
        }
        return Observations(
            week=self.week[index],
            time=self.time[index],
            start=np.concatenate([[0], np.cumsum(counts)]),
            **per_row,
        )

    def take_rows(self, keep):
        """The same epochs with only the rows where ``keep`` (bool, shape (m,)) is True."""
        counts = np.bincount(self.epoch[keep], minlength=self.n_epochs)
        start = np.concatenate([[0], np.cumsum(counts)])
        row = {
            f.name: getattr(self, f.name)[keep]
            for f in fields(Observations)
            if f.name not in ("week", "time", "start")
        }
        return replace(self, start=start, **row)


def make_observations(
    week, time, start, prn, pseudorange, *, range_rate=None, sigma=None, snr=None, signal=Signal.L1
):
    """:class:`Observations` from arrays, with dtypes checked and absent columns NaN."""
    m = len(prn)
    nan = np.full(m, np.nan)
    return Observations(
        week=np.broadcast_to(np.asarray(week, np.int64), np.shape(time)).copy(),
        time=np.asarray(time, float),
        start=np.asarray(start, np.int64),
        prn=np.asarray(prn, np.int64),
        pseudorange=np.asarray(pseudorange, float),
        range_rate=nan if range_rate is None else np.asarray(range_rate, float),
        sigma=nan if sigma is None else np.asarray(sigma, float),
        snr=nan if snr is None else np.asarray(snr, float),
        signal=np.broadcast_to(np.asarray(signal, np.int8), (m,)).copy(),
    )


def code_pseudorange(p1, p2, c1, sat=None):
    """Pseudorange and its :class:`Signal` per row from RINEX code observables.

    Ionosphere-free ``(f1^2 P1 - f2^2 P2) / (f1^2 - f2^2)`` where P1 and P2 both
    exist, else P1, else C1 (single-frequency L1). NaN where none exists. Rows of other
    systems (``sat`` given) use their pair's ratio (:data:`inins.gnss.systems.GAMMA_DUAL`:
    GLONASS G1/G2 ``9 / 7`` for every channel, Galileo E1/E5a, BeiDou B1I/B3I).

    Parameters
    ----------
    p1, p2, c1 : ndarray, shape (m,), m (NaN where absent)
    sat : ndarray of int, shape (m,), optional; satellite numbers (GPS when None)

    Returns
    -------
    pseudorange : ndarray, shape (m,), m
    signal : ndarray of int8, shape (m,)
    """
    p1, p2, c1 = (np.asarray(v, float) for v in (p1, p2, c1))
    dual = np.isfinite(p1) & np.isfinite(p2)
    single = np.where(np.isfinite(p1), p1, c1)
    free = ionosphere_free(p1, p2)
    if sat is not None and np.any(systems.system_of(sat) != systems.GPS):
        system = systems.system_of(sat)
        gamma = systems.GAMMA_DUAL[np.where(system < systems.SBAS, system, systems.GPS)]
        free = np.where(system == systems.GPS, free, (gamma * p1 - p2) / (gamma - 1.0))
    pr = np.where(dual, free, single)
    return pr, np.where(dual, Signal.IONO_FREE, Signal.L1).astype(np.int8)


def range_rate_from_doppler(doppler_hz, wavelength=LAMBDA_L1):
    """Range rate (m/s, positive when the range grows) from a band-1 Doppler (Hz):
    ``-lambda D`` (``wavelength`` per row for other systems:
    :func:`inins.gnss.systems.l1_wavelength`)."""
    return -np.asarray(wavelength, float) * np.asarray(doppler_hz, float)


def from_record(record):
    """:class:`Observations` of a recorded-flight GNSS record (anything with the fields
    ``week, time, start, prn, pseudorange, range_rate, sigma, snr, signal``, such as
    :class:`inins.io.flight_layout.GnssRecord`)."""
    return make_observations(
        record.week,
        record.time,
        record.start,
        record.prn,
        record.pseudorange,
        range_rate=record.range_rate,
        sigma=record.sigma,
        snr=record.snr,
        signal=record.signal,
    )


def from_code(
    week, time, start, prn, p1, p2, c1, *, doppler_l1=None, snr=None, sigma=None, channel=None
):
    """:class:`Observations` from RINEX-style code observables (one call for a reader's arrays).

    Pseudorange per :func:`code_pseudorange` (ionosphere-free where P1 and P2
    exist, else P1, else C1); range rate from the L1 Doppler when given.

    Parameters
    ----------
    week, time, start, prn : as in :class:`Observations`
    p1, p2, c1 : ndarray, shape (m,), m (NaN where absent; all-NaN columns allowed)
    doppler_l1 : ndarray, shape (m,), Hz, optional
    snr : ndarray, shape (m,), dB-Hz, optional
    sigma : ndarray, shape (m,), m, optional
    channel : ndarray, shape (m,), optional
        GLONASS frequency channel per row (NaN elsewhere): the wavelength of a GLONASS
        Doppler. GPS-only data need none.

    Returns
    -------
    Observations

    Raises
    ------
    InputError
        A GLONASS row carries a Doppler but no frequency channel.
    """
    prn = np.asarray(prn, np.int64)
    multi = np.any(prn >= 100)
    pr, signal = code_pseudorange(p1, p2, c1, prn if multi else None)
    rate = None
    if doppler_l1 is not None and not multi:
        rate = range_rate_from_doppler(doppler_l1)
    elif doppler_l1 is not None:
        wavelength = systems.l1_wavelength(prn, channel)
        lost = np.isnan(wavelength) & np.isfinite(doppler_l1)
        if lost.any():
            names = sorted({systems.rinex_name(p) for p in prn[lost].tolist()})
            raise InputError(
                f"GLONASS frequency channel missing for {' '.join(names)} (Doppler needs "
                "it; neither the observation header nor the navigation data give it)"
            )
        rate = range_rate_from_doppler(doppler_l1, wavelength)
    return make_observations(
        week, time, start, prn, pr, range_rate=rate, sigma=sigma, snr=snr, signal=signal
    )


@dataclass(frozen=True)
class GnssEpochs:
    """Measurements with the satellite states that go with them (what SPP and the EKF use).

    Attributes
    ----------
    obs : Observations
        The measurements (rows as below).
    eph_index : ndarray of int64, shape (m,)
        Ephemeris row used for each measurement.
    sat_pos : ndarray, shape (m, 3), m
        Satellite position at transmit time, ECEF frame of transmit time
        (rotate with :func:`inins.gnss.propagation.geometry` / ``sagnac_rotate``).
    sat_vel : ndarray, shape (m, 3), m/s
    sat_clock : ndarray, shape (m,), m
        ``c dt_sv`` with the relativistic term, minus ``c TGD`` on L1 rows.
    sat_drift : ndarray, shape (m,), m/s
    dropped_prn : ndarray of int64, shape (k,)
        PRNs of the measurements left out for want of a healthy ephemeris (sorted, unique).
    dropped_count : ndarray of int64, shape (k,)
        How many measurements of each of those PRNs were left out (on the ABPO day:
        all of unhealthy G08, and one row each of seven satellites at 00:00:00,
        transmitted 70 ms before the 2 h limit of their first set).
    """

    obs: Observations
    eph_index: np.ndarray
    sat_pos: np.ndarray
    sat_vel: np.ndarray
    sat_clock: np.ndarray
    sat_drift: np.ndarray
    dropped_prn: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    dropped_count: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))

    def take_epochs(self, index):
        """The epochs ``index`` (int array) with their rows and satellite states."""
        rows = self.obs.epoch_rows(index)
        return GnssEpochs(
            dropped_prn=self.dropped_prn,
            dropped_count=self.dropped_count,
            obs=self.obs.take_epochs(index),
            eph_index=self.eph_index[rows],
            sat_pos=self.sat_pos[rows],
            sat_vel=self.sat_vel[rows],
            sat_clock=self.sat_clock[rows],
            sat_drift=self.sat_drift[rows],
        )


def attach_satellites(obs, eph, *, max_age_s=7200.0, source=None):
    """Satellite states at the transmit time of every measurement.

    Transmit time (GPS) ``t_tx = t_rx - P / c - dt_sv(t_tx)`` (two steps; the
    receiver clock cancels: ``P`` carries it). Rows whose satellite has no
    healthy ephemeris within ``max_age_s`` are dropped.

    Parameters
    ----------
    obs : Observations
    eph : Ephemeris or inins.gnss.broadcast.Navigation
        GPS sets, or the sets of all systems (GLONASS rows use the 15 min validity of
        :data:`inins.gnss.glonass.MAX_AGE_S`).
    max_age_s : float, s
    source : str, optional
        File name for the error message.

    Returns
    -------
    GnssEpochs

    Raises
    ------
    InputError
        If no measurement has an ephemeris (navigation data missing).
    """
    nav = broadcast.as_navigation(eph)
    week = obs.week[obs.epoch]
    t_sv = obs.time[obs.epoch] - obs.pseudorange / C
    index = broadcast.select(nav, obs.prn, week, t_sv, max_age_s=max_age_s)
    keep = (index >= 0) & np.isfinite(obs.pseudorange)
    if obs.prn.size and not keep.any():
        names = sorted({systems.rinex_name(p) for p in obs.prn.tolist()})
        raise InputError(
            f"no usable navigation data for the satellites observed "
            f"({' '.join(names[:12])}): no healthy ephemeris within "
            f"{max_age_s:.0f} s of the observation times",
            source=source,
        )
    dropped_prn, dropped_count = np.unique(obs.prn[~keep], return_counts=True)
    obs = obs.take_rows(keep)
    index, week, t_sv = index[keep], week[keep], t_sv[keep]
    single = obs.signal == Signal.L1
    delay = C * broadcast.group_delay(nav, obs.prn, index)
    dual = systems.dual_group_delay_factor(obs.prn)  # BeiDou B1I/B3I: 2.94 TGD1
    tgd = np.where(single, delay, np.where(dual != 0.0, dual * delay, 0.0))
    t_tx = t_sv
    for _ in range(2):
        states = broadcast.satellite_states(nav, obs.prn, index, week, t_tx)
        clock = states.clock - tgd
        t_tx = t_sv - clock / C
    return GnssEpochs(
        obs=obs,
        eph_index=index,
        sat_pos=states.pos,
        sat_vel=states.vel,
        sat_clock=clock,
        sat_drift=states.drift,
        dropped_prn=dropped_prn,
        dropped_count=dropped_count.astype(np.int64),
    )


@dataclass(frozen=True)
class Prediction:
    """Predicted measurements and their partial derivatives, one per row.

    Attributes
    ----------
    pseudorange : ndarray, shape (m,), m
    range_rate : ndarray, shape (m,), m/s
    los : ndarray, shape (m, 3)
        Unit line of sight receiver -> satellite, ECEF: ``dP/dr_e = -los``.
    rate_scale : ndarray, shape (m,)
        ``d range_rate / d v_e = -rate_scale * los`` (1 +- 3e-6).
    elevation, azimuth : ndarray, shape (m,), rad
    delay : ndarray, shape (m,), m
        Troposphere plus modelled ionosphere.
    """

    pseudorange: np.ndarray
    range_rate: np.ndarray
    los: np.ndarray
    rate_scale: np.ndarray
    elevation: np.ndarray
    azimuth: np.ndarray
    delay: np.ndarray


def predict(epochs, rx_pos, rx_vel, clock, drift, *, troposphere=True, klobuchar=None):
    """Model of every measurement row at given receiver states (the EKF's h(x)).

    ``P = rho + b - sat_clock + T + I``, ``rdot = rate + d - sat_drift`` with
    ``rho, rate`` from :func:`inins.gnss.propagation.geometry` (Earth rotation
    during travel), ``T`` Saastamoinen, ``I`` Klobuchar on L1 rows when
    ``klobuchar`` = (alpha, beta) is given.

    Parameters
    ----------
    epochs : GnssEpochs
    rx_pos, rx_vel : ndarray, shape (m, 3) or (3,) (or scalar 0 velocity), m, m/s
        Antenna ECEF position and velocity for each row (or one for all).
    clock, drift : ndarray, shape (m,) or scalar, m, m/s
        ``c dt_rx`` and ``c dt_rx_dot``.
    troposphere : bool
    klobuchar : tuple of two (4,) arrays, optional

    Returns
    -------
    Prediction
    """
    rx_pos = np.broadcast_to(np.asarray(rx_pos, float), epochs.sat_pos.shape)
    rx_vel = np.broadcast_to(np.asarray(rx_vel, float), epochs.sat_pos.shape)
    rho, rate, los, scale = propagation.geometry(epochs.sat_pos, epochs.sat_vel, rx_pos, rx_vel)
    el, az = propagation.elevation_azimuth(los, rx_pos)
    lla = earth.llh_from_ecef(rx_pos)
    delay = np.zeros_like(rho)
    if troposphere:
        delay += propagation.troposphere_saastamoinen(lla[:, 2], lla[:, 0], el)
    if klobuchar is not None:
        iono = propagation.ionosphere_klobuchar(
            epochs.obs.time[epochs.obs.epoch], lla[:, 0], lla[:, 1], el, az, *klobuchar
        )
        delay += np.where(epochs.obs.signal == Signal.L1, iono, 0.0)
    return Prediction(
        pseudorange=rho + clock - epochs.sat_clock + delay,
        range_rate=rate + drift - epochs.sat_drift,
        los=los,
        rate_scale=scale,
        elevation=el,
        azimuth=az,
        delay=delay,
    )


@dataclass(frozen=True)
class IonosphereChoice:
    """Which rows SPP uses and how their ionosphere is handled (:func:`ionosphere_rows`).

    Attributes
    ----------
    keep : ndarray of bool, shape (m,), rows to use
    klobuchar : bool, apply the Klobuchar model to the kept single-frequency rows
    dropped : int, single-frequency rows left out because nothing corrects them
    text : str, what the report says
    """

    keep: np.ndarray
    klobuchar: bool
    dropped: int
    text: str


def ionosphere_rows(signal, choice, has_klobuchar):
    """Rows to use and the ionosphere model, for ``choice`` in auto, iono-free, klobuchar, none.

    - ``iono-free``: only the ionosphere-free rows; single-frequency rows are dropped and
      counted (a refusal only when no row is dual-frequency);
    - ``auto``: ionosphere-free rows as they are; single-frequency rows with Klobuchar when
      the navigation data carry it, otherwise -- beside ionosphere-free rows -- dropped and
      counted: an uncorrected L1 row carries metres of ionosphere delay (ABPO 2015-01-08:
      46 C1 rows, median residual 28 m, moved 7 epochs by 5-8 m); with no dual-frequency
      row at all they are kept (single-frequency data, several metres of error, said so);
    - ``klobuchar``: every row, Klobuchar on the single-frequency rows (needs it);
    - ``none``: every row, no model.

    Raises
    ------
    InputError
        ``iono-free`` without any dual-frequency row; ``klobuchar`` without coefficients.
    """
    signal = np.asarray(signal)
    free = signal == Signal.IONO_FREE
    n_free, rows = int(free.sum()), len(signal)
    everything = np.ones(rows, bool)
    if choice == "iono-free":
        if rows and not n_free:
            raise InputError(
                "ionosphere-free needs P1 and P2: no row has both (single-frequency data)",
                key="spp.ionosphere",
            )
        text = "ionosphere-free P1/P2 combination"
        if n_free < rows:
            text += f"; {rows - n_free} single-frequency rows dropped"
        return IonosphereChoice(free, False, rows - n_free, text)
    if choice == "klobuchar" and not has_klobuchar:
        raise InputError(
            "the navigation data carry no Klobuchar coefficients", key="spp.ionosphere"
        )
    if choice == "none":
        return IonosphereChoice(everything, False, 0, "none (no ionosphere model)")
    if choice == "klobuchar" or has_klobuchar:
        if n_free == rows:
            return IonosphereChoice(everything, False, 0, "ionosphere-free P1/P2 combination")
        what = (
            "single-frequency L1"
            if n_free == 0
            else (f"ionosphere-free P1/P2 on {n_free} of {rows} rows; the others L1")
        )
        return IonosphereChoice(everything, True, 0, f"{what} with the Klobuchar model")
    if n_free == rows:
        return IonosphereChoice(everything, False, 0, "ionosphere-free P1/P2 combination")
    if n_free == 0:
        return IonosphereChoice(
            everything,
            False,
            0,
            "single-frequency L1; ionosphere model: none (single frequency, several "
            "metres of error)",
        )
    return IonosphereChoice(
        free,
        False,
        rows - n_free,
        f"ionosphere-free P1/P2; {rows - n_free} single-frequency rows dropped (no "
        "ionosphere model in the navigation data to correct them)",
    )


def system_rows(obs, system_indices):
    """The rows of ``obs`` whose satellite is of one of ``system_indices``
    (:data:`inins.gnss.systems.SYSTEMS` values)."""
    keep = np.isin(systems.system_of(obs.prn), np.asarray(system_indices, np.int64))
    return obs if keep.all() else obs.take_rows(keep)


def gps_rows(obs):
    """The GPS rows of ``obs`` (for a consumer with one receiver clock and no inter-system
    bias, which must not mix systems; the tightly coupled filter takes the systems it
    has bias states for, :func:`system_rows`)."""
    gps = systems.system_of(obs.prn) == systems.GPS
    return obs if gps.all() else obs.take_rows(gps)

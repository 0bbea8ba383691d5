"""Checks of a run-ekf or observability scenario made before the run starts: its size
(:class:`~inins.commands.budget.Estimate`, refused by
:func:`~inins.commands.budget.check_budget` unless ``--force``) and the numerical edges
where the methods stop meaning anything (refused whatever ``--force`` says).

run-ekf (simulated flight): the flight time from the legs (turns from their angle and
coordinated rate), IMU samples = time x rate, one filter epoch a second; refused: a site
or flight within :data:`POLE_MARGIN_DEG` of a pole (the NED mechanisation is singular
there), a bank angle whose load factor 1 / cos(bank) exceeds :data:`MAX_LOAD_FACTOR`, a
dither frequency at or above the Nyquist frequency of the IMU (the moving average
cannot remove what aliases), ``filter.turning_from_s`` at or after the end of the
flight, a zero ``data.forward_axis_b``.

observability: the covariance steps (duration / update interval), the segments (listed,
or at most one per sample of the flight or truth row of the trajectory) and the samples
of a flight source.
"""

import math

import numpy as np

from inins.commands.budget import Estimate
from inins.exceptions import InputError

POLE_MARGIN_DEG = 0.5
"""Closest approach to a pole (deg of latitude, 55 km) a simulated flight may make."""
MAX_LOAD_FACTOR = 6.0
"""Largest load factor 1 / cos(bank) of a coordinated turn (bank 80.4 deg)."""
EKF_MAX_SAMPLES = 20_000_000
"""Stated limit of IMU samples of one run-ekf run (27.8 h at 200 Hz). Measured: a
simulated run takes about 30 us a sample (sensor simulation, strapdown, filter; an
82 s flight at 4 kHz, 329,000 samples, took 10 s more than at 200 Hz on a shared two-core
machine), so the limit is about 10 minutes of work."""
EKF_EPOCH_BYTES = 2400
"""Output bytes per 1 Hz filter epoch (26-state estimate, sigma, corrections, navigation,
about 12 satellites x 2 innovations)."""
OBS_MAX_STEPS = 20_000_000
"""Stated limit of covariance steps (26 x 26 Riccati cycles, about 2 us each)."""
OBS_MAX_SEGMENTS = 20_000
"""Stated limit of segments of one observability analysis (each a rank update, a
Gramian and an eigen-decomposition, about 1 ms)."""
OBS_MAX_FLIGHT_SAMPLES = 1_000_000
"""Stated limit of samples of a flight source (attitude, rates and position of each,
320 MB; each may start a segment)."""
_F8 = 8


def run_ekf_estimate(scenario):
    """Size of a run-ekf run, and the numerical edges checked (refused with the key).

    Raises
    ------
    InputError
        A numerical edge (see the module docstring), or a flight plan that cannot be
        flown (its key).
    """
    _check_forward_axis(scenario)
    if scenario.flight is None:
        return None  # a recording: a few MB, checked as it is read

    flight = scenario.flight
    plan = flight.plan()
    duration = float(plan.duration)
    rate = float(flight.imu.sample_rate_hz)
    samples = duration * rate
    epochs = duration
    keys = "flight.legs (durations, turn angles) and flight.imu.sample_rate_hz"
    estimate = Estimate(
        int(min(samples, 2**62)),
        int(min(epochs * EKF_EPOCH_BYTES, 2**62)),
        int(min(epochs * 3 * EKF_EPOCH_BYTES + 64 * rate * 6 * _F8, 2**62)) + (256 << 20),
        keys,
        max_samples=EKF_MAX_SAMPLES,
    )
    _check_ekf_edges(scenario, plan, duration, rate)
    return estimate


def _check_forward_axis(scenario):
    data = scenario.data
    if data is not None and not np.linalg.norm(data.forward_axis_b) > 1e-6:
        raise InputError(
            f"{list(data.forward_axis_b)} has no direction: give the body axis the vehicle "
            "moves along, e.g. [1, 0, 0]",
            key="data.forward_axis_b",
        )


def _check_ekf_edges(scenario, plan, duration, rate):
    from inins.core.units import DEG

    flight = scenario.flight
    for i, leg in enumerate(flight.legs):
        if leg.kind == "turn" and leg.bank_deg < 90.0:
            load = 1.0 / math.cos(leg.bank_deg * DEG)
            if load > MAX_LOAD_FACTOR:
                raise InputError(
                    f"bank {leg.bank_deg:g} deg: a coordinated turn there pulls "
                    f"{load:.3g} g (1 / cos bank), beyond the {MAX_LOAD_FACTOR:g} g limit of "
                    "the flight model (turn rate g tan(bank) / V grows without bound near 90 "
                    "deg)",
                    key=f"flight.legs[{i}].bank_deg",
                )
    nyquist = 0.5 * rate
    if flight.dither.amplitude_arcsec > 0.0 and flight.dither.frequency_hz >= nyquist:
        raise InputError(
            f"dither at {flight.dither.frequency_hz:g} Hz is at or above the Nyquist frequency "
            f"{nyquist:g} Hz of the {rate:g} Hz IMU: it aliases, and no moving average of the "
            "increments removes it (raise flight.imu.sample_rate_hz or set amplitude_arcsec: 0)",
            key="flight.dither.frequency_hz",
        )
    if scenario.filter.turning_from_s >= duration:
        raise InputError(
            f"{scenario.filter.turning_from_s:g} s is at or after the end of the flight "
            f"({duration:.6g} s): the heading-error window would be empty",
            key="filter.turning_from_s",
        )
    _check_pole(plan, duration, flight.site.lat_deg)


def _check_pole(plan, duration, lat_deg):
    """The site and every point of the flight (sampled at most 1 Hz, 20,000 points) stay
    :data:`POLE_MARGIN_DEG` away from the poles."""
    limit = 90.0 - POLE_MARGIN_DEG
    if abs(lat_deg) > limit:
        raise InputError(
            f"{lat_deg:g} deg is within {POLE_MARGIN_DEG:g} deg of a pole, where the "
            "north-east-down frame of the mechanisation is singular (heading and the "
            f"transport rate tan(lat) undefined); inins navigates within +-{limit:g} deg",
            key="flight.site.lat_deg",
        )
    if duration > 20_000 * 60.0:
        return  # long flights: checked at their start only (the walk is costly)
    from inins.ekf.flight import flight_trajectory

    time = np.linspace(0.0, duration, int(min(20_000, max(2, duration))))
    lat = flight_trajectory(plan).state(time)[2][:, 0]
    worst = float(np.max(np.abs(np.degrees(lat))))
    if worst > limit:
        at = float(time[np.argmax(np.abs(lat))])
        raise InputError(
            f"the flight comes within {90.0 - worst:.3g} deg of a pole (at t = {at:.6g} s), "
            "where the north-east-down frame of the mechanisation is singular; inins "
            f"navigates within +-{limit:g} deg",
            key="flight.site.lat_deg",
        )


def observability_estimate(scenario):
    """Size of an observability analysis (covariance steps, segments, flight samples)."""
    n = 26  # the largest model; the size is an upper bound
    dt = float(scenario.update_interval_s)
    if scenario.segments:
        duration = float(sum(s.duration_s for s in scenario.segments))
        segments = len(scenario.segments)
        samples = 0.0
        keys = "segments (count, duration_s) and update_interval_s"
    elif scenario.flight is not None:
        duration, samples = _flight_size(scenario.flight)
        if samples > OBS_MAX_FLIGHT_SAMPLES:
            return _too(
                samples, OBS_MAX_FLIGHT_SAMPLES, "flight samples", "flight.sample_rate_hz", 40
            )
        segments = 0.0  # cut from the samples: at most one per sample, counted below
        keys = "flight.sample_rate_hz and the run-ekf flight's legs"
    else:
        return None  # a table-data file: its size is that of the file, already written
    steps = duration / dt if scenario.covariance else 0.0
    if steps > OBS_MAX_STEPS:
        return _too(
            steps, OBS_MAX_STEPS, "covariance steps", "update_interval_s and the durations", n
        )
    if segments > OBS_MAX_SEGMENTS:
        key = "segments" if scenario.segments else "flight.sample_rate_hz"
        return _too(segments, OBS_MAX_SEGMENTS, "segments", key, n)
    memory = (steps + 1) * (n + 1) * _F8 * 3 + samples * 40 * _F8 + segments * n * n * _F8 * 4
    return Estimate(
        int(samples), int((steps + 1) * (n + 1) * _F8 + segments * n * 4 * _F8), int(memory), keys
    )


def _flight_size(source):
    from inins.scenario.base import load_scenario
    from inins.scenario.run_ekf import RunEkfScenario

    ekf = load_scenario(RunEkfScenario, source.scenario, [], None)[0]
    if ekf.flight is None:
        raise InputError(
            "the run-ekf scenario has no flight: section", source=str(source.scenario), key="flight"
        )
    duration = float(ekf.flight.plan().duration)
    return duration, duration * float(source.sample_rate_hz)


def _too(count, limit, what, key, n):
    """An estimate that :func:`check_budget` refuses: ``count`` of ``what`` over ``limit``."""
    return Estimate(
        int(min(count, 2**62)),
        int(min(count * n * _F8, 2**62)),
        int(min(count * n * _F8 * 3, 2**62)),
        key,
        max_samples=limit,
        what=what,
    )

"""``inins import-flight``: a GNSS recording into the recorded-flight layout, checked by
single-point positioning (spec §6, §6a).

Reads RINEX observation + navigation files or the PSINS tc file
(:mod:`inins.io.rinex_obs`, :mod:`inins.io.rinex_nav`, :mod:`inins.io.psins_tc`),
writes the recorded-flight layout (:mod:`inins.io.flight_layout`: ``gnss/``,
``imu/`` and the root attributes) into ``import-flight.h5`` so that run-ekf reads it
with :func:`inins.io.flight_layout.read_flight`, and adds the SPP check of every
epoch under ``spp/``: satellites used, PDOP, residual RMS, position, velocity,
track, and the error against a known position when the scenario gives one.
"""

import numpy as np

from inins.commands import import_flight_figures
from inins.core.units import DEG
from inins.exceptions import InputError
from inins.gnss import broadcast, ephemeris, glonass, gpstime, measurements, spp, timescales
from inins.gnss import systems as systems_mod
from inins.gnss.spp_check import SppCheck
from inins.gnss.systems import LETTERS, NAMES, rinex_name
from inins.io import flight_layout, imu_units, solution_layout
from inins.io.flight_checks import checked_flight
from inins.io.flight_layout import ImuRecord, RecordedFlight
from inins.io.rinex_nav import read_nav, read_navigation
from inins.io.rinex_obs import observable, read_obs, system_observable
from inins.io.rinex_text import read_track
from inins.results import CommandResult, Series, format_table
from inins.scenario.import_flight import ImportFlightScenario

SCENARIO_MODEL = ImportFlightScenario
FIGURES = {
    "import-flight-track.png": import_flight_figures.import_flight_track,
    "import-flight-residuals.png": import_flight_figures.import_flight_residuals,
    "import-flight-sky.png": import_flight_figures.import_flight_sky,
}


def run(scenario, seed, *, sink=None, progress=None):
    """Read the recording, solve every epoch, and describe both; ``seed`` is unused."""
    if scenario.format == "solution":
        return run_solution(scenario)
    flight, approx_pos_e = read_recording(scenario)
    reference = _reference(scenario, approx_pos_e)
    changes = {"reference_pos_e": reference}
    if scenario.imu_log is not None:
        changes |= {
            "imu": imu_from_log(scenario.imu_log, progress),
            "imu_t0_week": int(flight.gnss.week[0]),
            "imu_t0_sow": float(scenario.imu_t0_sow),
        }
    flight = RecordedFlight(**{**vars(flight), **changes})
    source = str(scenario.nav_file or scenario.file)
    if scenario.format == "rinex":  # the PSINS reader checks its own flight
        flight = checked_flight(flight, scenario.obs_file)
    obs = measurements.from_record(flight.gnss)
    has_klobuchar = flight.iono_alpha is not None and flight.iono_beta is not None
    rows = measurements.ionosphere_rows(obs.signal, scenario.spp.ionosphere, has_klobuchar)
    epochs = measurements.attach_satellites(
        obs.take_rows(rows.keep), _navigation(scenario, flight), source=source
    )
    klobuchar = (flight.iono_alpha, flight.iono_beta) if rows.klobuchar else None
    iono = rows.text
    solution = spp.solve(epochs, spp_options(scenario.spp, klobuchar))
    imu_end = None if flight.imu is None else float(flight.imu.time[-1])
    check = SppCheck(
        solution,
        flight.reference_pos_e,
        flight.imu_t0_sow,
        imu_end,
        scenario.static_window_imu_s,
        epochs,
    )
    check.single_frequency_dropped = rows.dropped
    if scenario.reference_track is not None:
        check.score_track(*read_track(scenario.reference_track), scenario.reference_track_offset_s)
    datasets = {
        path: Series(value, unit, "", description)
        for path, (value, unit, description) in flight_layout.flight_arrays(flight).items()
    }
    datasets.update(_spp_datasets(check))
    used = "".join(LETTERS[k] for k in _systems(epochs.obs.prn[solution.used]))
    systems = {"systems_asked": scenario.systems, "systems_used": used}
    return CommandResult(
        command="import-flight",
        results=_spp_results(check, flight) | {"systems_used": len(used)},
        datasets=datasets,
        attrs={"": flight_layout.flight_attrs(flight), "spp": {"ionosphere": iono} | systems},
        report=report(scenario, flight, epochs, check, iono),
        warnings=(*flight.dropped, *check.warnings),
    )


def run_solution(scenario):
    """Join a GNSS solution file to an IMU log in the recorded-solution layout
    (:mod:`inins.io.solution_layout`); both files read and checked by the rules run-ekf
    applies (:mod:`inins.io.solution_checks`, :mod:`inins.io.imu_checks`, the units and
    axes of :mod:`inins.io.imu_units` but the gyro grade at rest, which is a run-ekf
    setting: the file and line named). The IMU keeps its own time axis: run-ekf's ``post.time``
    maps it to GNSS time, as from the source files. Refused: IMU and GNSS spans that
    cannot overlap (the IMU log shorter than a tenth of the GNSS span, or the other way,
    so no mapping of the IMU tick onto GNSS time would cover the drive)."""
    # imported here: the RINEX path (the default) needs neither these readers nor what
    # they import
    from inins.ekf.gnss_time import solution_on_gps_time
    from inins.io import post_inputs

    sol = solution_on_gps_time(post_inputs.read_gnss(scenario.solution_gnss), "solution_gnss")
    imu = post_inputs.read_imu(scenario.solution_imu)
    imu_units.check_against_gnss(imu, sol, scenario.solution_imu.axes)
    span_g = float(sol.time[-1] - sol.time[0])
    span_i = float(imu.time[-1] - imu.time[0])
    if span_g <= 0.0 or span_i < 0.1 * span_g or span_g < 0.1 * span_i:
        raise InputError(
            f"no overlap possible: IMU log spans {span_i:.1f} s, GNSS solutions {span_g:.1f} s",
            source=str(scenario.solution_imu.file),
            key="solution_imu",
        )
    if scenario.imu_t0_sow is not None:
        week_s = np.mod(sol.time, 604800.0)
        t0, t1 = scenario.imu_t0_sow, scenario.imu_t0_sow + span_i
        if week_s[-1] < t0 or week_s[0] > t1:
            raise InputError(
                f"no overlap: IMU {t0:.3f}-{t1:.3f} s of week, GNSS "
                f"{week_s[0]:.3f}-{week_s[-1]:.3f} s of week",
                source=str(scenario.solution_gnss.file),
                key="imu_t0_sow",
            )
    datasets = {
        path: Series(value, unit, "", description)
        for path, (value, unit, description) in solution_layout.solution_arrays(sol, imu).items()
    }
    results = dict.fromkeys(RESULT_NAMES)
    results |= {"epochs": len(sol), "imu_samples": int(imu.time.size)}
    fixed = int(np.count_nonzero(sol.q == 1))
    report = (
        f"GNSS solutions: {len(sol)} epochs over {span_g:.1f} s ({fixed} with Q = 1), "
        f"from {scenario.solution_gnss.file}\n"
        f"IMU log: {imu.time.size} samples over {span_i:.1f} s (its own time axis), "
        f"from {scenario.solution_imu.file}\n"
        "Written in the recorded-solution layout: run-ekf post.imu/post.gnss "
        "format: recorded reads it.\n"
    )
    return CommandResult(
        command="import-flight",
        results=results,
        datasets=datasets,
        attrs={"": solution_layout.solution_attrs(sol, imu)},
        report=report,
        warnings=(),
    )


RESULT_NAMES = (
    "epochs",
    "epochs_accepted",
    "single_frequency_rows_dropped",
    "err_h_median_m",
    "err_h_p95_m",
    "epochs_scored",
    "epochs_fix",
    "epochs_no_fix",
    "epochs_fault_excluded",
    "epochs_fault_detected",
    "satellites_used_median",
    "pdop_median",
    "residual_rms_median_m",
    "track_length_m",
    "speed_max_mps",
    "err_3d_rms_m",
    "err_3d_p95_m",
    "err_3d_max_m",
    "imu_samples",
    "track_length_imu_m",
    "static_horizontal_std_m",
    "static_speed_rms_mps",
    "systems_used",
)
"""Every result a run gives (null where not applicable); ``systems_used``: how many
satellite systems the fixes used (the report and the ``spp`` attributes name them and
the systems asked)."""


def declared_results(scenario):
    """``(results, truth)`` names of every run, for validating checks before it."""
    return RESULT_NAMES, ()


def estimate(scenario):
    """None: a recording is a few MB (the whole ABPO day is 3 MB of text)."""
    return None


def read_recording(scenario):
    """The :class:`RecordedFlight` of the scenario's files, and the RINEX header position
    (NaN for the PSINS file)."""
    if scenario.format == "psins-tc":
        from inins.io.psins_tc import read_psins_tc  # scipy.io only for this format

        return read_psins_tc(scenario.file), np.full(3, np.nan)
    if scenario.systems != "G" or scenario.extra_nav_files:
        return _read_multi(scenario)
    obs_file, nav = read_obs(scenario.obs_file), read_nav(scenario.nav_file)
    obs = measurements.from_code(
        obs_file.week,
        obs_file.time,
        obs_file.start,
        obs_file.prn,
        observable(obs_file, "P1"),
        observable(obs_file, "P2"),
        observable(obs_file, "C1"),
        doppler_l1=observable(obs_file, "D1"),
        snr=observable(obs_file, "S1"),
    )
    gnss = _gnss_record(obs, observable(obs_file, "L1") * measurements.LAMBDA_L1)
    flight = RecordedFlight(
        gnss=gnss,
        ephemeris=nav.records,
        imu=None,
        source=f"RINEX {obs_file.version:g} {scenario.obs_file.name}, {scenario.nav_file.name}",
        imu_t0_week=-1,
        imu_t0_sow=float("nan"),
        reference_pos_e=np.full(3, np.nan),
        iono_alpha=nav.iono_alpha,
        iono_beta=nav.iono_beta,
        dropped=obs_notes(obs_file, scenario.systems),
    )
    return flight, obs_file.approx_pos_e


def _system_name(letter):
    if letter in LETTERS:
        return f"{NAMES[LETTERS.index(letter)]} ({letter})"
    return {"I": "NavIC (I)"}.get(letter, letter)


def obs_notes(obs_file, systems):
    """Report lines for what the observation file held and was not read: records of
    systems not asked (or of no RINEX system) and event epochs, each counted."""
    notes = []
    if obs_file.skipped:
        what = ", ".join(
            f"{n} of {_system_name(name)}" for name, n in sorted(obs_file.skipped.items())
        )
        notes.append(f"satellite records not read (systems asked: {systems}): {what}")
    if obs_file.events:
        what = ", ".join(f"{n} with flag {f}" for f, n in sorted(obs_file.events.items()))
        notes.append(f"event epochs skipped (RINEX flags 2-6): {what}")
    return tuple(notes)


def _gnss_record(obs, carrier):
    """The recorded-flight GNSS datasets of observations ``obs`` with ``carrier`` (m)."""
    return flight_layout.GnssRecord(
        week=obs.week,
        time=obs.time,
        start=obs.start,
        prn=obs.prn,
        pseudorange=obs.pseudorange,
        signal=obs.signal,
        range_rate=obs.range_rate,
        sigma=obs.sigma,
        snr=obs.snr,
        carrier=carrier,
    )


def _systems(prn):
    """System indices present among satellite numbers, ascending (a count per system:
    ``np.unique`` would import numpy.ma for this)."""
    return np.flatnonzero(np.bincount(np.asarray(prn, np.int64) // 100)).tolist()


def imu_from_log(path, progress=None):
    """The IMU increments of an import-log scenario's log (body axes, SI) as an
    :class:`inins.io.flight_layout.ImuRecord`; time is the end of each sample interval
    on the log's uniform grid ``t0 + (k + 1) dt``."""
    from inins.io.logimport import LogReader
    from inins.scenario.base import load_scenario
    from inins.scenario.import_log import ImportLogScenario, import_settings

    log_scenario = load_scenario(ImportLogScenario, path, [], None)[0]
    reader = LogReader(import_settings(log_scenario))
    parts = [(c.table.dtheta, c.table.dv) for c in reader.chunks(progress)]
    extent = reader.extent
    time = extent.t0 + (np.arange(extent.n) + 1.0) * extent.dt
    return ImuRecord(
        time=time,
        dtheta=np.concatenate([p[0] for p in parts]),
        dv=np.concatenate([p[1] for p in parts]),
    )


def _reference(scenario, approx_pos_e):
    if scenario.reference_pos_e_m is not None:
        return np.array(scenario.reference_pos_e_m, dtype=float)
    if scenario.reference == "header":
        if not np.all(np.isfinite(approx_pos_e)):
            raise InputError(
                "the RINEX header has no APPROX POSITION XYZ",
                source=str(scenario.obs_file),
                key="reference",
            )
        return np.asarray(approx_pos_e, dtype=float)
    return np.full(3, np.nan)


def spp_options(section, klobuchar):
    """:class:`inins.gnss.spp.SppOptions` of the scenario's ``spp`` section."""
    index = {letter: k for k, letter in enumerate(LETTERS)}
    return spp.SppOptions(
        mask_rad=section.mask_deg * DEG,
        sigma_zenith_m=section.sigma_zenith_m,
        false_alarm=section.false_alarm,
        klobuchar=klobuchar,
        max_exclusions=section.max_exclusions,
        snr_reference_dbhz=section.snr_reference_dbhz,
        system_mask_rad=tuple((index[s], v * DEG) for s, v in section.system_mask_deg.items()),
        system_sigma_scale=tuple((index[s], v) for s, v in section.system_sigma_scale.items()),
    )


def _nav_files(scenario):
    """The scenario's navigation files read for all systems, their leap seconds checked
    against the date of their records (:func:`check_leap_seconds`)."""
    files = [
        read_navigation(path, leap_seconds=scenario.leap_seconds)
        for path in (scenario.nav_file, *scenario.extra_nav_files)
    ]
    for f in files:
        check_leap_seconds(f)
    return files


def check_leap_seconds(nav):
    """The leap seconds of a navigation file (its header's, or the scenario's) must be
    GPS - UTC at the date of its records (:data:`inins.gnss.timescales.LEAP_SECONDS`):
    a wrong value moves every GLONASS orbit by the Earth's turn in that time."""
    if nav.leap_seconds is None:
        return
    if len(nav.glonass):
        week, sow = nav.glonass["week"], nav.glonass["toe"] - nav.leap_seconds
    else:
        gps = nav.records[(nav.records["prn"] < 100) | (nav.records["prn"] // 100 == 2)]
        if not len(gps):
            return
        week, sow = gps["week"], gps["toe"]
    k = len(week) // 2
    expected = timescales.leap_seconds_at(int(week[k]), float(sow[k]))
    if expected is None or expected == nav.leap_seconds:
        return
    date = str(gpstime.to_datetime64(int(week[k]), float(sow[k])))[:10]
    where = "the header's LEAP SECONDS" if nav.leap_line else "leap_seconds"
    problem = (
        f"{where} is {nav.leap_seconds} s, but GPS - UTC was {expected} s on {date}, the "
        "date of the records of {file}(IERS Bulletin C): a wrong value turns every GLONASS "
        "orbit with the Earth by that time"
    )
    if nav.leap_line:  # the file's header is wrong
        raise InputError(problem.format(file=""), source=nav.path, line=nav.leap_line)
    raise InputError(problem.format(file=f"{nav.path} "), key="leap_seconds")


def _navigation(scenario, flight):
    """Broadcast data for the SPP check: the flight's GPS sets, or every enabled system's
    sets of the navigation files (GLONASS state vectors are not in the flight layout)."""
    if scenario.format != "rinex" or (scenario.systems == "G" and not scenario.extra_nav_files):
        return ephemeris.from_columns(flight.ephemeris)
    return _enabled(scenario, _nav_files(scenario))[0]


def _enabled(scenario, files):
    """(Navigation of the enabled systems, files); InputError for an enabled system that no
    navigation file carries."""
    nav = broadcast.merge([broadcast.from_records(f.records, f.glonass) for f in files])
    have = {LETTERS[s] for s in nav.systems}
    for letter in scenario.systems:
        if letter not in have:
            raise InputError(
                f"no navigation record of system {letter} ({NAMES[LETTERS.index(letter)]}) in "
                f"the navigation files; they carry {''.join(sorted(have)) or 'none'}",
                source=", ".join(f.path for f in files),
                key="systems",
            )
    keep = np.isin(nav.kepler.prn // 100, [LETTERS.index(s) for s in scenario.systems])
    glo = nav.glonass if "R" in scenario.systems else glonass.empty()
    return broadcast.Navigation(kepler=nav.kepler.take(keep), glonass=glo), files


def _read_multi(scenario):
    """A multi-system RINEX recording (``systems``) as a RecordedFlight."""
    obs_file = read_obs(scenario.obs_file, scenario.systems)
    if len(obs_file.prn) == 0:
        raise InputError(
            f"no observation of the enabled systems {scenario.systems}",
            source=str(scenario.obs_file),
            key="systems",
        )
    nav, files = _enabled(scenario, _nav_files(scenario))
    channel = broadcast.glonass_channels(nav, obs_file.prn)
    for slot, k in obs_file.glonass_channels.items():
        channel[obs_file.prn == 100 + slot] = k
    observed = {LETTERS[s] for s in _systems(obs_file.prn)}
    doppler = system_observable(obs_file, "D1")
    lost = (obs_file.prn // 100 == 1) & np.isnan(channel) & np.isfinite(doppler)
    if lost.any():
        names = " ".join(sorted({rinex_name(p) for p in obs_file.prn[lost].tolist()}))
        raise InputError(
            f"GLONASS frequency channel missing for {names}: neither the header's GLONASS "
            "SLOT / FRQ # nor a navigation set gives it (a Doppler needs it)",
            source=str(scenario.obs_file),
            key="extra_nav_files",
        )
    obs = measurements.from_code(
        obs_file.week,
        obs_file.time,
        obs_file.start,
        obs_file.prn,
        system_observable(obs_file, "P1"),
        system_observable(obs_file, "P2"),
        system_observable(obs_file, "C1"),
        doppler_l1=doppler,
        snr=system_observable(obs_file, "S1"),
        channel=channel,
    )
    wavelength = systems_mod.l1_wavelength(obs.prn, channel)
    gnss = _gnss_record(obs, system_observable(obs_file, "L1") * wavelength)
    names = ", ".join(p.name for p in (scenario.nav_file, *scenario.extra_nav_files))
    notes = obs_notes(obs_file, scenario.systems)
    absent = [s for s in scenario.systems if s not in observed]
    if absent:
        notes += (
            f"systems asked {scenario.systems}: no "
            f"{', '.join(_system_name(s) for s in absent)} observation in the file, solved "
            f"with {''.join(s for s in scenario.systems if s in observed)}",
        )
    flight = RecordedFlight(
        gnss=gnss,
        ephemeris=nav_records(nav),
        imu=None,
        source=f"RINEX {obs_file.version:g} {scenario.obs_file.name} "
        f"({''.join(s for s in scenario.systems if s in observed)}), {names}",
        imu_t0_week=-1,
        imu_t0_sow=float("nan"),
        reference_pos_e=np.full(3, np.nan),
        iono_alpha=next((f.iono_alpha for f in files if f.iono_alpha is not None), None),
        iono_beta=next((f.iono_beta for f in files if f.iono_beta is not None), None),
        glonass=flight_layout.glonass_columns(nav.glonass),
        dropped=notes,
    )
    return flight, obs_file.approx_pos_e


def nav_records(nav):
    """Structured array of the Keplerian sets of a Navigation (the flight layout's table)."""
    from dataclasses import fields as dc_fields

    out = np.zeros(len(nav.kepler), dtype=[(f[0], f[1]) for f in flight_layout.EPHEMERIS_FIELDS])
    for f in dc_fields(nav.kepler):
        out[f.name] = getattr(nav.kepler, f.name)
    return out


def _spp_results(check, flight):
    """The check's figures and the IMU sample count."""
    return check.results() | {"imu_samples": 0 if flight.imu is None else len(flight.imu.time)}


def _spp_datasets(check):
    """The ``spp/`` datasets of the check (:class:`inins.gnss.spp_check.SppCheck`)."""
    s = check.sol
    out = {
        "spp/time": Series(s.time, "s", "", "receive time tag, GPS seconds of week"),
        "spp/pos_e": Series(s.pos, "m", "e", "antenna position, ECEF (NaN: no fix)"),
        "spp/lla": Series(check.lla(), "rad, rad, m", "", "latitude, longitude, height"),
        "spp/vel_n": Series(check.track.vel_n, "m/s", "n", "range-rate velocity, NED"),
        "spp/clock_m": Series(s.clock, "m", "", "receiver clock bias c dt_rx"),
        "spp/drift_mps": Series(s.drift, "m/s", "", "receiver clock drift c dt_rx_dot"),
        "spp/status": Series(
            s.status.astype(np.int8),
            "1",
            "",
            "0 fix, 1 no fix, 2 fault excluded, 3 fault detected, 4 not converged",
        ),
        "spp/satellites_used": Series(s.n_used, "1", "", "satellites in the fix"),
        "spp/pdop": Series(s.pdop, "1", "", "position dilution of precision"),
        "spp/residual_rms": Series(s.residual_rms, "m", "", "RMS of the used residuals"),
        "spp/excluded_prn": Series(s.excluded_prn, "1", "", "satellite excluded, 0 none"),
        "spp/n_excluded": Series(s.n_excluded, "1", "", "satellites excluded in the epoch"),
        "spp/distance": Series(check.track.distance, "m", "", "path length so far"),
    }
    if check.track_reference is not None:
        out["spp/reference_pos_e"] = Series(
            check.track_reference, "m", "e", "reference trajectory at each epoch (NaN: outside)"
        )
    if s.isb_systems:
        out["spp/isb_m"] = Series(
            s.isb,
            "m",
            "",
            "inter-system bias of each further system ("
            + ", ".join(NAMES[k] for k in s.isb_systems)
            + "), NaN where not estimated",
        )
    geometry = check.row_geometry()
    if geometry is not None:  # the sky plot, the residual figure
        el, az, epoch = geometry
        out |= {
            "spp/row_elevation": Series(el, "rad", "", "elevation from the fix (NaN: no fix)"),
            "spp/row_azimuth": Series(az, "rad", "", "azimuth from the fix, from north"),
            "spp/row_prn": Series(check.epochs.obs.prn, "1", "", "satellite of each row"),
            "spp/row_epoch": Series(epoch, "1", "", "epoch"),
            "spp/residual": Series(s.residual, "m", "", "pseudorange residual (measured - model)"),
            "spp/row_used": Series(s.used.astype(np.int8), "1", "", "row used in the fix"),
        }
    if check.error_ned is not None:
        out["spp/error_ned"] = Series(
            check.error_ned, "m", "n", "position error against the reference, NED"
        )
    return out


def report(scenario, flight, epochs, check, iono):
    """Report body: the recording as read, the SPP check, errors and track."""
    r = check.results()
    s = check.sol
    g = flight.gnss
    span = (s.time[-1] - s.time[0]) if len(s.time) else 0.0
    used = "".join(LETTERS[k] for k in _systems(epochs.obs.prn[s.used]))
    lines = [
        f"source: {flight.source}",
        f"systems: asked {scenario.systems}, used by the fixes {used or 'none'}",
        f"{r['epochs']} epochs over {span:g} s, {len(g.prn)} satellite measurements, "
        f"{len(flight.ephemeris)} broadcast ephemeris sets",
        f"ionosphere: {iono}",
        f"SPP: mask {scenario.spp.mask_deg:g} deg, weights sigma/sin(el) with "
        f"{scenario.spp.sigma_zenith_m:g} m at zenith, Saastamoinen troposphere, residual "
        f"test at false-alarm {scenario.spp.false_alarm:g}",
    ]
    if flight.dropped:
        lines.append("read but not used (counted):")
        lines += [f"  {note}" for note in flight.dropped]
    dropped = dict(zip(epochs.dropped_prn.tolist(), epochs.dropped_count.tolist(), strict=True))
    if dropped:
        lines.append(
            "measurements without a healthy ephemeris (dropped): "
            + ", ".join(f"{rinex_name(p)} x{c}" for p, c in sorted(dropped.items()))
        )
    if flight.imu is not None:
        imu = flight.imu
        lines.append(
            f"IMU: {len(imu.time)} samples, t {imu.time[0]:g}-{imu.time[-1]:g} s; "
            f"IMU t = 0 at GPS week {flight.imu_t0_week}, "
            f"{flight.imu_t0_sow:.3f} s of week"
        )
    rows = [
        [name, value]
        for name, value in (
            ("epochs with a fix", r["epochs_fix"]),
            ("no fix (< 4 satellites)", r["epochs_no_fix"]),
            ("a fault excluded", r["epochs_fault_excluded"]),
            ("a fault detected, not isolated", r["epochs_fault_detected"]),
            ("satellites used (median)", r["satellites_used_median"]),
            ("PDOP (median)", r["pdop_median"]),
            ("residual RMS (median)", r["residual_rms_median_m"]),
            ("track length", r["track_length_m"]),
            ("track during the IMU", r["track_length_imu_m"]),
            ("highest speed", r["speed_max_mps"]),
        )
    ]
    lines += [
        "",
        "single-point positioning of every epoch",
        format_table(rows, ["", "value"], fmt=".5g"),
    ]
    excluded = sorted(set(s.excluded_prn[s.excluded_prn > 0].tolist()))
    if excluded:
        lines.append(
            "satellites excluded by the residual test: "
            + ", ".join(rinex_name(p) for p in excluded)
        )
    if s.isb_systems:
        per = ", ".join(
            f"{NAMES[k]} {np.nanmedian(s.isb[:, j]):.2f} m"
            if np.isfinite(s.isb[:, j]).any()
            else f"{NAMES[k]} not estimated"
            for j, k in enumerate(s.isb_systems)
        )
        used = epochs.obs.prn[s.used] // 100
        count = ", ".join(
            f"{NAMES[k]} {np.count_nonzero(used == k)}" for k in _systems(epochs.obs.prn)
        )
        lines.append(f"inter-system biases (median, against the first system): {per}")
        lines.append(f"measurements used per system: {count}")
    if r["single_frequency_rows_dropped"]:
        lines.append(
            f"single-frequency rows dropped (no ionosphere correction): "
            f"{r['single_frequency_rows_dropped']}"
        )
    if r["err_h_median_m"] is not None:
        lines += [
            "",
            f"against the reference trajectory: {r['epochs_scored']} accepted fixes of "
            f"{check.track_inside} epochs inside it; horizontal error median "
            f"{r['err_h_median_m']:.2f} m, 95th percentile {r['err_h_p95_m']:.2f} m",
        ]
    if check.error_ned is not None:
        ned = check.error_ned[np.isfinite(check.error_ned[:, 0])]
        rms = np.sqrt(np.mean(ned**2, axis=0))
        lines += [
            "",
            f"against the reference position {np.round(flight.reference_pos_e, 3)} m "
            f"(ECEF): 3D RMS {r['err_3d_rms_m']:.3f} m, 95th percentile "
            f"{r['err_3d_p95_m']:.3f} m, max {r['err_3d_max_m']:.3f} m; RMS north "
            f"{rms[0]:.3f}, east {rms[1]:.3f}, down {rms[2]:.3f} m",
        ]
    if r["static_horizontal_std_m"] is not None:
        w = scenario.static_window_imu_s
        lines += [
            "",
            f"standing (IMU t {w[0]:g}-{w[1]:g} s): horizontal scatter "
            f"{r['static_horizontal_std_m']:.3f} m (std), range-rate speed "
            f"{r['static_speed_rms_mps']:.3f} m/s RMS",
        ]
    return "\n".join(lines)

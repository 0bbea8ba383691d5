"""``inins noise``: noise characterisation of an IMU at rest.

The record (a lab log in any import-log format, a table-data file, or a simulated
static hold) streams chunk by chunk through
:class:`inins.calibration.allan.AllanAccumulator` (overlapping Allan deviation on an
octave or denser tau grid, six sensors at once) while block means are kept to find
motion and flat (saturated or stuck) sensors. Motion is refused, or cut away (a
second pass over the longest static part). Each sensor axis gets the IEEE 952
five-term fit (:func:`inins.calibration.allan.fit_terms`) with intervals, the terms
in continuous SI, lab and discrete per-sample units, and the fitted model is written
as the ``imu:`` block of simulate-table, the ``filter.noise:`` block of run-ekf and a
Kalibr ``imu.yaml`` (:data:`FILES`). Scenario keys: :mod:`inins.scenario.noise`.

Spec §10 reads each term off its slope (N at tau = 1 s, K at 3 s, B = min / 0.664); the
fit does the same wherever one term dominates and keeps the read-offs consistent where
terms overlap, and it says over which tau each term was seen.
"""

import math
from dataclasses import dataclass

import numpy as np

from inins.calibration import allan
from inins.commands import noise_report
from inins.exceptions import InputError
from inins.scenario.noise import NoiseScenario

SCENARIO_MODEL = NoiseScenario
CHANNELS = noise_report.CHANNELS
MIN_SAMPLES = 256
"""Shortest record accepted."""


def _figure(result, path):
    from inins.commands.noise_figures import deviation_figure

    deviation_figure(result, path)


FIGURES = {"noise.png": _figure}
FILES = {
    "noise-imu.yaml": lambda result: result.attrs["noise"]["scenario_block_yaml"],
    "kalibr-imu.yaml": lambda result: result.attrs["noise"]["kalibr_yaml"],
}
"""Text files written beside the results: the sensor error-model blocks."""


def declared_results(scenario):
    """Names of the results a run gives."""
    names = ["samples", "duration_s", "sample_rate_hz", "static_start_s", "static_end_s"]
    for ch in CHANNELS:
        sensor = ch.split("_")[0]
        for term in allan.TERMS:
            unit = noise_report.LAB[sensor][term][0]
            base = f"{ch}_{noise_report.SHORT[sensor][term]}_{unit}"
            names += [base, f"{base}_lo", f"{base}_hi"]
        names += [f"{ch}_reproduces", f"{ch}_model_p"]
    return tuple(names), ()


# --------------------------------------------------------------------------- reading


@dataclass
class Source:
    """Chunks of increments (rad, m/s) of the record: ``chunks(start, stop)`` yields
    (k0, dtheta, dv) for samples [start, stop); ``n`` and ``dt`` are known after the
    first full pass (a log) or at once (a record). ``lat`` (rad) where the site is
    known; ``pulse`` the declared pulse weights (gyro rad, accel m/s; body axes) of a
    counting sensor, else None; ``keys`` the scenario keys of the gyro and accelerometer
    units (named by a unit check)."""

    name: str
    n: int | None
    dt: float | None
    chunks: object
    lat: float | None = None
    pulse: tuple | None = None
    keys: tuple = ("gyro.unit", "accel.unit")


def open_source(scenario, seed, progress=None):
    """The :class:`Source` of the scenario's input."""
    if scenario.log is not None:
        return _log_source(scenario, progress)
    from inins.commands._table import load_record

    record, _ = load_record(scenario.data, scenario.simulate, seed, progress)

    def chunks(start=0, stop=None):
        yield from record.imu_chunks(start, stop)

    name = str(scenario.data) if scenario.data is not None else "simulate"
    key = "data" if scenario.data is not None else "simulate"
    return Source(name, record.n_samples, record.dt, chunks, float(record.lla[0]), None, (key, key))


def _log_source(scenario, progress):
    from inins.io.logimport import LogReader
    from inins.scenario.import_log import ImportLogScenario, import_settings

    site = scenario.site
    log = scenario.log.model_dump()
    log["file"] = str(scenario.log.file)
    spec = {
        "log": log,
        "gyro": scenario.gyro.model_dump(exclude_none=True),
        "accel": scenario.accel.model_dump(exclude_none=True),
        "body_axes": list(scenario.body_axes),
        "site": {
            "lat_deg": 0.0 if site.lat_deg is None else site.lat_deg,
            "lon_deg": 0.0 if site.lon_deg is None else site.lon_deg,
            "height_m": 0.0 if site.height_m is None else site.height_m,
        }
        if scenario.log.format != "psins"
        else site.model_dump(exclude_none=True),
    }
    if scenario.log.columns is not None and scenario.log.columns.table_angles is not None:
        raise InputError(
            "noise reads a static record; table angles are not used (remove the key)",
            key="log.columns.table_angles",
        )
    cfg = import_settings(ImportLogScenario.model_validate(spec))
    source = Source(str(scenario.log.file), None, None, None)
    reader = LogReader(cfg)
    if reader.dt is None:  # from the time column: read the first chunk
        next(iter(reader.chunks()), None)
    source.dt = reader.dt
    if site.lat_deg is not None or scenario.log.format == "psins":
        source.lat = float(reader.resolved.lla[0])
    source.pulse = _declared_pulses(reader.resolved, scenario.body_axes)

    def chunks(start=0, stop=None):
        reader = LogReader(cfg)
        k = 0
        for part in reader.chunks(progress):
            p = part.table.dtheta.shape[0]
            lo, hi = max(start - k, 0), p if stop is None else min(p, stop - k)
            if hi > lo:
                yield k + lo, part.table.dtheta[lo:hi], part.table.dv[lo:hi]
            k += p
            if stop is not None and k >= stop:
                break

    source.chunks = chunks
    return source


def _declared_pulses(resolved, body_axes):
    """Pulse weights (gyro rad, accel m/s) of a counting log in body axes, or None."""
    pulses = []
    for pw in (resolved.gyro_pw, resolved.accel_pw):
        if pw is None:
            return None
        pw = np.broadcast_to(np.asarray(pw, float), (3,))
        pulses.append(np.array([pw["xyz".index(a[-1])] for a in body_axes]))
    return tuple(pulses)


# --------------------------------------------------------------------------- run


@dataclass(frozen=True)
class Pass:
    """What one pass over the record gave."""

    deviation: allan.Deviation
    blocks: np.ndarray
    spread: np.ndarray
    block_n: int
    n: int
    record: np.ndarray | None


def _pass(source, dt, ms, cfg, start, stop, keep):
    block_n = max(1, round(cfg.static.block_s / dt))
    expected = (source.n if stop is None else stop) - start if source.n is not None else 0
    acc = allan.AllanAccumulator(
        dt,
        6,
        ms,
        cfg.deviation.offsets,
        block_n=block_n,
        monotone_alpha=True,
        expected_rows=expected,
    )
    kept = []
    sat = _saturation_limits(cfg, dt)
    n = 0
    for k0, dtheta, dv in source.chunks(start, stop):
        if sat is not None:
            hit = np.abs(np.hstack([dtheta, dv])) >= sat
            if hit.any():
                row, col = np.argwhere(hit)[0]
                raise InputError(
                    f"{CHANNELS[col]} saturated at sample {k0 + row} "
                    f"({(k0 + row) * dt:.6g} s): at its range (static.*_range_*)",
                    source=source.name,
                )
        bad = acc.add(dtheta, dv)
        if bad >= 0:
            raise InputError(f"non-finite increments at sample {k0 + bad}", source=source.name)
        n += dtheta.shape[0]
        if keep:
            if n > cfg.deviation.in_memory_limit:
                raise InputError(
                    f"the record exceeds {cfg.deviation.in_memory_limit} samples, the "
                    "most mdev/totdev hold in memory; set deviation.mdev and "
                    "deviation.totdev false, or raise deviation.in_memory_limit",
                    key="deviation.in_memory_limit",
                )
            kept.append(np.hstack([dtheta, dv]))
    dev = acc.finish() if n else None
    record = np.vstack(kept) if keep and kept else None
    blocks, spread = acc.blocks()
    return Pass(dev, blocks, spread / dt, block_n, n, record)


def _saturation_limits(cfg, dt):
    from inins.core.units import DEG, G0

    s = cfg.static
    if s.gyro_range_dps is None and s.accel_range_g is None:
        return None
    g = math.inf if s.gyro_range_dps is None else 0.999 * s.gyro_range_dps * DEG * dt
    a = math.inf if s.accel_range_g is None else 0.999 * s.accel_range_g * G0 * dt
    return np.array([g, g, g, a, a, a])


def run(scenario, seed, *, sink=None, progress=None):
    """Characterise the noise of the scenario's static record."""
    cfg = scenario
    source = open_source(scenario, seed, progress)
    dt = source.dt
    big = allan.tau_grid(1 << 40, cfg.deviation.per_octave, cfg.deviation.offsets)
    start, stop = _window(cfg, source.n, dt)
    keep = cfg.deviation.mdev or cfg.deviation.totdev
    first = _pass(source, dt, big, cfg, start, stop, keep)
    if cfg.static.window_s is not None and first.n < MIN_SAMPLES:
        raise InputError(
            f"static.window_s {list(cfg.static.window_s)} holds {first.n} samples",
            key="static.window_s",
        )
    n_total = first.n
    warnings = []
    _flat(first, dt, start, source.name, cfg)
    moving = _motion(first, cfg, dt)
    run_pass = first
    if moving.any():
        spans = _spans(moving, first.block_n * dt, start * dt)
        listed = ", ".join(f"{a:.6g}-{b:.6g} s" for a, b in spans[:5])
        if cfg.static.motion == "refuse":
            raise InputError(
                f"the record moves ({len(spans)} interval(s): {listed}); noise needs a "
                "sensor at rest: set static.motion: cut to keep the longest static part, "
                "or static.window_s",
                source=source.name,
                key="static.motion",
            )
        a, b = _longest_static(moving, first.block_n, round(cfg.static.guard_s / dt))
        if b <= a:
            raise InputError("no static part left after cutting the motion", source=source.name)
        start, stop = start + a, start + b
        warnings.append(
            f"motion at {listed}: cut to the longest static part, "
            f"{start * dt:.6g} s to {stop * dt:.6g} s ({(stop - start) * dt:.6g} s)"
        )
        run_pass = _pass(source, dt, big, cfg, start, stop, keep)
    n = run_pass.n
    if n < MIN_SAMPLES:
        raise InputError(
            f"the static record has {n} samples; noise needs at least {MIN_SAMPLES}",
            source=source.name,
        )
    _units(run_pass, dt, source)
    dev = _trim(run_pass.deviation, n, cfg)
    if cfg.deviation.max_tau_s is not None and dev.tau[-1] < cfg.deviation.max_tau_s * (1 - 1e-9):
        raise InputError(
            f"the static record ({n * dt:.6g} s) is too short for tau up to "
            f"{cfg.deviation.max_tau_s:g} s: it needs at least 4 tau "
            f"({4 * cfg.deviation.max_tau_s:g} s)",
            source=source.name,
            key="deviation.max_tau_s",
        )
    extra = {}
    if keep:
        kinds = [k for k in ("mdev", "totdev") if getattr(cfg.deviation, k)]
        extra = allan.deviations(
            run_pass.record, dt, kinds=kinds, per_octave=cfg.deviation.per_octave
        )
    fits = [_fit(dev, c, cfg) for c in range(6)]
    rejected = [ch for ch, f in zip(CHANNELS, fits, strict=True) if not f.reproduces]
    if rejected:
        warnings.append(
            f"the five-term model does not reproduce the curve of {', '.join(rejected)} "
            "(chi-square p < 0.01): noise-imu.yaml says so; read its terms as a fit the "
            "curve rejects"
        )
    return noise_report.build(
        cfg,
        dev,
        extra,
        fits,
        dt,
        n,
        n_total,
        (start * dt, (start + n) * dt),
        warnings,
        source.pulse,
    )


def _units(p, dt, source):
    """Bad input when the record at rest cannot be what its units say: the mean specific
    force is not gravity, or the mean rate is not what a gyro of its noise reads at rest
    (:mod:`inins.calibration.static_check`), naming the likely unit mistake."""
    from inins.calibration import static_check

    if p.blocks.shape[0] == 0:
        return
    mean = np.median(p.blocks, axis=0)
    arw = float(np.max(np.median(p.spread[:, :3], axis=0))) * math.sqrt(dt)
    for problem, key in (
        (static_check.gravity_problem(mean[3:], source.lat), source.keys[1]),
        (static_check.rate_problem(mean[:3], arw, source.lat), source.keys[0]),
    ):
        if problem:
            raise InputError(problem, source=source.name, key=key)


def _window(cfg, n, dt):
    """Sample range [start, stop) of static.window_s (stop None: to the end)."""
    w = cfg.static.window_s
    if w is None:
        return 0, n
    a, b = round(w[0] / dt), round(w[1] / dt)
    if n is not None:
        b = min(n, b)
        if b - a < MIN_SAMPLES:
            raise InputError(
                f"static.window_s {list(w)} holds {max(b - a, 0)} samples of the "
                f"{n * dt:.6g}-s record",
                key="static.window_s",
            )
    return a, b


def _trim(dev, n, cfg):
    """Keep tau with at least 4 tau in the record (m <= n/4) and up to max_tau_s."""
    keep = (dev.m * 4 <= n) & (dev.terms > 0)
    if cfg.deviation.max_tau_s is not None:
        keep &= dev.tau <= cfg.deviation.max_tau_s * (1 + 1e-9)
    if not keep.any():
        raise InputError(f"the record ({n} samples) is too short for any tau")
    return allan.Deviation(
        dev.kind,
        dev.tau[keep],
        dev.m[keep],
        dev.dev[keep],
        dev.edf[keep],
        dev.alpha[keep],
        dev.terms[keep],
    )


def _fit(dev, c, cfg):
    f = cfg.fit
    sel = dev.tau >= f.min_tau_s
    if f.max_tau_s is not None:
        sel &= dev.tau <= f.max_tau_s
    sub = allan.Deviation(
        dev.kind,
        dev.tau[sel],
        dev.m[sel],
        dev.dev[sel],
        dev.edf[sel],
        dev.alpha[sel],
        dev.terms[sel],
    )
    if sub.tau.size < 2:
        raise InputError("fewer than 2 tau in the fit range", key="fit.min_tau_s")
    fit = allan.fit_terms(sub, c, confidence=f.confidence, use=tuple(f.terms))
    model = np.full(dev.tau.size, np.nan)
    inside = np.zeros(dev.tau.size, dtype=bool)
    model[sel], inside[sel] = fit.model, fit.inside
    names = {t.name for t in fit.terms}
    terms = list(fit.terms) + [
        allan.Term(t, 0.0, 0.0, 0.0, None) for t in allan.TERMS if t not in names
    ]
    terms.sort(key=lambda t: allan.TERMS.index(t.name))
    return allan.Fit(tuple(terms), model, inside, fit.chi2_per_dof, fit.dof, fit.p_value)


def _motion(p, cfg, dt):

    if p.blocks.shape[0] < 3:
        return np.zeros(p.blocks.shape[0], dtype=bool)
    center = np.median(p.blocks, axis=0)
    return np.any(np.abs(p.blocks - center) > _limits(p, cfg), axis=1)


def _limits(p, cfg):
    """Distance from the median block mean beyond which a block moves, per channel."""
    from inins.core.units import DPH, UG

    center = np.median(p.blocks, axis=0)
    scale = 1.4826 * np.median(np.abs(p.blocks - center), axis=0)
    s = cfg.static
    floor = np.array([s.motion_floor_dph * DPH] * 3 + [s.motion_floor_ug * UG] * 3)
    return np.maximum(s.motion_sigma * scale, floor)


def _flat(p, dt, start, name, cfg):
    """Refuse a channel with no output at all, or stuck at one value far from its median
    for a whole block while it is noisy elsewhere (saturated). A pulse-output sensor
    may give no pulse in a block at rest: a flat block at the median is not refused."""
    if p.spread.shape[0] < 3:
        return
    dead = np.all(p.spread == 0, axis=0) & np.all(p.blocks == 0, axis=0)
    if dead.any():
        raise InputError(
            f"{CHANNELS[int(np.argmax(dead))]} gives no output (every increment is zero)",
            source=name,
        )
    still = np.all(p.spread == 0, axis=0) & np.all(p.blocks == p.blocks[0], axis=0)
    if still.any():
        stuck = ", ".join(c for c, s in zip(CHANNELS, still, strict=True) if s)
        raise InputError(
            f"{stuck} give the same value at every sample (stuck or not connected): no "
            "noise to characterise",
            source=name,
        )
    typical = np.median(p.spread, axis=0)
    center = np.median(p.blocks, axis=0)
    limit = _limits(p, cfg)
    flat = (p.spread <= 1e-9 * typical) & (typical > 0) & (np.abs(p.blocks - center) > limit)
    if flat.any():
        b, c = np.argwhere(flat)[0]
        t = (start + b * p.block_n) * dt
        raise InputError(
            f"{CHANNELS[c]} is stuck far from its median (saturated) in the block at "
            f"{t:.6g} s ({int(flat[:, c].sum())} block(s) in all)",
            source=name,
        )


def _spans(moving, block_s, t0):
    spans, k = [], 0
    while k < moving.size:
        if moving[k]:
            j = k
            while j < moving.size and moving[j]:
                j += 1
            spans.append((t0 + k * block_s, t0 + j * block_s))
            k = j
        else:
            k += 1
    return spans


def _longest_static(moving, block_n, guard):
    """Sample range [a, b) of the longest run of static blocks, widened moving blocks."""
    bad = np.zeros(moving.size * block_n, dtype=bool)
    for k in np.nonzero(moving)[0]:
        bad[max(0, k * block_n - guard) : (k + 1) * block_n + guard] = True
    best, a = (0, 0), None
    for i, b in enumerate(np.append(bad, True)):
        if not b and a is None:
            a = i
        elif b and a is not None:
            if i - a > best[1] - best[0]:
                best = (a, i)
            a = None
    return best


def estimate(scenario):
    """Memory is flat in the record length except for mdev/totdev (bounded by a key)."""
    return None

"""Results, datasets, report and the sensor error-model blocks of ``inins noise``.

Units, stated twice
-------------------
Every term is given in the continuous-time SI unit the filters use, in the lab unit,
and in the discrete per-sample form at the log's rate fs = 1/dt:

==================  ==================  ==============  ===================================
term                SI (gyro / accel)   lab             discrete, per sample at fs
==================  ==================  ==============  ===================================
quantization Q      rad / m/s           arcsec / ug*s   angle error sd Q; pulse sqrt(12) Q
random walk N       rad/sqrt(s),        deg/sqrt(h),    increment sd N sqrt(dt); rate sd
                    m/s/sqrt(s)         ug/sqrt(Hz)     N / sqrt(dt)
bias instability B  rad/s / m/s^2       deg/h / ug      flat Allan deviation 0.664 B;
                                                        Gauss-Markov sd and time (below)
rate random walk K  rad/s/sqrt(s),      deg/h/sqrt(h),  bias step sd K sqrt(dt) per sample
                    m/s^2/sqrt(s)       ug/sqrt(h)
rate ramp R         rad/s^2 / m/s^3     deg/h/h, ug/h   R dt per sample
==================  ==================  ==============  ===================================

deg/sqrt(h) = (pi/180)/60 rad/sqrt(s); ug/sqrt(Hz) = 9.80665e-6 m/s^2/sqrt(Hz) = the
same number in m/s/sqrt(s); deg/h/sqrt(h) = (pi/180)/3600/60 rad/s/sqrt(s).

The simulate-table model has no flicker bias: the bias instability is written as the
first-order Gauss-Markov bias whose Allan deviation peaks at 0.664 B at the tau of the
curve's minimum (:func:`gauss_markov`).
"""

import math

import numpy as np

from inins.calibration import allan
from inins.core.units import ARCSEC, DEG_RTH, DPH, HOUR, UG, UG_RTHZ, UG_S
from inins.results import CommandResult, Series, format_table

CHANNELS = tuple(f"{s}_{a}" for s in ("gyro", "accel") for a in "xyz")
"""The six channels, in the order of the accumulator's columns."""
SHORT = {
    "gyro": {
        "quantization": "q",
        "random_walk": "arw",
        "bias_instability": "bi",
        "rate_random_walk": "rrw",
        "rate_ramp": "ramp",
    },
    "accel": {
        "quantization": "q",
        "random_walk": "vrw",
        "bias_instability": "bi",
        "rate_random_walk": "rrw",
        "rate_ramp": "ramp",
    },
}
"""Short name of each term in the result names."""
LAB = {
    "gyro": {
        "quantization": ("arcsec", ARCSEC, "rad"),
        "random_walk": ("deg_rth", DEG_RTH, "rad/sqrt(s)"),
        "bias_instability": ("dph", DPH, "rad/s"),
        "rate_random_walk": ("dph_rth", DPH / math.sqrt(HOUR), "rad/s/sqrt(s)"),
        "rate_ramp": ("dph_per_h", DPH / HOUR, "rad/s^2"),
    },
    "accel": {
        "quantization": ("ug_s", UG_S, "m/s"),
        "random_walk": ("ug_rthz", UG_RTHZ, "m/s/sqrt(s)"),
        "bias_instability": ("ug", UG, "m/s^2"),
        "rate_random_walk": ("ug_rth", UG / math.sqrt(HOUR), "m/s^2/sqrt(s)"),
        "rate_ramp": ("ug_per_h", UG / HOUR, "m/s^3"),
    },
}
"""Lab unit name, SI per lab unit, SI unit name, of each term."""


DISPLAY = {
    "arcsec": "arcsec",
    "deg_rth": "deg/sqrt(h)",
    "dph": "deg/h",
    "dph_rth": "deg/h/sqrt(h)",
    "dph_per_h": "deg/h/h",
    "ug_s": "ug*s",
    "ug_rthz": "ug/sqrt(Hz)",
    "ug": "ug",
    "ug_rth": "ug/sqrt(h)",
    "ug_per_h": "ug/h",
}
"""Lab unit as printed."""


def _gm_peak():
    """Peak over tau of the Allan deviation of a unit first-order Gauss-Markov bias,
    and the tau/T of the peak (IEEE Std 952-1997 Table C.2 form of the correlated noise)."""
    u = np.geomspace(0.05, 50.0, 20001)
    var = (2.0 / u) * (1.0 - (3.0 - 4.0 * np.exp(-u) + np.exp(-2.0 * u)) / (2.0 * u))
    k = int(np.argmax(var))
    return math.sqrt(var[k]), float(u[k])


GM_PEAK, GM_PEAK_TAU = _gm_peak()
"""A Gauss-Markov bias of sd s and time T has its largest Allan deviation
``GM_PEAK s`` (0.62) at ``tau = GM_PEAK_TAU T`` (1.89 T)."""


def gauss_markov(b, tau_min, corr_time=None):
    """Gauss-Markov bias (sd, correlation time) standing for bias instability b.

    Its Allan deviation peaks at ``0.664 b`` (the flat level of the flicker bias) at
    ``tau_min``, the tau of the curve's minimum, unless ``corr_time`` is given.
    """
    t = tau_min / GM_PEAK_TAU if corr_time is None else corr_time
    return allan.BIAS_FACTOR * b / GM_PEAK, t


def term_rows(fits, sensor, dt):
    """Report rows of the five terms of the three axes of a sensor."""
    rows = []
    for a, fit in enumerate(fits):
        for t in fit.terms:
            unit, factor, si = LAB[sensor][t.name]
            rng = "-" if t.tau_range is None else f"{t.tau_range[0]:.4g}-{t.tau_range[1]:.4g}"
            rows.append(
                [
                    f"{sensor} {'xyz'[a]}",
                    t.name,
                    f"{t.value / factor:.4g}",
                    f"[{t.lo / factor:.4g}, {t.hi / factor:.4g}]",
                    DISPLAY[unit],
                    f"{t.value:.4g} {si}",
                    _discrete(t, sensor, dt),
                    rng,
                ]
            )
    return rows


def _discrete(t, sensor, dt):
    v = t.value
    u = "rad" if sensor == "gyro" else "m/s"
    if t.name == "quantization":
        return f"pulse {math.sqrt(12) * v:.4g} {u}"
    if t.name == "random_walk":
        return f"sd {v * math.sqrt(dt):.4g} {u}/sample"
    if t.name == "bias_instability":
        return f"flat adev {allan.BIAS_FACTOR * v:.4g} {u}/s"
    if t.name == "rate_random_walk":
        return f"bias step sd {v * math.sqrt(dt):.4g} {u}/s"
    return f"{v * dt:.4g} {u}/s per sample"


def _axis_values(fits, name):
    return [f.term(name) for f in fits]


def _pulses(fits, declared, unit, name):
    """Pulse weights for simulate-table (SI, 3) and the comment lines that say where they
    come from: the log's declared pulse weights when it has them (the fitted
    quantization compared with the sqrt(12) law they give), else the equivalent pulse
    ``sqrt(12) Q`` of a resolved quantization term (0 unless every axis has one)."""
    q = [t.value if t.resolved else 0.0 for t in _axis_values(fits, "quantization")]
    equivalent = [math.sqrt(12.0) * v for v in q]
    if declared is not None:
        ratio = ", ".join(f"{v / p:.3g}" for v, p in zip(q, declared, strict=True))
        own = ", ".join(f"{p / unit:.6g}" for p in declared)
        return list(declared), [
            f"# {name} pulse weight: the log's own ({own}); the fitted quantization Q is",
            f"# {ratio} pulses (the quantizer alone gives 1/sqrt(12) = 0.289): the rest is",
            f"# white {name} angle noise beyond the quantizer, which simulate-table's model",
            "# does not carry",
        ]
    if any(v == 0 for v in equivalent):
        return [0.0] * 3, []
    return equivalent, [
        f"# {name} pulse weight: the equivalent sqrt(12) Q of the fitted quantization "
        "(a quantizer with that pulse gives the same white angle noise)"
    ]


def scenario_block(fits_g, fits_a, dt, tau_min, corr_time, pulse=None, rejected=()):
    """The ``imu:`` block (simulate-table) and ``filter.noise:`` block (run-ekf), YAML.

    ``pulse``: the log's declared pulse weights (gyro rad, accel m/s), if any;
    ``rejected``: channels whose curve the five-term model does not reproduce (said at the
    head of the file)."""

    def vec(values, factor):
        return "[" + ", ".join(f"{v / factor:.6g}" for v in values) + "]"

    ng = [t.value for t in _axis_values(fits_g, "random_walk")]
    na = [t.value for t in _axis_values(fits_a, "random_walk")]
    bg = [t.value for t in _axis_values(fits_g, "bias_instability")]
    ba = [t.value for t in _axis_values(fits_a, "bias_instability")]
    kg = [t.value for t in _axis_values(fits_g, "rate_random_walk")]
    ka = [t.value for t in _axis_values(fits_a, "rate_random_walk")]
    gm_g = [gauss_markov(b, tau_min[0], corr_time) for b in bg]
    gm_a = [gauss_markov(b, tau_min[1], corr_time) for b in ba]
    q_g, note_g = _pulses(fits_g, None if pulse is None else pulse[0], ARCSEC, "gyro")
    q_a, note_a = _pulses(fits_a, None if pulse is None else pulse[1], UG_S, "accelerometer")
    head = [
        "# Sensor error model fitted by inins noise (IEEE 952 terms; see its report).",
        "# simulate-table / calibrate-bias: the imu: block. Bias instability B is written",
        "# as the Gauss-Markov bias whose Allan deviation peaks at 0.664 B at the tau of",
        "# the curve's minimum; rate random walk and rate ramp have no key there.",
    ]
    if rejected:
        head += [
            "# WARNING: the five-term model does NOT reproduce the Allan deviation of",
            f"# {', '.join(rejected)} (the fit's chi-square, p < 0.01): for those",
            "# sensors the values below are the closest five-term model, which the curve",
            "# rejects; read the report before using them.",
        ]
    head += note_g + note_a
    return "\n".join(head) + (
        "\nimu:\n"
        f"  sample_rate_hz: {1.0 / dt:.9g}\n"
        "  gyro:\n"
        f"    arw_deg_rth: {vec(ng, DEG_RTH)}\n"
        f"    bias_instability_dph: {vec([s for s, _ in gm_g], DPH)}\n"
        f"    bias_corr_time_s: {np.median([t for _, t in gm_g]):.6g}\n"
        f"    pulse_weight_arcsec: {vec(q_g, ARCSEC)}\n"
        "  accel:\n"
        f"    vrw_ug_rthz: {vec(na, UG_RTHZ)}\n"
        f"    bias_instability_ug: {vec([s for s, _ in gm_a], UG)}\n"
        f"    bias_corr_time_s: {np.median([t for _, t in gm_a]):.6g}\n"
        f"    pulse_weight_ug_s: {vec(q_a, UG_S)}\n"
        "# run-ekf: the filter's process noise (one value per sensor type: the largest\n"
        "# axis); bias walk = rate random walk K, the 1-sigma growth over one hour.\n"
        "filter:\n"
        "  noise:\n"
        f"    arw_deg_rth: {max(ng) / DEG_RTH:.6g}\n"
        f"    vrw_ug_rthz: {max(na) / UG_RTHZ:.6g}\n"
        f"    gyro_bias_walk_dph: {max(kg) * math.sqrt(HOUR) / DPH:.6g}\n"
        f"    accel_bias_walk_ug: {max(ka) * math.sqrt(HOUR) / UG:.6g}\n"
    )


def kalibr_yaml(fits_g, fits_a, dt, topic):
    """Kalibr ``imu.yaml``: continuous densities, SI, the largest axis of each sensor.

    Rate random walk terms not resolved by the record are written as their upper
    bound (Kalibr needs a value)."""

    def worst(fits, name):
        ts = _axis_values(fits, name)
        return max((t.value if t.resolved else t.hi) for t in ts)

    return (
        "# Kalibr IMU noise model fitted by inins noise: continuous-time densities,\n"
        "# the largest of the three axes of each sensor.\n"
        f"rostopic: {topic}\n"
        f"update_rate: {1.0 / dt:.9g}\n"
        f"accelerometer_noise_density: {worst(fits_a, 'random_walk'):.6g}  # m/s^2/sqrt(Hz)\n"
        f"accelerometer_random_walk: {worst(fits_a, 'rate_random_walk'):.6g}  # m/s^3/sqrt(Hz)\n"
        f"gyroscope_noise_density: {worst(fits_g, 'random_walk'):.6g}  # rad/s/sqrt(Hz)\n"
        f"gyroscope_random_walk: {worst(fits_g, 'rate_random_walk'):.6g}  # rad/s^2/sqrt(Hz)\n"
    )


def _tau_of_min(dev, fits, cols):
    out = []
    for c in cols:
        model = fits[c].model
        ok = np.isfinite(model)
        out.append(float(dev.tau[ok][np.argmin(model[ok])]) if ok.any() else float(dev.tau[-1]))
    return float(np.median(out))


def build(cfg, dev, extra, fits, dt, n, n_total, span, warnings, pulse=None):
    """The :class:`CommandResult` of a run (``pulse``: the log's declared pulse weights)."""
    fits_g, fits_a = fits[:3], fits[3:]
    tau_min = (_tau_of_min(dev, fits, range(3)), _tau_of_min(dev, fits, range(3, 6)))
    corr = cfg.output.bias_corr_time_s
    rejected = [ch for ch, f in zip(CHANNELS, fits, strict=True) if not f.reproduces]
    block = scenario_block(fits_g, fits_a, dt, tau_min, corr, pulse, rejected)
    kalibr = kalibr_yaml(fits_g, fits_a, dt, cfg.output.kalibr_topic)
    results = {
        "samples": n,
        "duration_s": n * dt,
        "sample_rate_hz": 1.0 / dt,
        "static_start_s": span[0],
        "static_end_s": span[1],
    }
    for c, ch in enumerate(CHANNELS):
        sensor = ch.split("_")[0]
        for t in fits[c].terms:
            unit, factor, _ = LAB[sensor][t.name]
            base = f"{ch}_{SHORT[sensor][t.name]}_{unit}"
            results[base] = t.value / factor
            results[f"{base}_lo"] = t.lo / factor
            results[f"{base}_hi"] = t.hi / factor
        results[f"{ch}_reproduces"] = int(fits[c].reproduces)
        results[f"{ch}_model_p"] = fits[c].p_value
    datasets = {"adev/tau": Series(dev.tau, "s", "", "averaging time")}
    conf = cfg.deviation.band_confidence
    for name, d in {"adev": dev, **extra}.items():
        lo, hi = d.interval(conf)
        if name != "adev":
            datasets[f"{name}/tau"] = Series(d.tau, "s", "", "averaging time")
        for s, sensor in enumerate(("gyro", "accel")):
            cols = slice(3 * s, 3 * s + 3)
            unit = "rad/s" if sensor == "gyro" else "m/s^2"
            what = {"adev": "overlapping Allan", "mdev": "modified Allan", "totdev": "total"}[name]
            datasets[f"{name}/{sensor}"] = Series(d.dev[:, cols], unit, "b", f"{what} deviation")
            datasets[f"{name}/{sensor}_lo"] = Series(
                lo[:, cols], unit, "b", f"lower limit, confidence {conf:g}"
            )
            datasets[f"{name}/{sensor}_hi"] = Series(
                hi[:, cols], unit, "b", f"upper limit, confidence {conf:g}"
            )
            datasets[f"{name}/{sensor}_edf"] = Series(
                d.edf[:, cols], "1", "b", "equivalent degrees of freedom"
            )
            datasets[f"{name}/{sensor}_alpha"] = Series(
                d.alpha[:, cols].astype(np.int64), "1", "b", "power-law noise exponent assumed"
            )
            if name == "adev":
                model = np.stack([fits[c].model for c in range(3 * s, 3 * s + 3)], axis=1)
                datasets[f"adev/{sensor}_model"] = Series(
                    model, unit, "b", "deviation of the fitted five-term model"
                )
    datasets["fit/terms"] = Series(
        np.array([[t.value for t in f.terms] for f in fits]),
        "SI",
        "",
        "fitted Q, N, B, K, R per channel (gyro x y z, accel x y z)",
    )
    datasets["fit/lo"] = Series(
        np.array([[t.lo for t in f.terms] for f in fits]), "SI", "", "lower limits"
    )
    datasets["fit/hi"] = Series(
        np.array([[t.hi for t in f.terms] for f in fits]), "SI", "", "upper limits"
    )
    attrs = {
        "noise": {
            "dt_s": dt,
            "scenario_block_yaml": block,
            "kalibr_yaml": kalibr,
            "fit_confidence": cfg.fit.confidence,
            "band_confidence": conf,
        }
    }
    text = report(cfg, dev, extra, fits, dt, n, n_total, span, block, kalibr)
    return CommandResult(
        command="noise",
        results=results,
        datasets=datasets,
        attrs=attrs,
        report=text,
        warnings=tuple(warnings),
    )


def report(cfg, dev, extra, fits, dt, n, n_total, span, block, kalibr):
    """The text report."""
    fs = 1.0 / dt
    lines = [
        f"Record: {n} samples at {fs:.6g} Hz ({n * dt:.6g} s), static part "
        f"{span[0]:.6g} s to {span[1]:.6g} s of {n_total * dt:.6g} s.",
        "",
        "Overlapping Allan deviation on "
        + (
            "octave tau"
            if cfg.deviation.per_octave == 1
            else f"{cfg.deviation.per_octave} tau per octave"
        )
        + (
            f"; above {cfg.deviation.offsets} starts per tau every 2^l-th start is used "
            f"({cfg.deviation.offsets} per tau)."
            if cfg.deviation.offsets
            else "; all starts (fully overlapping)."
        ),
        "Confidence intervals: chi-square with the equivalent degrees of freedom of "
        "Greenhall & Riley (2003) for a single power-law noise S_y(f) ~ f^alpha at each "
        "tau, alpha identified by the lag-1 autocorrelation (Riley & Greenhall 2004; "
        "+2 quantization, 0 white rate, -1 flicker (bias instability), -2 rate random "
        "walk); band confidence "
        f"{cfg.deviation.band_confidence:g}.",
        "",
    ]
    for s, sensor in enumerate(("gyro", "accel")):
        unit, factor = ("deg/h", DPH) if sensor == "gyro" else ("ug", UG)
        lo, hi = dev.interval(cfg.deviation.band_confidence)
        rows = []
        for j in range(dev.tau.size):
            row = [f"{dev.tau[j]:.5g}"]
            for c in range(3 * s, 3 * s + 3):
                row += [
                    f"{dev.dev[j, c] / factor:.5g}",
                    f"[{lo[j, c] / factor:.4g}, {hi[j, c] / factor:.4g}]",
                    f"{dev.alpha[j, c]:+d}",
                ]
            rows.append(row)
        heads = ["tau s"]
        for a in "xyz":
            heads += [f"{a} {unit}", "interval", "alpha"]
        lines += [f"Allan deviation, {sensor} ({unit}):", format_table(rows, heads), ""]
    for name, d in extra.items():
        lines.append(f"{name}: tau " + ", ".join(f"{t:.4g}" for t in d.tau))
        for s, sensor in enumerate(("gyro", "accel")):
            factor = DPH if sensor == "gyro" else UG
            for c in range(3 * s, 3 * s + 3):
                vals = ", ".join(f"{v / factor:.4g}" for v in d.dev[:, c])
                lines.append(f"  {sensor} {'xyz'[c % 3]}: {vals}")
        lines.append("")
    lines += [
        "Noise terms (IEEE Std 952-1997 Annex C): s2(tau) = 3 Q^2/tau^2 + N^2/tau + "
        "(2 ln2/pi) B^2 + K^2 tau/3 + R^2 tau^2/2,",
        "fitted by non-negative weighted least squares in the Allan variance (weights "
        "edf / (2 s2^2)); bias instability B = flat deviation / 0.664 "
        "(0.664 = sqrt(2 ln2 / pi)).",
        "Each coefficient is bounded by what the curve allows: its variance alone within "
        f"the curve's upper {cfg.fit.confidence:g} limit at every tau.",
        f"Interval: {cfg.fit.confidence:g} confidence from the covariance of the fit with "
        "the estimates correlated across tau for the fitted noises (0.9 between octaves "
        "for a random-walk rate, 0.5 for a white rate); a term dominating where the "
        f"curve holds fewer than {allan.MIN_DOMINANT_EDF:g} degrees of freedom, or left "
        "out, gets [0, bound].",
        "tau range: where the term carries at least half the model variance "
        "('-': nowhere, the value is a bound).",
        "",
    ]
    heads = ["sensor", "term", "value", "interval", "lab unit", "SI", "discrete", "tau s"]
    rows = term_rows(fits[:3], "gyro", dt) + term_rows(fits[3:], "accel", dt)
    lines += [format_table(rows, heads), ""]
    lines += [
        "Conversions: deg/sqrt(h) = 2.909e-4 rad/sqrt(s); deg/h = 4.848e-6 rad/s; "
        "deg/h/sqrt(h) = 8.081e-8 rad/s/sqrt(s); ug/sqrt(Hz) = 9.807e-6 m/s/sqrt(s); "
        "arcsec = 4.848e-6 rad.",
        f"Discrete at fs = {fs:.6g} Hz: random-walk increment sd = N sqrt(dt), rate sd "
        "= N sqrt(fs); rate-random-walk bias step sd = K sqrt(dt); quantization pulse "
        "= sqrt(12) Q (uniform angle error of sd Q); rate ramp R dt per sample.",
        "",
        "Model check: the chi-square of the residuals with the covariance of the "
        "estimates (correlated across tau), rejected below p = "
        f"{allan.MODEL_P:g}; the tau inside the curve's 0.95 band are shown for reading:",
    ]
    for c, ch in enumerate(CHANNELS):
        f = fits[c]
        lines.append(
            f"  {ch}: chi2/dof {f.chi2_per_dof:.3g} on {f.dof} dof, p = {f.p_value:.3g} "
            f"({int(f.inside.sum())}/{int(np.isfinite(f.model).sum())} tau inside) -> "
            f"{'reproduces' if f.reproduces else 'DOES NOT reproduce'}"
        )
    lines += [
        "",
        "Sensor error-model block (written as noise-imu.yaml):",
        block,
        "Kalibr imu.yaml (written as kalibr-imu.yaml):",
        kalibr,
    ]
    return "\n".join(lines)

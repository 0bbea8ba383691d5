"""import-log's text report: the log as read, the steps, the stationary check of each
hold (screened and not), the white noise and, for a PSINS log, its header."""

import numpy as np

from inins.calibration import stationary
from inins.core import earth
from inins.core.units import ARCSEC, DEG, DEG_RTH, DPH, UG, UG_RTHZ
from inins.results import format_table


def _sensor_line(name, sensor, pw, unit, scale, scale_name):
    if sensor.counts:
        return (
            f"{name}: pulse counts, stored as int32; pulse weight per body axis x y z "
            f"{np.array2string(pw / scale, precision=6)} {scale_name}"
        )
    how = "rates, stored as increments rate x dt" if sensor.quantity == "rate" else "increments"
    return f"{name}: {how} in {unit} (float64)"


def _input_lines(cfg, run):
    n, dt, t0, lla = run.extent.n, run.extent.dt, run.extent.t0, run.resolved.lla
    lines = [
        f"log: {cfg.path.name} ({cfg.format}), {n} samples at {1 / dt:.6g} Hz "
        f"({n * dt:.2f} s) from t0 = {t0:.6g} s; imported at {run.extent.rows_per_s:.3g} rows/s"
    ]
    if run.extent.time_span is not None:
        first, last = run.extent.time_span
        mean = (last - first) / (n - 1)
        lines.append(
            f"time column: {first:.6f} s to {last:.6f} s, mean step {mean:.9g} s "
            f"({(mean / dt - 1) * 1e6:+.1f} ppm from the nominal {dt:.6g} s)"
        )
    h = run.resolved.header
    if h is not None:
        att = ", ".join(f"{v:g}" for v in h.attitude_deg)
        lines += [
            f"PSINS header: lat {h.lat_deg:.8f} deg, lon {h.lon_deg:.8f} deg, height "
            f"{h.height_m:g} m, t0 {h.t0_s:g} s, interval {h.dt_s * 1e3:g} ms, "
            f"g {h.g_mps2:g} m/s^2 (the g of its ug); pulse weights gyro "
            f"{h.gyro_pulse_arcsec} arcsec, accel {h.accel_pulse_ug_s} ug*s (log axes)",
            f"  attitude (pitch, roll, yaw; PSINS yaw is counter-clockwise from north, of the "
            f"log y axis, 'maybe inaccurate'): {att} deg",
            "  scenario values used instead of the header: "
            + (", ".join(run.resolved.overrides) or "none"),
        ]
    sign = {1.0: "+", -1.0: "-"}
    mapping = ", ".join(
        f"body {b} = {sign[cfg.mat_bl[i][j]]}log {'xyz'[j]}"
        for i, b in enumerate("xyz")
        for j in range(3)
        if cfg.mat_bl[i][j]
    )
    lines += [
        _sensor_line("gyro", cfg.gyro, run.resolved.gyro_pw, "rad", ARCSEC, "arcsec"),
        _sensor_line(
            "accel",
            cfg.accel,
            run.resolved.accel_pw,
            "m/s",
            1e-6 * run.resolved.g,
            f"ug*s (ug = 1e-6 x {run.resolved.g:.7g} m/s^2)",
        ),
        f"axes: {mapping}",
        f"site: lat {lla[0] / DEG:.8f} deg, lon {lla[1] / DEG:.8f} deg, height {lla[2]:g} m; "
        f"normal gravity {earth.gravity(lla[0], lla[2]):.6f} m/s^2, Earth rate "
        f"{earth.RATE / DPH:.4f} deg/h, horizontal {earth.RATE * np.cos(lla[0]) / DPH:.4f} "
        "deg/h",
    ]
    return lines


def _step_rows(cfg, steps):
    rows = []
    for i, s in enumerate(steps):
        axis = cfg.gimbals[s.axis] if s.axis >= 0 and cfg.gimbals else ""
        rows.append(
            [
                i,
                s.kind,
                s.label,
                axis,
                s.start_time,
                s.end_time,
                s.stop_index - s.start_index,
                *np.degrees(s.angles_end),
            ]
        )
    heads = [
        "#",
        "kind",
        "label",
        "axis",
        "start",
        "end",
        "samples",
        *[f"{g} end" for g in cfg.gimbals],
    ]
    units = ["", "", "", "", "s", "s", "", *["deg"] * len(cfg.gimbals)]
    return format_table(rows, heads, units, fmt=".8g")


def report(cfg, run, steps, checks):
    """Report body: the input as read, the steps, the stationary check of each hold."""
    lla = run.resolved.lla
    lines = [*_input_lines(cfg, run), "", "steps", _step_rows(cfg, steps)]
    done = [c for c in checks if c is not None]
    if not done:
        return "\n".join([*lines, "", "no hold long enough to check"])
    rows, raw, noise = [], [], []
    for c in done:
        v = hold_numbers(c, lla)
        rows.append(
            [
                c.label,
                v["hold_s"],
                v["quiet_s"],
                v["roll_deg"],
                v["pitch_deg"],
                v["heading_deg"],
                v["heading_sigma_deg"],
                v["gravity_err_ug"],
                v["earth_rate_dph"],
                v["earth_rate_horizontal_dph"],
                v["earth_rate_horizontal_err_pct"],
                v["implied_lat_deg"],
                v["implied_lat_err_deg"],
            ]
        )
        raw.append(
            [
                c.label,
                v["heading_unscreened_deg"],
                v["earth_rate_horizontal_unscreened_dph"],
                100 * (c.earth_rate_all[2] / (earth.RATE * np.cos(lla[0])) - 1),
                v["implied_lat_unscreened_deg"],
            ]
        )
        noise.append(
            [
                c.label,
                *(v[f"arw_{a}_deg_rth"] for a in "xyz"),
                *(v[f"vrw_{a}_ug_rthz"] for a in "xyz"),
            ]
        )
    opts = cfg.check
    lines += [
        "",
        "stationary check of each hold (quiet blocks; first hold -> summary.json)",
        format_table(
            rows,
            [
                "hold",
                "used",
                "quiet",
                "roll",
                "pitch",
                "heading",
                "1 sigma",
                "|f|-gamma",
                "|omega|",
                "horizontal",
                "vs W cos L",
                "latitude",
                "vs site",
            ],
            ["", "s", "s", "deg", "deg", "deg", "deg", "ug", "deg/h", "deg/h", "%", "deg", "deg"],
            fmt=".5g",
        ),
        "",
        "the same without screening",
        format_table(
            raw,
            ["hold", "heading", "horizontal", "vs W cos L", "latitude"],
            ["", "deg", "deg/h", "%", "deg"],
            fmt=".5g",
        ),
        "",
        "white noise (min over tau of Allan deviation x sqrt(tau), quiet blocks)",
        format_table(
            noise,
            ["hold", "ARW x", "ARW y", "ARW z", "VRW x", "VRW y", "VRW z"],
            ["", *["deg/sqrt(h)"] * 3, *["ug/sqrt(Hz)"] * 3],
            fmt=".4g",
        ),
        "",
        (
            f"screening: {'on' if opts.screen else 'off'}; blocks of {opts.block_s:g} s; a "
            f"block is disturbed when a gyro's sample spread exceeds {opts.std_ratio:g} x the "
            f"hold's median or its mean rate is more than {opts.rate_sigma:g} robust sigma "
            f"from the hold's median; widened by {opts.guard_s:g} s"
        ),
    ]
    lines += [
        f"  {c.label}: too few quiet blocks, all blocks used"
        for c in done
        if opts.screen and not c.screened
    ]
    h = run.resolved.header
    if h is not None:
        azimuth = stationary.log_y_azimuth(done[0].align.mat_nb, cfg.mat_bl) / DEG
        lines.append(
            f"log y axis azimuth from the gyrocompass ({done[0].label}): "
            f"{azimuth:.3f} deg; header yaw {h.attitude_deg[2]:g} deg "
            f"(counter-clockwise) = azimuth {np.mod(-h.attitude_deg[2], 360):.3f} "
            "deg"
        )
    return "\n".join(lines)


def hold_numbers(c, lla):
    """A check in lab units: dict of flat, unit-suffixed numbers."""
    w_h = earth.RATE * np.cos(lla[0])
    roll, pitch, heading = c.align.euler
    rate, lat, hor = c.earth_rate
    _, lat_all, hor_all = c.earth_rate_all
    out = {
        "roll_deg": roll / DEG,
        "pitch_deg": pitch / DEG,
        "heading_deg": np.mod(heading, 2 * np.pi) / DEG,
        "heading_sigma_deg": c.align.heading_sigma / DEG,
        "earth_rate_dph": rate / DPH,
        "earth_rate_err_pct": 100 * (rate / earth.RATE - 1),
        "earth_rate_horizontal_dph": hor / DPH,
        "earth_rate_horizontal_err_pct": 100 * (hor / w_h - 1),
        "implied_lat_deg": lat / DEG,
        "implied_lat_err_deg": (lat - lla[0]) / DEG,
        "gravity_err_ug": c.gravity_err / UG,
        "hold_s": c.used,
        "quiet_s": c.quiet,
        "heading_unscreened_deg": np.mod(c.align_all.euler[2], 2 * np.pi) / DEG,
        "earth_rate_horizontal_unscreened_dph": hor_all / DPH,
        "implied_lat_unscreened_deg": lat_all / DEG,
    }
    for i, axis in enumerate("xyz"):
        out[f"arw_{axis}_deg_rth"] = c.arw[i] / DEG_RTH
        out[f"vrw_{axis}_ug_rthz"] = c.vrw[i] / UG_RTHZ
    return {k: (None if not np.isfinite(v) else float(v)) for k, v in out.items()}

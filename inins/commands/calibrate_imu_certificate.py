"""The calibration certificate of a calibrate-imu run (and the plan of a plan-only run):
one self-contained HTML page (figures embedded as base64 PNG, no script, no external
resource), laid out for A4.

What a lab signs: the unit (name, serial, description), the laboratory, operator,
procedure and calibration date; per method its model (what its gyro bias includes) and
the schedule's observability verdict (what it separates, the combinations it leaves
free); every term as ``value ± U`` with ``U`` the expanded uncertainty (k = 2) to two
significant digits and the value rounded to the same place, in µg, °/h, ppm and arcsec;
a legend of the term names; the residuals before and after; the provenance. A plan-only
run gives a *calibration plan* (predicted 1-sigma, separability), titled as such: nothing
was measured.
"""

import html
import math

from inins.commands._calibrate_imu_units import PREFIX, lab

SYMBOL = {"ug": "µg", "dph": "°/h", "ppm": "ppm", "arcsec": "arcsec", "dph_per_g": "°/h per g"}
"""How each lab unit is printed."""
TITLES = {
    "discrete": "Discrete rate-table method",
    "table_free": "Table-free multi-position method",
    "system": "System-level calibration (Kalman filter on navigation errors)",
}
LEGEND = (
    ("ba_i", "accelerometer bias, axis i"),
    ("bg_i", "gyro bias, axis i"),
    ("sa_i, sg_i", "accelerometer, gyro scale-factor error, axis i"),
    (
        "ma_ij",
        "misalignment of accelerometer i toward axis j (a_xy = a_xz = a_yz = 0: the "
        "body axes are the accelerometer triad's)",
    ),
    ("mg_ij", "misalignment of gyro i toward axis j"),
    ("gg_ij", "gyro i sensitivity to specific force along j"),
    ("mount_i", "rotation of the triad from its nominal mounting on the table, about i"),
)
CSS = (
    "@page{size:A4;margin:14mm}"
    "body{font-family:'DejaVu Sans',Arial,sans-serif;font-size:9.5pt;color:#111;"
    "max-width:180mm;margin:0 auto}"
    "h1{font-size:16pt;margin:0 0 4mm 0}h2{font-size:12pt;margin:6mm 0 2mm 0;"
    "page-break-after:avoid}"
    "table{border-collapse:collapse;margin:1mm 0 3mm 0;page-break-inside:auto}"
    "tr{page-break-inside:avoid}"
    "td,th{border:1px solid #999;padding:1px 5px;text-align:right;vertical-align:top}"
    "th{background:#eee;text-align:left}td.n{text-align:left}"
    "td.w{text-align:left;word-break:break-all;max-width:120mm}"
    "p{margin:1mm 0}.note{font-size:8.5pt;color:#333}"
    "img{max-width:100%;page-break-inside:avoid}"
)


def value_with_uncertainty(value, u):
    """``("40.10", "0.20")``: ``u`` to two significant digits, ``value`` rounded to the same
    decimal place (GUM 7.2.6). Non-finite ``u``: the value to 6 significant digits and
    "n/a"."""
    if value is None:
        return "n/a", "n/a"
    if u is None or not math.isfinite(u) or u <= 0:
        return f"{value:.6g}", "n/a"
    u2 = float(f"{u:.2g}")
    place = math.floor(math.log10(u2)) - 1  # the second significant digit of U
    decimals = max(0, -place)
    scale = 10.0**place
    v = round(value / scale) * scale
    u2 = round(u2 / scale) * scale
    return f"{v:.{decimals}f}", f"{u2:.{decimals}f}"


def _head(title, info, unit_name, date):
    e = html.escape
    rows = (
        ("unit", unit_name),
        ("serial number", info.get("unit_serial", "")),
        ("description", info.get("unit_description", "")),
        ("laboratory", info.get("laboratory", "")),
        ("operator", info.get("operator", "")),
        ("procedure", info.get("procedure", "")),
        ("calibration date (UTC)", date or "-"),
    )
    return [
        "<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>",
        f"<title>{e(title)}</title><style>{CSS}</style></head><body>",
        f"<h1>{e(title)}</h1>",
        "<table>",
        *(f"<tr><th>{e(k)}</th><td class='w'>{e(str(v))}</td></tr>" for k, v in rows),
        "</table>",
    ]


def _method(result, method):
    """The section of one method: model, verdict, schedule, terms."""
    e = html.escape
    pre = PREFIX[method]
    a = result.attrs[pre]
    out = [f"<h2>{e(TITLES.get(pre, method))}</h2>"]
    out.append(f"<p><b>Model.</b> {e(a.get('model', ''))}</p>")
    out.append(f"<p><b>Observability.</b> {e(a.get('verdict', ''))}</p>")
    if a.get("combinations"):
        combos = "; ".join(a["combinations"])
        out.append(f"<p class='note'>Combinations the schedule leaves free: {e(combos)}</p>")
    if "labels" in a:
        sched = ", ".join(
            f"{k}:{lbl}" for k, lbl in zip(a.get("kinds", []), a["labels"], strict=False)
        )
        out.append(
            f"<p class='note'><b>Schedule</b> ({len(a['labels'])} intervals): {e(sched)}</p>"
        )
    out.append("<table><tr><th>term</th><th>value</th><th>U (k = 2)</th><th>unit</th></tr>")
    for n in a["names"]:
        unit, _ = lab(n)
        v = result.results.get(f"{pre}_{n}_{unit}")
        u = result.results.get(f"{pre}_{n}_u_{unit}")
        shown_v, shown_u = value_with_uncertainty(v, u)
        if v is None:
            shown_v, shown_u = "not determined", "-"
        out.append(
            f"<tr><td class='n'>{e(n)}</td><td>{shown_v}</td><td>{shown_u}</td>"
            f"<td class='n'>{e(SYMBOL.get(unit, unit))}</td></tr>"
        )
    out.append("</table>")
    return out


def _plan(result):
    e = html.escape
    out = [
        "<p><b>Nothing was measured.</b> This is the plan of the schedule: what it "
        "separates and the 1-sigma each term is predicted to get, from the motion program "
        "and the noise figures alone.</p>",
        "<table><tr><th>term</th><th>predicted 1&sigma;</th><th>unit</th></tr>",
    ]
    for k, v in result.results.items():
        if k.startswith("plan_") and "_sigma_" in k:
            name, unit = k.removeprefix("plan_").split("_sigma_")
            shown = "not separable" if v is None else f"{v:.2g}"
            out.append(
                f"<tr><td class='n'>{e(name)}</td><td>{shown}</td>"
                f"<td class='n'>{e(SYMBOL.get(unit, unit))}</td></tr>"
            )
    out.append("</table>")
    return out


def certificate_html(result, png, provenance=None):
    """HTML text of the certificate (or the plan), ``png`` the residual figure (base64)."""
    e = html.escape
    top = result.attrs[""]
    info = top.get("certificate", {})
    plan_only = bool(top.get("plan_only"))
    methods = top.get("methods", [])
    dates = [result.attrs[PREFIX[m]].get("calibrated", "") for m in methods]
    title = "Calibration plan" if plan_only else "Calibration certificate"
    parts = _head(title, info, top.get("unit_name", ""), dates[0] if dates else "")
    for method in methods:
        parts += _method(result, method)
    if plan_only:
        parts += _plan(result)
    parts += [
        "<h2>Legend</h2><table>",
        *(f"<tr><td class='n'>{e(k)}</td><td class='n'>{e(v)}</td></tr>" for k, v in LEGEND),
        "</table>",
        "<p class='note'>Units: µg = 9.80665e-6 m/s²; °/h = degree per hour; ppm = 1e-6; "
        "arcsec = 1/3600 degree.</p>",
    ]
    if not plan_only:
        parts.append(
            "<p class='note'><b>Uncertainty.</b> U = 2&sigma; (coverage factor k = 2, about "
            "95 %), &sigma; from the sensor white noise propagated through each method's "
            "estimate (and its misfit where the residuals exceed the noise); U is given to "
            "two significant digits and the value rounded to the same place.</p>"
        )
    heading = "Planned uncertainty" if plan_only else "Residuals before and after calibration"
    parts += [
        f"<h2>{heading}</h2>",
        f"<img alt='figures' src='data:image/png;base64,{png}'>",
        "<h2>Provenance</h2><table>",
        *(
            f"<tr><th>{e(str(k))}</th><td class='w'>{e(str(v))}</td></tr>"
            for k, v in sorted((provenance or {}).items())
        ),
        "</table></body></html>",
    ]
    return "\n".join(parts)

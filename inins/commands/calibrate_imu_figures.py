"""calibrate-imu figures, the compensation file and the HTML calibration certificate.

Each function takes the run's :class:`inins.results.CommandResult` and a path. The
certificate is one self-contained HTML page (figures embedded as base64 PNG, no
script, no external resource), laid out for printing to PDF.
"""

import base64
import html
import io

import numpy as np

from inins.core.units import DPH, UG

TITLES = {
    "discrete": "Discrete rate-table method",
    "table_free": "Table-free multi-position",
    "system": "System-level calibration (Kalman filter on navigation errors)",
}


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _panels(result):
    """(title, before, after, unit label) of every before/after residual the run has."""
    out = []
    ds = result.datasets
    for pre in result.attrs[""].get("methods", []):
        pre = {"table-free": "table_free", "system-level": "system"}.get(pre, pre)
        if f"{pre}/gravity_norm_before" in ds:
            out.append(
                (
                    f"{pre}: gravity-norm residual per interval",
                    ds[f"{pre}/gravity_norm_before"].data / UG,
                    ds[f"{pre}/gravity_norm_after"].data / UG,
                    "|f| - g (ug)",
                )
            )
        for key, title in (
            ("earth_rate", "Earth-rate residual per position"),
            ("rate", "rate-test residual"),
        ):
            if f"{pre}/{key}_before" in ds and ds[f"{pre}/{key}_before"].data.size:
                out.append(
                    (
                        f"{pre}: {title}",
                        np.linalg.norm(ds[f"{pre}/{key}_before"].data, axis=1) / DPH,
                        np.linalg.norm(ds[f"{pre}/{key}_after"].data, axis=1) / DPH,
                        "|residual| (deg/h)",
                    )
                )
        if f"{pre}/velocity_before" in ds:
            out.append(
                (
                    f"{pre}: velocity error at each filter step",
                    np.linalg.norm(ds[f"{pre}/velocity_before"].data, axis=1),
                    np.linalg.norm(ds[f"{pre}/velocity_after"].data, axis=1),
                    "|v| (m/s)",
                )
            )
        if f"{pre}/gravity_dir_before" in ds:
            out.append(
                (
                    f"{pre}: gravity direction after each rotation",
                    np.degrees(np.linalg.norm(ds[f"{pre}/gravity_dir_before"].data, axis=1)),
                    np.degrees(np.linalg.norm(ds[f"{pre}/gravity_dir_after"].data, axis=1)),
                    "|u_pred - u| (deg)",
                )
            )
    return out


def _draw_plan(result, fileobj):
    """Planned 1-sigma of every term (plan only: nothing measured yet)."""
    plt = _pyplot()
    keys = [k for k, v in result.results.items() if k.startswith("plan_") and "_sigma_" in k]
    fig, ax = plt.subplots(figsize=(8, 3.5), layout="constrained")
    labels, values = [], []
    for k in keys:
        v = result.results[k]
        labels.append(k.removeprefix("plan_").split("_sigma_")[0])
        values.append(np.nan if v is None else v)
    ax.bar(range(len(values)), values, color="tab:blue")
    ax.set_xticks(range(len(values)), labels, rotation=90, fontsize=7)
    ax.set_yscale("log")
    ax.set_ylabel("predicted 1-sigma (lab unit of each term)")
    ax.set_title("planned 1-sigma (missing bar: not separable)", fontsize=10)
    fig.savefig(fileobj, format="png", dpi=90)
    plt.close(fig)


def _draw(result, fileobj):
    if result.attrs[""].get("plan_only"):
        _draw_plan(result, fileobj)
        return
    plt = _pyplot()
    panels = _panels(result)
    n = max(1, len(panels))
    fig, axes = plt.subplots(n, 1, figsize=(8, 2.6 * n), layout="constrained", squeeze=False)
    for ax, (title, before, after, unit) in zip(axes[:, 0], panels, strict=False):
        k = np.arange(before.size)
        ax.semilogy(k, np.abs(before) + 1e-30, "o", ms=4, label="before (nominal)")
        ax.semilogy(k, np.abs(after) + 1e-30, "s", ms=4, label="after calibration")
        ax.set_title(title, fontsize=10)
        ax.set_xlabel("interval")
        ax.set_ylabel(unit)
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
    fig.savefig(fileobj, format="png", dpi=90)
    plt.close(fig)


def residuals(result, path):
    """Before/after residuals: gravity norm, Earth rate, rate tests, gravity direction."""
    with open(path, "wb") as fh:
        _draw(result, fh)


def compensation_text(result):
    """The compensation file of the first method (the YAML in the results file)."""
    if not result.attrs[""]["methods"]:
        return "# calibrate-imu plan only: nothing estimated, no compensation\n"
    first = result.attrs[""]["methods"][0]
    pre = {"table-free": "table_free", "system-level": "system"}.get(first, first)
    return result.attrs[pre]["compensation_yaml"]


def certificate(result, path, data=None):
    """The calibration certificate: a self-contained, printable HTML page; the
    provenance is read from the run's results file ``data`` when given."""
    prov = {}
    if data is not None:
        import h5py

        with h5py.File(data, "r") as h5:
            for k, v in h5.attrs.items():
                if k != "summary_json" and not k.startswith("scenario"):
                    prov[k] = v.decode() if isinstance(v, bytes) else v
    with open(path, "w", encoding="utf-8") as fh:
        fh.write(certificate_html(result, prov))


def certificate_html(result, provenance=None):
    """HTML text of the certificate."""
    from inins.commands._calibrate_imu_units import PREFIX, lab

    buf = io.BytesIO()
    _draw(result, buf)
    png = base64.b64encode(buf.getvalue()).decode("ascii")
    info = result.attrs[""].get("certificate", {})
    e = html.escape
    parts = [
        "<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'>",
        "<title>Calibration certificate</title><style>",
        "body{font-family:sans-serif;font-size:11pt;margin:2em;color:#111}",
        "table{border-collapse:collapse;margin:0.5em 0 1.5em 0}",
        "td,th{border:1px solid #999;padding:2px 6px;text-align:right}",
        "th{background:#eee}td.n{text-align:left}",
        "h1{font-size:18pt}h2{font-size:13pt;margin-top:1.5em}",
        "img{max-width:100%}@media print{body{margin:1cm}h2{page-break-after:avoid}}",
        "</style></head><body>",
        "<h1>Calibration certificate</h1>",
        "<table>",
        *(
            f"<tr><th>{k}</th><td class='n'>{e(str(v))}</td></tr>"
            for k, v in (
                ("unit", result.attrs[""].get("unit_name", "")),
                ("serial", info.get("unit_serial", "")),
                ("description", info.get("unit_description", "")),
                ("laboratory", info.get("laboratory", "")),
                ("operator", info.get("operator", "")),
                ("procedure", info.get("procedure", "")),
            )
        ),
        "</table>",
    ]
    for method in result.attrs[""].get("methods", []):
        pre = PREFIX[method]
        a = result.attrs[pre]
        parts.append(f"<h2>{e(TITLES.get(pre, method))}</h2>")
        if "labels" in a:
            sched = ", ".join(
                f"{k}:{lbl}" for k, lbl in zip(a.get("kinds", []), a["labels"], strict=False)
            )
            parts.append(f"<p><b>schedule</b> ({len(a['labels'])} intervals): {e(sched)}</p>")
        parts.append(
            "<table><tr><th>term</th><th>estimate</th><th>1&sigma;</th>"
            "<th>U (k=2)</th><th>unit</th></tr>"
        )
        for n in a["names"]:
            unit, _ = lab(n)
            v = result.results.get(f"{pre}_{n}_{unit}")
            s = result.results.get(f"{pre}_{n}_sigma_{unit}")
            u = result.results.get(f"{pre}_{n}_u_{unit}")

            def f(x):
                return "n/a" if x is None else f"{x:.6g}"

            parts.append(
                f"<tr><td class='n'>{e(n)}</td><td>{f(v)}</td><td>{f(s)}</td><td>{f(u)}</td>"
                f"<td class='n'>{e(unit)}</td></tr>"
            )
        parts.append("</table>")
        if a.get("combinations"):
            parts.append("<p>Inseparable combinations: " + e("; ".join(a["combinations"])) + "</p>")
    if result.attrs[""].get("plan_only"):
        parts.append("<h2>Calibration plan (nothing measured)</h2><table>")
        parts.append("<tr><th>term</th><th>predicted 1&sigma;</th></tr>")
        for k, v in result.results.items():
            if k.startswith("plan_") and "_sigma_" in k:
                shown = "not separable" if v is None else f"{v:.4g}"
                parts.append(f"<tr><td class='n'>{e(k)}</td><td>{shown}</td></tr>")
        parts.append("</table>")
    parts += [
        "<h2>Residuals before and after calibration</h2>"
        if not result.attrs[""].get("plan_only")
        else "<h2>Planned uncertainty</h2>",
        f"<img alt='residual figures' src='data:image/png;base64,{png}'>",
        "<h2>Provenance</h2><table>",
    ]
    for k, v in sorted((provenance or {}).items()):
        parts.append(f"<tr><th>{e(str(k))}</th><td class='n'>{e(str(v))}</td></tr>")
    parts.append(
        "<tr><th>uncertainty</th><td class='n'>1&sigma; from the sensor white noise "
        "propagated through the least squares; U = 2&sigma; (k = 2, about 95 %)</td></tr>"
    )
    parts.append("</table></body></html>")
    return "\n".join(parts)

"""The text report of a calibrate-imu run and the certificate's header fields."""

import numpy as np

from inins.commands._calibrate_imu_units import lab
from inins.core.units import DPH, UG
from inins.results import format_table


def certificate_info(scenario):
    c = scenario.certificate
    return {
        "laboratory": c.laboratory,
        "operator": c.operator,
        "procedure": c.procedure,
        "unit_serial": scenario.unit.serial,
        "unit_description": scenario.unit.description,
    }


def report(method, out, truth, comp_yaml):
    rows = []
    for k, n in enumerate(out["names"]):
        unit, scale = lab(n)
        s = out["sigma"][k]
        row = [n, out["values"][k] / scale, s / scale, 2 * s / scale, unit]
        if truth is not None:
            row.append(truth.get(n, 0.0) / scale)
        if out["plan_sigma"] is not None:
            row.append(out["plan_sigma"][k] / scale)
        rows.append(row)
    head = ["term", "estimate", "1-sigma", "U (k=2)", "unit"]
    if truth is not None:
        head.append("truth")
    if out["plan_sigma"] is not None:
        head.append("planned 1-sigma")
    lines = [f"== {method} ==", format_table(rows, head, fmt=".6g")]
    lines.append(
        "  ".join(
            f"{k} {v:.6g}" if isinstance(v, float) else f"{k} {v}"
            for k, v in out["scalars"].items()
        )
    )
    if out["residuals"] is not None:
        res = out["residuals"]
        rrows = []
        for k, label in enumerate(out["labels"]):
            rrows.append(
                [
                    label,
                    out["kinds"][k],
                    *(res[k, :3] / DPH),
                    *(np.nan_to_num(res[k, 3:], nan=np.nan) / UG),
                ]
            )
        lines += [
            "",
            "residuals per interval (mean minus model)",
            format_table(
                rrows,
                ["interval", "kind", "gx", "gy", "gz", "ax", "ay", "az"],
                ["", "", "deg/h", "deg/h", "deg/h", "ug", "ug", "ug"],
                fmt=".3g",
            ),
        ]
    corr = out["correlation"]
    names = out["names"]
    strong = [
        (abs(corr[i, j]), names[i], names[j], corr[i, j])
        for i in range(len(names))
        for j in range(i)
        if np.isfinite(corr[i, j]) and abs(corr[i, j]) > 0.5
    ]
    strong.sort(reverse=True)
    if strong:
        lines += ["", "correlations above 0.5:"]
        lines += [f"  {a} - {b}: {c:+.3f}" for _, a, b, c in strong[:12]]
    if out["attrs"].get("combinations"):
        lines += [
            "",
            "inseparable combinations:",
            *("  " + c for c in out["attrs"]["combinations"]),
        ]
    if out["attrs"].get("flagged"):
        lines += [
            "",
            "flagged static intervals (not used):",
            *("  " + c for c in out["attrs"]["flagged"]),
        ]
    lines += ["", "compensation file:", comp_yaml]
    return "\n".join(lines)

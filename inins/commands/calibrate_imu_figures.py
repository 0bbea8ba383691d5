"""calibrate-imu figures, the compensation file and the HTML calibration certificate.

Each function takes the run's :class:`inins.results.CommandResult` and a path. The
certificate's page is :mod:`inins.commands.calibrate_imu_certificate`'s.
"""

import base64
import io

import numpy as np

from inins.core.units import DPH, UG


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
                    "|f| - g (µg)",
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
                        "|residual| (°/h)",
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
    """HTML text of the certificate (:mod:`inins.commands.calibrate_imu_certificate`)."""
    from inins.commands.calibrate_imu_certificate import certificate_html as page

    buf = io.BytesIO()
    _draw(result, buf)
    return page(result, base64.b64encode(buf.getvalue()).decode("ascii"), provenance)

"""The text report ``OUTDIR/CMD.txt`` and table helpers for method authors.

The report is plain text (no terminal colour codes)::

    inins calibrate-bias report
    ===========================
    command    calibrate-bias
    ...
    <the method's report body>

    Warnings
    --------
    - ...

    Checks
    ------
    #  check                        value     result
    ...

Method authors build their body with :func:`format_table`, e.g.::

    format_table(
        [("beta_x", 0.00161, 0.0016), ("beta_y", -0.00339, -0.0034)],
        headers=("gyro", "estimate", "truth"), units=("", "deg/h", "deg/h"),
    )
"""

import math


def format_value(value, fmt: str = ".6g") -> str:
    """One cell: numbers with ``fmt``, None as ``n/a``, booleans as yes/no."""
    if value is None:
        return "n/a"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if hasattr(value, "item") and getattr(value, "ndim", 0) == 0:
        value = value.item()
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        return "nan" if math.isnan(value) else format(value, fmt)
    return str(value)


def format_table(rows, headers, units=None, fmt: str = ".6g", indent: int = 0) -> str:
    """Rows as an aligned plain-text table.

    Parameters
    ----------
    rows : sequence of sequence
        Cells: numbers (right-aligned, formatted with ``fmt``), text
        (left-aligned), None (``n/a``).
    headers : sequence of str
        Column titles.
    units : sequence of str, optional
        Unit per column, shown under the title as ``[unit]`` (empty: none).
    fmt : str
        Number format, e.g. ``".6g"`` or ``".3e"``.
    indent : int
        Spaces before every line.

    Returns
    -------
    str
        Lines joined with newlines (no trailing newline).
    """
    rows = [list(r) for r in rows]
    ncol = len(headers)
    if any(len(r) != ncol for r in rows):
        raise ValueError(f"every row needs {ncol} cells")
    numeric = [
        bool(rows) and all(_is_number(r[c]) or r[c] is None for r in rows) for c in range(ncol)
    ]
    head = [list(headers)]
    if units is not None and any(units):
        head.append([f"[{u}]" if u else "" for u in units])
    body = [[format_value(v, fmt) for v in r] for r in rows]
    widths = [max(len(line[c]) for line in head + body) for c in range(ncol)]
    pad = " " * indent

    def line(cells):
        parts = [
            cell.rjust(widths[c]) if numeric[c] else cell.ljust(widths[c])
            for c, cell in enumerate(cells)
        ]
        return (pad + "  ".join(parts)).rstrip()

    rule = pad + "  ".join("-" * w for w in widths)
    return "\n".join([*(line(h) for h in head), rule, *(line(b) for b in body)])


def _is_number(value) -> bool:
    if hasattr(value, "item") and getattr(value, "ndim", 0) == 0:
        value = value.item()
    return isinstance(value, int | float) and not isinstance(value, bool)


def _heading(text: str, char: str = "-") -> str:
    return f"{text}\n{char * len(text)}"


def checks_table(checks) -> str:
    """The checks as a table: number, expression, tested value, PASS/FAIL (reason)."""
    rows = []
    for i, c in enumerate(checks):
        outcome = "PASS" if c["passed"] else "FAIL"
        if c.get("reason"):
            outcome += f" ({c['reason']})"
        rows.append((i, c["name"], c.get("value"), outcome))
    return format_table(rows, headers=("#", "check", "value", "result"))


def build_report(provenance: dict, body: str, warnings=(), checks=()) -> str:
    """The full report text.

    Parameters
    ----------
    provenance : dict
        From :func:`inins.io.provenance.make_provenance`.
    body : str
        The method's report (:attr:`CommandResult.report`).
    warnings : sequence of str
    checks : list of dict
        Evaluated checks.

    Returns
    -------
    str
        Plain text ending in a newline.
    """
    title = f"inins {provenance['command']} report"
    overrides = provenance.get("scenario_overrides") or []
    header = format_table(
        [
            ("command", provenance["command"]),
            ("version", f"inins {provenance['inins_version']}"),
            ("created", provenance["created_utc"]),
            ("scenario", provenance["scenario_source"]),
            *(("override", f"--set {o}") for o in overrides),
            ("seed", str(provenance["seed"])),
        ],
        headers=("", ""),
    ).split("\n")[2:]
    parts = [_heading(title, "="), "\n".join(header)]
    if body.strip():
        parts.append(body.rstrip())
    if warnings:
        parts.append(_heading("Warnings") + "\n" + "\n".join(f"- {w}" for w in warnings))
    if checks:
        passed = sum(c["passed"] for c in checks)
        verdict = "PASSED" if passed == len(checks) else "FAILED"
        parts.append(
            _heading("Checks") + "\n" + checks_table(checks)
            + f"\n\n{verdict}: {passed} of {len(checks)} checks passed"
        )
    return "\n\n".join(parts) + "\n"

"""The text report ``OUTDIR/CMD.txt``: header, the command's body, warnings, checks.

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

Command modules build the body with :func:`inins.results.format_table`, e.g.::

    format_table(
        [("beta_x", 0.00161, 0.0016), ("beta_y", -0.00339, -0.0034)],
        headers=("gyro", "estimate", "truth"), units=("", "deg/h", "deg/h"),
    )
"""

from inins.results import format_table


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


def build_report(provenance: dict, body: str, warnings=(), checks=(), files=()) -> str:
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
    files : sequence of str
        The files this run writes into its folder (the report lists them: the folder
        holds these and no other file of an earlier run of the command).

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
            _heading("Checks")
            + "\n"
            + checks_table(checks)
            + f"\n\n{verdict}: {passed} of {len(checks)} checks passed"
        )
    if files:
        parts.append(_heading("Files") + "\n" + "\n".join(f"- {name}" for name in files))
    return "\n\n".join(parts) + "\n"

"""Terminal output of the CLI (rich): run outcome, summaries, dataset listings.

User text is never parsed as rich markup (key paths like ``bias_dph[1]`` and
check expressions would be mangled).

The outcome of a run printed to a pipe or a file (no colours, nothing to wrap) is
the text rich would print, made here without loading rich (:func:`plain_outcome`,
about a twentieth of a short run); a test compares the two on many summaries.
Where rich would colour, wrap or measure text (a terminal, ``FORCE_COLOR``, a table
wider than the console, any character other than printable ASCII) rich prints it.
"""

import os
import re
import sys

from inins.results import format_value

MAX_ROWS = 40
FEW = 12
"""Up to this many results are all shown."""


def console():
    """A console on the current stdout (created per call, so test runners capture it)."""
    from rich.console import Console

    return Console(highlight=False, soft_wrap=True)


def _sigma_name(name: str) -> str | None:
    """``beta_x_dph`` -> ``beta_x_sigma_dph`` (the 1-sigma result of a value), or None."""
    stem, _, unit = name.rpartition("_")
    return f"{stem}_sigma_{unit}" if stem else None


def shown_results(summary: dict) -> list[str]:
    """The results worth a row on the terminal: those with a truth or named in a check
    (all of them if there are at most :data:`FEW`); 1-sigma results go in a column."""
    results, truth = summary.get("results", {}), summary.get("truth", {})
    sigmas = {_sigma_name(n) for n in results} & set(results)
    names = [n for n in results if n not in sigmas]
    if len(names) <= FEW:
        return names
    checked = " ".join(c.get("name", "") for c in summary.get("checks", []))
    keep = [n for n in names if n in truth or re.search(rf"\b{re.escape(n)}\b", checked)]
    return keep or names[:FEW]


def _results_cells(summary: dict):
    """``(columns, rows, caption)`` of the results table, or None: columns are
    ``(title, justify)``, rows lists of cell strings."""
    results, truth = summary.get("results", {}), summary.get("truth", {})
    if not results:
        return None
    names = shown_results(summary)[:MAX_ROWS]
    has_truth = any(k in truth for k in names)
    has_sigma = any(_sigma_name(k) in results for k in names)
    columns = [("name", "left"), ("value", "right")]
    if has_sigma:
        columns.append(("1-sigma", "right"))
    if has_truth:
        columns += [("truth", "right"), ("error", "right")]
    rows = []
    for name in names:
        value = results[name]
        row = [name, format_value(value)]
        if has_sigma:
            row.append(format_value(results.get(_sigma_name(name))))
        if has_truth:
            true = truth.get(name)
            err = value - true if _numbers(value, true) else None
            row += [format_value(true), format_value(err)]
        rows.append(row)
    hidden = len(results) - len(names) - sum(_sigma_name(n) in results for n in names)
    caption = f"... {hidden} more in summary.json" if hidden > 0 else None
    return columns, rows, caption


def _check_cells(summary: dict):
    """``(columns, rows)`` of the checks table (the last cell of a row is ``(text,
    passed)``), or None."""
    checks = summary.get("checks", [])
    if not checks:
        return None
    rows = []
    for c in checks:
        result = "PASS" if c["passed"] else "FAIL"
        if c.get("reason"):
            result += f" ({c['reason']})"
        rows.append([c["name"], format_value(c.get("value")), (result, c["passed"])])
    return [("check", "left"), ("value", "right"), ("result", "left")], rows


def _rich_table(title, columns, rows, caption=None):
    from rich import box
    from rich.table import Table
    from rich.text import Text

    table = Table(
        title=title, title_justify="left", show_edge=False, pad_edge=False, box=box.SIMPLE_HEAD
    )
    for name, justify in columns:
        table.add_column(name, justify=justify)
    for row in rows:
        cells = []
        for cell in row:
            if isinstance(cell, tuple):  # a check's result: PASS green, FAIL bold red
                text, passed = cell
                verdict, rest = text[:4], text[4:]
                cell = Text(verdict, style="green" if passed else "bold red")
                cell.append(rest)
            else:
                cell = Text(cell)
            cells.append(cell)
        table.add_row(*cells)
    if caption is not None:
        table.caption = caption
    return table


def results_table(summary: dict):
    """The results that matter (:func:`shown_results`) with 1-sigma, truth and error where
    known (a rich Table, or None); the rest are in summary.json."""
    cells = _results_cells(summary)
    return None if cells is None else _rich_table("results", *cells)


def _numbers(*values) -> bool:
    return all(isinstance(v, int | float) and not isinstance(v, bool) for v in values)


def checks_table(summary: dict):
    """The checks with PASS/FAIL (a rich Table, or None)."""
    cells = _check_cells(summary)
    return None if cells is None else _rich_table("checks", *cells)


def _verdict(summary: dict):
    """``(text, passed)`` of the verdict line, or None without checks."""
    checks = summary.get("checks", [])
    if not checks:
        return None
    passed = sum(c["passed"] for c in checks)
    verdict = "PASSED" if summary.get("passed") else "FAILED"
    return f"{verdict}: {passed} of {len(checks)} checks passed", bool(summary.get("passed"))


def print_summary(summary: dict, out=None) -> None:
    """Results and checks tables, then the verdict."""
    from rich.text import Text

    out = out or console()
    for table in (results_table(summary), checks_table(summary)):
        if table is not None:
            out.print(table)
            out.print()
    verdict = _verdict(summary)
    if verdict is not None:
        text, passed = verdict
        out.print(Text(text, style="bold green" if passed else "bold red"))


def _outcome_lines(summary: dict, paths, elapsed_s: float):
    return (
        f"inins {summary['command']}: done in {elapsed_s:.1f} s "
        f"(scenario {summary['scenario']}, seed {summary['seed']})",
        "wrote " + ", ".join(str(p) for p in paths),
    )


def print_outcome(summary: dict, paths, elapsed_s: float) -> None:
    """What a finished run prints: summary, then the files written."""
    text = plain_outcome(summary, paths, elapsed_s)
    if text is not None:
        sys.stdout.write(text)
        sys.stdout.flush()
        return
    print_outcome_rich(summary, paths, elapsed_s, console())


def print_outcome_rich(summary: dict, paths, elapsed_s: float, out) -> None:
    """:func:`print_outcome` through rich, on console ``out``."""
    from rich.text import Text

    first, last = _outcome_lines(summary, paths, elapsed_s)
    out.print(Text(first))
    print_summary(summary, out)
    out.print(Text(last))


_PRINTABLE = re.compile(r"[ -~]*")
"""Printable ASCII: one terminal cell per character, nothing rich would interpret."""
_TERMINAL_ENV = ("FORCE_COLOR", "TTY_COMPATIBLE", "TTY_INTERACTIVE", "JUPYTER_COLUMNS")


def _console_width() -> int:
    """The width rich gives a console on a pipe: the first standard stream that is a
    terminal, ``COLUMNS`` if set, else 80 (rich's ``Console.size``)."""
    width = None
    for fd in (0, 1, 2):
        try:
            width, _ = os.get_terminal_size(fd)
        except (AttributeError, ValueError, OSError):
            pass
        else:
            break
    columns = os.environ.get("COLUMNS")
    if columns is not None and columns.isdigit():
        width = int(columns)
    return width or 80


def _plain_table(title, columns, rows, caption, width):
    """The lines rich prints for :func:`_rich_table` on a pipe, or None if rich would
    have to wrap or shorten a cell (wider than ``width``)."""
    cells = [[c[0] if isinstance(c, tuple) else c for c in row] for row in rows]
    header = [name for name, _ in columns]
    texts = [title, *header, *(c for row in cells for c in row), caption or ""]
    if not all(_PRINTABLE.fullmatch(text) and text.strip() == text for text in texts):
        return None  # rich strips or wraps at spaces at either end
    widths = [max(len(r[i]) for r in (header, *cells)) for i in range(len(columns))]
    total = sum(widths) + 3 * (len(columns) - 1)
    if total > width:
        return None
    justify = [j for _, j in columns]

    def line(row):
        return "   ".join(
            c.rjust(w) if j == "right" else c.ljust(w)
            for c, w, j in zip(row, widths, justify, strict=True)
        )

    lines = [title, line(header), "\u2500" * total, *(line(r) for r in cells)]
    if caption is not None:
        lines.append(caption)
    return lines


def _isatty(stream) -> bool:
    try:
        return stream is not None and stream.isatty()
    except (AttributeError, ValueError):  # no such method, or closed
        return False


def plain_outcome(summary: dict, paths, elapsed_s: float) -> str | None:
    """The text of :func:`print_outcome` as rich prints it on a pipe, or None where rich
    must print it (a terminal, forced colours, wrapping, characters other than
    printable ASCII)."""
    if os.name == "nt" or sys.stdout is None or any(k in os.environ for k in _TERMINAL_ENV):
        return None
    if _isatty(sys.stdout) or not hasattr(sys.stdout, "write"):
        return None
    first, last = _outcome_lines(summary, paths, elapsed_s)
    lines = [first]
    width = _console_width()
    results = _results_cells(summary)
    checks = _check_cells(summary)
    for title, cells in (("results", results), ("checks", checks and (*checks, None))):
        if cells is None:
            continue
        table = _plain_table(title, *cells, width)
        if table is None:
            return None
        lines += [*table, ""]
    verdict = _verdict(summary)
    if verdict is not None:
        lines.append(verdict[0])
    lines.append(last)
    if not (_PRINTABLE.fullmatch(first) and _PRINTABLE.fullmatch(last)):
        return None
    return "\n".join(lines) + "\n"


def print_datasets(datasets, out=None) -> None:
    """A listing of datasets: path, shape, dtype, units, frame, description."""
    from rich import box
    from rich.table import Table
    from rich.text import Text

    out = out or console()
    table = Table(
        title="datasets", title_justify="left", show_edge=False, pad_edge=False, box=box.SIMPLE_HEAD
    )
    for col in ("path", "shape", "dtype", "units", "frame", "description"):
        table.add_column(col, overflow="fold")
    for d in datasets:
        shape = "x".join(str(n) for n in d["shape"]) or "scalar"
        table.add_row(
            *(
                Text(str(v))
                for v in (d["path"], shape, d["dtype"], d["units"], d["frame"], d["description"])
            )
        )
    out.print(table)


class ProgressBar:
    """A transient progress bar on stderr for long runs: ``bar(done, total)``, labelled
    by phase (``bar.phase("simulate")``; each phase gets its own bar).

    Shown only on a terminal; in a pipe or a CI log it stays silent.
    """

    def __init__(self, label: str):
        self._label = label
        self._phase = "running"
        self._task = None
        self._last = 0
        self._progress = None
        if not (_isatty(sys.stderr) or any(k in os.environ for k in _TERMINAL_ENV)):
            return  # silent, and rich is not even loaded: rich would not show it either
        from rich.console import Console
        from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

        stderr = Console(stderr=True)
        if not stderr.is_terminal:
            return

        self._progress = Progress(
            TextColumn("{task.description}"),
            BarColumn(),
            TextColumn("{task.percentage:>3.0f}%"),
            TimeRemainingColumn(),
            console=stderr,
            transient=True,
        )

    def __enter__(self):
        if self._progress is not None:
            self._progress.__enter__()
        return self

    def __exit__(self, *exc):
        return self._progress is not None and self._progress.__exit__(*exc)

    def phase(self, name: str) -> None:
        """Start a new phase: later progress goes to a new bar labelled ``name``."""
        if self._progress is None:
            return
        if self._task is not None:
            self._progress.update(self._task, visible=False)
        self._phase, self._task, self._last = name, None, 0

    def __call__(self, done: int, total: int) -> None:
        if self._progress is None:
            return
        if self._task is not None and done < self._last:  # the work started over
            self.phase(self._phase)
        if self._task is None:
            self._task = self._progress.add_task(f"{self._label}: {self._phase}", total=total)
        self._last = done
        self._progress.update(self._task, completed=done, total=total)

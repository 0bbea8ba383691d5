"""Terminal output of the CLI (rich): run outcome, summaries, dataset listings.

User text is never parsed as rich markup (key paths like ``bias_dph[1]`` and
check expressions would be mangled).
"""

import re

from rich import box
from rich.console import Console
from rich.table import Table
from rich.text import Text

from inins.results import format_value

MAX_ROWS = 40
FEW = 12
"""Up to this many results are all shown."""


def console() -> Console:
    """A console on the current stdout (created per call, so test runners capture it)."""
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


def results_table(summary: dict) -> Table | None:
    """The results that matter (:func:`shown_results`) with 1-sigma, truth and error where
    known; the rest are in summary.json."""
    results, truth = summary.get("results", {}), summary.get("truth", {})
    if not results:
        return None
    names = shown_results(summary)[:MAX_ROWS]
    has_truth = any(k in truth for k in names)
    has_sigma = any(_sigma_name(k) in results for k in names)
    table = Table(
        title="results", title_justify="left", show_edge=False, pad_edge=False, box=box.SIMPLE_HEAD
    )
    table.add_column("name")
    table.add_column("value", justify="right")
    if has_sigma:
        table.add_column("1-sigma", justify="right")
    if has_truth:
        table.add_column("truth", justify="right")
        table.add_column("error", justify="right")
    for name in names:
        value = results[name]
        row = [Text(name), Text(format_value(value))]
        if has_sigma:
            row.append(Text(format_value(results.get(_sigma_name(name)))))
        if has_truth:
            true = truth.get(name)
            err = value - true if _numbers(value, true) else None
            row += [Text(format_value(true)), Text(format_value(err))]
        table.add_row(*row)
    hidden = len(results) - len(names) - sum(_sigma_name(n) in results for n in names)
    if hidden > 0:
        table.caption = f"... {hidden} more in summary.json"
    return table


def _numbers(*values) -> bool:
    return all(isinstance(v, int | float) and not isinstance(v, bool) for v in values)


def checks_table(summary: dict) -> Table | None:
    """The checks with PASS/FAIL."""
    checks = summary.get("checks", [])
    if not checks:
        return None
    table = Table(
        title="checks", title_justify="left", show_edge=False, pad_edge=False, box=box.SIMPLE_HEAD
    )
    for col, justify in (("check", "left"), ("value", "right"), ("result", "left")):
        table.add_column(col, justify=justify)
    for c in checks:
        result = Text("PASS", style="green") if c["passed"] else Text("FAIL", style="bold red")
        if c.get("reason"):
            result.append(f" ({c['reason']})")
        table.add_row(Text(c["name"]), Text(format_value(c.get("value"))), result)
    return table


def print_summary(summary: dict, out: Console | None = None) -> None:
    """Results and checks tables, then the verdict."""
    out = out or console()
    for table in (results_table(summary), checks_table(summary)):
        if table is not None:
            out.print(table)
            out.print()
    checks = summary.get("checks", [])
    if checks:
        passed = sum(c["passed"] for c in checks)
        style = "bold green" if summary.get("passed") else "bold red"
        verdict = "PASSED" if summary.get("passed") else "FAILED"
        out.print(Text(f"{verdict}: {passed} of {len(checks)} checks passed", style=style))


def print_outcome(summary: dict, paths, elapsed_s: float) -> None:
    """What a finished run prints: summary, then the files written."""
    out = console()
    out.print(
        Text(
            f"inins {summary['command']}: done in {elapsed_s:.1f} s "
            f"(scenario {summary['scenario']}, seed {summary['seed']})"
        )
    )
    print_summary(summary, out)
    out.print(Text("wrote " + ", ".join(str(p) for p in paths)))


def print_datasets(datasets, out: Console | None = None) -> None:
    """A listing of datasets: path, shape, dtype, units, frame, description."""
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
        stderr = Console(stderr=True)
        if not stderr.is_terminal:
            return  # silent: rich's progress machinery is not even loaded
        from rich.progress import BarColumn, Progress, TextColumn, TimeRemainingColumn

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

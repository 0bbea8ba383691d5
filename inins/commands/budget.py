"""What a run will cost, estimated from its scenario before it starts, and the limits.

Each command module may define ``estimate(scenario) -> Estimate``;
:func:`check_budget` refuses a run (exit 2, with the estimate) whose samples exceed
:data:`MAX_SAMPLES`, whose output would not fit the free disk, or whose memory
exceeds the memory available, unless the user passes ``--force``.
"""

from dataclasses import dataclass

from inins.exceptions import InputError, OutputError

MAX_SAMPLES = 1_000_000_000
"""Stated limit of IMU samples in one run (~48 GB of float64 increments)."""


@dataclass(frozen=True)
class Estimate:
    """Size of a run, estimated before it starts.

    Attributes
    ----------
    samples : int
        IMU samples simulated or read.
    output_bytes : int
        Upper bound of the output files (uncompressed datasets).
    memory_bytes : int
        Peak memory of the arrays the run holds at once.
    keys : str
        The scenario keys that set the size (named in a refusal).
    max_samples : int
        The command's stated limit of ``samples`` (None: :data:`MAX_SAMPLES`).
    what : str
        What ``samples`` counts (IMU samples, covariance steps, segments).
    """

    samples: int
    output_bytes: int
    memory_bytes: int
    keys: str
    max_samples: int | None = None
    what: str = "samples"

    def describe(self) -> str:
        """``3.2e+14 samples, output up to 15 PB, memory 4.5 EB``."""
        samples = f"{self.samples:.3g} {self.what}, " if self.samples else ""
        return (
            f"{samples}output up to {human_bytes(self.output_bytes)}, "
            f"memory about {human_bytes(self.memory_bytes)}"
        )


def human_bytes(n: float) -> str:
    """``1536`` -> ``1.5 kB`` (powers of 1024, named kB, MB, ...)."""
    n = float(n)
    for unit in ("B", "kB", "MB", "GB", "TB", "PB"):
        if abs(n) < 1024 or unit == "PB":
            return f"{n:.3g} {unit}" if unit != "B" else f"{int(n)} B"
        n /= 1024
    return f"{n:.3g} PB"


def check_budget(estimate: Estimate | None, outdir=None, force: bool = False) -> None:
    """Refuse a run that exceeds :data:`MAX_SAMPLES`, the free disk of ``outdir`` or the
    available memory (``force`` skips the check).

    Raises
    ------
    InputError
        Too many samples or too much memory (key: the scenario keys that set the size).
    OutputError
        The output would not fit on the disk of ``outdir``.
    """
    if estimate is None or force:
        return
    from inins.io.diskspace import available_memory, device_of, free_bytes

    said = f"this run would need {estimate.describe()}"
    hint = "; pass --force to run anyway"
    limit = MAX_SAMPLES if estimate.max_samples is None else estimate.max_samples
    if estimate.samples > limit:
        raise InputError(
            f"{said}: more than the limit of {limit:.3g} {estimate.what} per run{hint}",
            key=estimate.keys,
        )
    memory = available_memory()
    if memory is not None and estimate.memory_bytes > memory:
        raise InputError(
            f"{said}: more memory than the {human_bytes(memory)} available{hint}",
            key=estimate.keys,
        )
    if outdir is not None:
        free = free_bytes(outdir)
        if free is not None and estimate.output_bytes > free:
            raise OutputError(
                f"{said}: more than the {human_bytes(free)} free on {device_of(outdir)} "
                f"for {outdir}{hint}"
            )

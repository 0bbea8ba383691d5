"""What every command's figures share (matplotlib, the optional ``plot`` extra).

A figure function is ``f(result, path)``, or ``f(result, path, data)`` where ``data``
is the run's results file (still under its temporary name) for the series streamed
there rather than kept in the result; each command draws its own in
``<command>_figures.py`` and lists them in its ``FIGURES``. A function that declines
to draw raises :class:`Skipped` with the reason, one that belongs to another kind of
run of the command :class:`NotThisRun` (no file, no note).
"""


def pyplot():
    """``matplotlib.pyplot`` on the Agg backend (no display needed)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


_pyplot = pyplot  # the name inins.commands.noise_figures imports


def note_figure(path, text):
    """A figure of one line of text (a figure that has nothing to show says why)."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(6, 2))
    ax.axis("off")
    ax.text(0.5, 0.5, text, ha="center", va="center")
    fig.savefig(path, dpi=100, format="png")
    plt.close(fig)


class Skipped(Exception):
    """A figure not drawn, with the reason (all zero, nothing to show): the run writes no
    file for it and says why in its report."""


class NotThisRun(Skipped):
    """A figure of another kind of run of the command (run-ekf's tight figures in a
    ``post:`` run and the other way): no file, and nothing to say in the report."""

"""Sweeps and batch runs (spec §8): grids, zipped axes and Monte Carlo seeds over a
command's scenario keys, run on local processes or a Dask cluster, resumable.

- :mod:`inins.sweep.plan`: the sweep file (:mod:`inins.scenario.sweep`) expanded
  into points (``--set`` overrides and a seed each), checked before anything runs;
- :mod:`inins.sweep.worker`: one point = :func:`inins.commands.execute.execute`, the
  function behind ``inins CMD``, so a point gives what the single command gives;
- :mod:`inins.sweep.executors`: local worker processes (default) and Dask;
- :mod:`inins.sweep.engine`: journal, resume, the table, the aggregates;
- :mod:`inins.sweep.aggregate`: statistics per axis value;
- :mod:`inins.sweep.check`: ``inins check``, the CI gate over scenario files.

Nothing here prints or exits (the CLI does); files are written through
:mod:`inins.io.sweep_files`.
"""

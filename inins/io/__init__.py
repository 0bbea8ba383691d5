"""Files at the edge: HDF5 results, table-data and log formats, reports, summaries.

Modules
-------
atomic        write-to-temporary-then-rename
hdf5          the results file: writer, storage layout, readers
hdf5_sink     streaming :class:`~inins.results.SeriesSink` (optionally threaded)
provenance    root attributes recording what made a file
summary       ``summary.json``
report        the text report ``CMD.txt``
resources     where the shipped scenarios (``configs/``) are
tabledata     the table-data layout of simulate-table / import-log / calibrate-bias
logformats    CSV, HDF5 and PSINS text logs, read in blocks
logimport     a lab log as typed chunks in SI
rinex_obs     RINEX 2.11 / 3.x GPS observation files (gzip read transparently)
rinex_nav     RINEX GPS navigation files
rinex_text    fixed-width RINEX text helpers
psins_tc      the PSINS tightly coupled MATLAB file
flight_layout the recorded-flight layout (IMU, GNSS epochs, ephemerides), declared once

Nothing here imports a method package, :mod:`inins.commands` or :mod:`inins.cli`.
"""

"""Observability of INS error-state models along piecewise-constant segments
(paper 002; Goshen-Meskin & Bar-Itzhack).

Pure numerics: imports only ``inins.core`` and ``inins.gnss``.

Modules
-------
:mod:`~inins.observability.models`        the model library (align12/10, nav15, ekf17/26)
:mod:`~inins.observability.measurements`  velocity, position, DD phase, range, range rate
:mod:`~inins.observability.segments`      segments, given or cut from a trajectory
:mod:`~inins.observability.pwcs`          TOM/SOM, rank, null space, Gramian
:mod:`~inins.observability.covariance`    Riccati covariance analysis, normalised eigen-analysis
:mod:`~inins.observability.analysis`      one call combining them, with per-state verdicts
"""

"""Observability of INS error-state models along piecewise-constant segments
(paper 002; Goshen-Meskin & Bar-Itzhack).

Pure numerics: imports only ``inins.core`` and ``inins.gnss``.
"""

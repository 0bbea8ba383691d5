"""Tightly coupled INS/GPS extended Kalman filters of paper 003 (run-ekf).

Pure numerics: imports only ``inins.core`` and ``inins.gnss``.
"""

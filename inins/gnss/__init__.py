"""GNSS measurement layer (spec §6a): GPS broadcast orbits, signal propagation,
pseudorange and range-rate models, single-point positioning and receiver simulation.

Pure numerics like :mod:`inins.core`: no file I/O, no CLI; imports only
``inins.core``. Readers of RINEX and recorded-flight files live in :mod:`inins.io`.
"""

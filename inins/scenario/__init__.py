"""Scenarios: loading YAML with line numbers, ``--set`` overrides, pydantic validation
with messages naming the key path and line, ``checks:`` expressions, lab units, and one
model module per command (``inins.scenario.<command>``).

Scenario models describe and validate; they never build method objects (the command
modules in :mod:`inins.commands` convert them to SI). Nothing here imports a method
package, :mod:`inins.commands` or :mod:`inins.cli`.
"""

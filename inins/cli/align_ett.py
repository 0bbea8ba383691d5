"""``inins align-ett``: placeholder until the method lands (see :mod:`inins.cli`).

A command module provides ``SCENARIO_MODEL`` (a
:class:`inins.io.scenario.ScenarioModel` subclass) and
``run(model, seed) -> CommandResult``. While ``SCENARIO_MODEL`` is None the
command prints "inins align-ett: not implemented yet in this version" and exits 2.
"""

SCENARIO_MODEL = None
run = None

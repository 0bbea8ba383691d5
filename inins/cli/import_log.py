"""``inins import-log``: a lab IMU log into the table-data layout (spec §3).

See :mod:`inins.io.logimport` (import), :mod:`inins.io.logcheck` (stationary
check) and :mod:`inins.io.scenarios.import_log` (scenario keys).
"""

from inins.io.logimport import import_log
from inins.io.scenarios.import_log import ImportLogScenario

SCENARIO_MODEL = ImportLogScenario


def run(model, seed, sink, progress=None):
    """Import the scenario's log, streaming the table-data layout into ``sink``.

    ``seed`` is unused (nothing is random).
    """
    return import_log(model.to_import(), sink, progress)

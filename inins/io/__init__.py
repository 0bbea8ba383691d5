"""Input and output at the edge: scenarios, HDF5 results, reports, summaries.

Modules
-------
scenario      typed scenario models (:class:`ScenarioModel`), :func:`load_scenario`
labunits      lab-unit key suffixes, SI factors, documentation checks
yaml_source   YAML with line numbers, ``--set`` overrides
validation    pydantic errors -> one :class:`~inins.exceptions.InputError`
checks        safe evaluation of the scenario's pass/fail ``checks``
atomic        write-to-temporary-then-rename
hdf5          the results file: writer, storage layout, readers
hdf5_sink     streaming :class:`~inins.results.SeriesSink` (optionally threaded)
provenance    root attributes recording what made a file
summary       ``summary.json``
report        the text report and :func:`format_table`
resources     where the shipped scenarios (``configs/``) are
tabledata     the table-data layout of simulate-table / calibrate-bias

The names below are importable from :mod:`inins.io` directly; each loads its
module on first use, so ``import inins.io`` stays cheap.
"""

import importlib

_EXPORTS = {
    "scenario": (
        "ScenarioModel", "ScenarioSection", "Positive", "NonNegative", "Vec3",
        "DEFAULT_SEED", "resolve_seed", "load_scenario", "CheckExpr",
    ),
    "labunits": ("UNIT_SUFFIXES", "unit_of", "to_si", "field_doc_problems"),
    "validation": ("KeyPathError",),
    "checks": ("evaluate_checks", "parse_check", "CheckSyntaxError"),
    "atomic": ("AtomicFile", "AtomicGroup", "write_text_atomic"),
    "hdf5": ("ResultsWriter", "open_results", "read_summary", "read_provenance",
             "list_datasets", "storage_options"),
    "hdf5_sink": ("H5SeriesSink",),
    "provenance": ("make_provenance", "PROVENANCE_KEYS"),
    "summary": ("build_summary", "summary_text", "write_summary", "json_scalar"),
    "report": ("build_report", "format_table", "format_value", "checks_table"),
    "resources": ("config_path", "configs_root", "available_configs"),
}
_WHERE = {name: module for module, names in _EXPORTS.items() for name in names}

__all__ = sorted(_WHERE)


def __getattr__(name):
    module = _WHERE.get(name)
    if module is None:
        raise AttributeError(f"module 'inins.io' has no attribute {name!r}")
    value = getattr(importlib.import_module(f"inins.io.{module}"), name)
    globals()[name] = value
    return value


def __dir__():
    return sorted(set(globals()) | set(__all__))

"""The exports of a run-ekf ``post:`` run (``post.export``): the forward and smoothed
trajectories with their 1-sigma as CSV, RTKLIB ``.pos`` and GeoJSON
(:mod:`inins.io.trajectory_export`), made from the results' datasets (on GNSS time) and
written by the runner through the atomic output contract, listed in the report's Files."""

from inins.gnss import timescales
from inins.io import trajectory_export as te

SOLUTIONS = ("forward", "smoothed")
NAMES = {
    "csv": tuple(f"run-ekf-{s}.csv" for s in SOLUTIONS),
    "pos": tuple(f"run-ekf-{s}.pos" for s in SOLUTIONS),
    "geojson": ("run-ekf.geojson",),
}
"""Files of each export format."""
OPTIONAL_FILES = tuple(n for names in NAMES.values() for n in names)


def trajectory(result, solution):
    """The :class:`~inins.io.trajectory_export.Trajectory` of ``solution`` (forward or
    smoothed) in a run's :class:`~inins.results.CommandResult`, None when absent."""
    d = result.datasets
    if f"post/{solution}/lla" not in d:
        return None
    a = result.attrs["post"]
    week, sow = a.get("time_origin_gps_week", 0), a.get("time_origin_gps_sow", 0.0)
    return te.Trajectory(
        name=solution,
        gps_seconds=week * te.WEEK + sow + d["post/time"].data,
        leap=timescales.leap_seconds_at(week, sow) if week > 0 else None,
        lla=d[f"post/{solution}/lla"].data,
        vel=d[f"post/{solution}/vel_n"].data,
        quat=d[f"post/{solution}/quat_nb"].data,
        sigma=d[f"post/{solution}/sigma"].data,
    )


def files(scenario):
    """``{name: function(result) -> text}`` of the formats in ``post.export`` (the
    smoothed files only with the smoother on)."""
    p = scenario.post
    if p is None:
        return {}
    solutions = SOLUTIONS if p.smoother == "rts" else SOLUTIONS[:1]
    out = {}
    for fmt in dict.fromkeys(p.export):
        if fmt == "geojson":
            out["run-ekf.geojson"] = lambda r, s=solutions: te.geojson_text(
                [trajectory(r, k) for k in s]
            )
            continue
        write = te.csv_text if fmt == "csv" else te.pos_text
        for k in solutions:
            out[f"run-ekf-{k}.{fmt}"] = lambda r, k=k, w=write: w(trajectory(r, k))
    return out

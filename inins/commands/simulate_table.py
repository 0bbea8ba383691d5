"""``inins simulate-table``: an IMU on a rate table (spec §3, 000 §2).

Streams :func:`inins.table.simulate.simulation_chunks` into the table-data layout
(:mod:`inins.io.tabledata`) and describes the run: step schedule, layout attributes,
summary numbers and the report.
"""

import numpy as np

from inins.commands import simulate_table_figures
from inins.commands._table import stream, table_estimate, table_layout
from inins.core.units import DEG_RTH, DPH, PPM, UG, UG_RTHZ
from inins.results import CommandResult, NullSink, format_table
from inins.scenario.si.table import table_simulation
from inins.scenario.simulate_table import SimulateTableScenario

SCENARIO_MODEL = SimulateTableScenario
FIGURES = {"simulate-table.png": simulate_table_figures.simulate_table_motion}
RESULT_NAMES = ("samples", "duration_s", "sample_rate_hz", "steps")
TRUTH_NAMES = tuple(
    f"{s}_bias_{a}_{u}" for s, u in (("gyro", "dph"), ("accel", "ug")) for a in "xyz"
)


def declared_results(scenario):
    """Names of the results and truth a run gives (checks are validated against them)."""
    return RESULT_NAMES, TRUTH_NAMES


def estimate(scenario):
    """Samples, output bytes and memory of the run (streamed: memory is a few chunks)."""
    return table_estimate(scenario, in_memory=False)


def run(scenario, seed, *, sink=None, progress=None):
    """Simulate the scenario, streaming the table-data layout into ``sink`` (kept in
    nothing when none is given)."""
    sim = table_simulation(scenario)
    stream(sim, np.random.default_rng(seed), NullSink() if sink is None else sink, progress)
    attrs, datasets = table_layout(sim)
    results = {
        "samples": sim.n_samples,
        "duration_s": sim.n_samples * sim.dt,
        "sample_rate_hz": sim.sample_rate,
        "steps": len(sim.trajectory.program.steps),
    }
    return CommandResult(
        command="simulate-table",
        results=results,
        truth=truth_scalars(sim.sensor),
        datasets=datasets,
        attrs=attrs,
        report=report(sim),
    )


def truth_scalars(sensor):
    """Sensor error truth in lab units for summary.json (deg/h, ug)."""
    out = {}
    for i, axis in enumerate("xyz"):
        out[f"gyro_bias_{axis}_dph"] = float(sensor.gyro_bias[i] / DPH)
        out[f"accel_bias_{axis}_ug"] = float(sensor.accel_bias[i] / UG)
    return out


def report(sim):
    """Report body: site, table, motion program, sensor errors."""
    lla = sim.trajectory.lla
    s = sim.sensor
    steps = [
        [
            st.index,
            st.kind,
            st.label,
            sim.gimbal_names[st.axis] if st.axis >= 0 else "",
            st.start,
            st.end,
            *np.degrees(st.angles_end),
        ]
        for st in sim.trajectory.program.steps
    ]
    gimbals = [f"{g} end" for g in sim.gimbal_names]
    sensors = [
        ["gyro bias", *(s.gyro_bias / DPH), "deg/h"],
        ["gyro ARW", *(s.gyro_arw / DEG_RTH), "deg/sqrt(h)"],
        ["gyro scale", *(s.gyro_scale / PPM), "ppm"],
        ["accel bias", *(s.accel_bias / UG), "ug"],
        ["accel VRW", *(s.accel_vrw / UG_RTHZ), "ug/sqrt(Hz)"],
        ["accel scale", *(s.accel_scale / PPM), "ppm"],
    ]
    lines = [
        f"site: latitude {np.degrees(lla[0]):.6f} deg, longitude {np.degrees(lla[1]):.6f} "
        f"deg, height {lla[2]:.1f} m",
        f"table: gimbals {', '.join(sim.gimbal_names)} (outer first)",
        f"IMU: {sim.sample_rate:g} Hz, {sim.n_samples} samples "
        f"({sim.n_samples * sim.dt:.1f} s); truth every {sim.truth_decimation} samples",
        "",
        "motion program",
        format_table(
            steps,
            ["#", "kind", "label", "axis", "start", "end", *gimbals],
            ["", "", "", "", "s", "s", *["deg"] * len(gimbals)],
            fmt=".6g",
        ),
        "",
        "sensor errors (truth)",
        format_table(sensors, ["term", "x", "y", "z", "unit"], fmt=".6g"),
    ]
    if sim.after_rotation is not None:
        lines += [
            "",
            "accelerometer bias change after each rotation: "
            f"{np.array2string(sim.after_rotation.step / UG, precision=1)} ug, "
            f"settling {sim.after_rotation.settle_time:g} s",
        ]
    if sim.trajectory.mounts:
        for m in sim.trajectory.mounts:
            lines.append(
                f"mount rotation: {np.degrees(m.angle):.6g} deg about body "
                f"{np.array2string(m.axis, precision=3)} from {m.start:g} s "
                f"over {m.duration:g} s"
            )
    return "\n".join(lines)

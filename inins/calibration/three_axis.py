"""All three gyro biases from two return sequences (issue 7 item 7; 000 §4 leaves the
vertical axis as future work).

The level sequence (000 Table 1, body z vertical) gives the two horizontal biases. A
second return sequence with the table's pitch gimbal at 90 deg puts body z horizontal
(and another body axis vertical); the same formulas with the axes permuted give beta_z
with the same automatic choice and mount check (:func:`inins.calibration.bias.calibrate_bias`
works on whichever body axis is vertical). Each sequence takes the vertical bias as known:
the pitched one from the level result (with its combined 1-sigma as the stated error of
the vertical bias), and the level one is run again with the beta_z found, so both carry
the other's result instead of a zero. Set the pitched sequence so that z points north at
its first position: eq. 38 then gives beta_z under any mount rotation.
"""

from dataclasses import dataclass, replace

import numpy as np

from inins.calibration import alignment, bias, budget, navigate, sequence
from inins.calibration.tilt_model import vertical_axis
from inins.exceptions import InputError


@dataclass(frozen=True)
class ThreeAxisOutcome:
    """The level calibration (run with the beta_z found) and the pitched one (or None)."""

    level: bias.Outcome
    pitched: bias.Outcome | None


def chosen_budgets(outcome):
    """``axis -> {term: 1-sigma rad/s, ..., "total": ...}`` of each chosen bias: the
    budget of the estimate the automatic choice took that axis from."""
    g = outcome.geometry
    if not outcome.seq.has_return:
        return {}
    source = {g.north: outcome.choice.east_formula or "eq38", g.east: outcome.choice.east_formula}
    out = {}
    for axis, name in source.items():
        if name is None or outcome.chosen.get(axis) is None:
            continue
        b = outcome.budgets[name]
        i = g.horizontal.index(axis)
        out[axis] = {t: float(b.terms[t][i]) for t in budget.TERMS} | {"total": float(b.total[i])}
    return out


def _down_axis_at(record, start, duration):
    """Body axis (index) along the vertical over ``duration`` s from ``start`` (s), from the
    mean specific force."""
    k0 = navigate.sample_index(record, start)
    k1 = max(k0 + 2, navigate.sample_index(record, start + duration))
    dtheta, dv = record.imu(k0, k1)
    _, f_b = alignment.mean_rates(dtheta, dv, record.dt)
    axis, _ = vertical_axis(alignment.level(f_b).T @ np.eye(3))
    return axis


def find_pitched(record, level, settings, labels=None):
    """First position of a later return sequence whose vertical body axis differs from
    the level one's, and that axis; None if there is none (``labels`` given: must exist)."""
    after = level.seq.positions[2].end if level.seq.has_return else np.inf
    try:
        a, _, _ = sequence.find_return_sequence(record, labels, after)
    except InputError:
        if labels is not None:
            raise
        return None
    axis = _down_axis_at(record, a.start + settings.settle, min(10.0, a.end - a.start))
    if axis == level.track.down_axis:
        if labels is not None:
            raise InputError(
                f"the sequence labelled {list(labels)} has the same vertical body axis as "
                "the level one: turn the pitch gimbal to 90 deg for beta_z",
                source=record.source,
                key="sequence.vertical_labels",
            )
        return None
    return after, axis


def calibrate_three_axis(record, settings, labels=None, progress=None):
    """Level calibration, then the pitched sequence for beta_z if the record has one.

    Parameters
    ----------
    record : inins.core.records.TableRecord
    settings : inins.calibration.bias.Settings
    labels : sequence of 3 str, optional
        Labels of the pitched sequence's holds; default: the first later return sequence
        with another vertical body axis.

    Returns
    -------
    ThreeAxisOutcome
    """
    level = bias.calibrate_bias(record, settings, progress)
    found = find_pitched(record, level, settings, labels)
    if found is None:
        return ThreeAxisOutcome(level, None)
    after, axis = found
    known = level.chosen.get(axis)
    u = chosen_budgets(level).get(axis, {}).get("total", settings.stated.gyro_bias_z)
    pitched = bias.calibrate_bias(
        record,
        replace(
            settings,
            labels=labels,
            start_after=after,
            bias_z=settings.bias_z if known is None else float(known[0]),
            stated=replace(settings.stated, gyro_bias_z=u),
        ),
        progress,
    )
    beta_z = pitched.chosen.get(2)
    if beta_z is None:
        return ThreeAxisOutcome(level, pitched)
    u_z = chosen_budgets(pitched)[2]["total"]
    level = bias.calibrate_bias(
        record,
        replace(
            settings, bias_z=float(beta_z[0]), stated=replace(settings.stated, gyro_bias_z=u_z)
        ),
        progress,
    )
    return ThreeAxisOutcome(level, pitched)

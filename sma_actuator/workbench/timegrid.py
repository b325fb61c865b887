# Copyright 2026 sma_actuator developers
#
# Licensed under the Apache License, Version 2.0 (the "License");
# you may not use this file except in compliance with the License.
# You may obtain a copy of the License at
#
#     http://www.apache.org/licenses/LICENSE-2.0
#
# Unless required by applicable law or agreed to in writing, software
# distributed under the License is distributed on an "AS IS" BASIS,
# WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
# See the License for the specific language governing permissions and
# limitations under the License.

"""
A dynamic record's signals on one uniform time grid.

A record whose steps vary by more than 1 % is resampled to its mean step
(`steady_columns`, `resample_columns`); missing positions are interpolated and left out of
fits and scores (`fill_missing_positions`, `measured_on_grid`); missing duties, ambient and
setpoints hold their last value (`hold_missing_signals`); sensor glitches are left out
(`leave_out_glitches`).
"""
from typing import Any, Optional, Tuple

import numpy as np

from . import limits
from .formats import (COUNTER_MIN_STEP_S, DataError, HELD_SIGNALS, MAX_BRIDGED_STEPS,
                      MIN_SAMPLES, PathLike)
from .glitches import glitch_mask, max_glitch_samples
from ..core.datakinds import uniform_steps


def leave_out_glitches(source: Any, cols: dict, scored: Optional[np.ndarray],
                       notes: Optional[list] = None) -> Optional[np.ndarray]:
    """
    Bridge the position's sensor glitches in `cols` (`glitches.glitch_mask`); return `scored`.

    A glitch lasts up to `glitches.max_glitch_samples` of the record's step. Each glitch
    sample takes the position interpolated from the samples around it and is neither
    fitted nor scored (False in the returned mask). notes receives a line with
    their number, the first one's time [s] and the clearance in % of the record's range
    (its unit may be settled only later, beside the other records).
    """
    time = cols['time']
    longest = max_glitch_samples(float(np.median(np.diff(time))))
    glitch, clearance = glitch_mask(cols['position'], longest)
    if not glitch.any():
        return scored
    keep = ~glitch
    cols['position'] = np.interp(time, time[keep], cols['position'][keep])
    if notes is not None:
        share = 100 * clearance / max(float(np.ptp(cols['position'])), clearance)
        notes.append(f'{source}: {np.count_nonzero(glitch)} position sample(s) (the first at '
                     f'{time[np.argmax(glitch)]:.3f} s) jump away by over {share:.2g} % of '
                     f"the record's range and back within {longest} samples: read "
                     'as sensor glitches, bridged, neither fitted nor scored '
                     '(--keep-glitches reads them as measured)')
    return keep if scored is None else scored & keep


def hold_missing_signals(path: PathLike, cols: dict, lines: np.ndarray,
                         notes: Optional[list] = None) -> None:
    """
    Fill the empty (NaN) rows of the duties, ambient and setpoint in `cols` by holding.

    Each row takes the signal's last value on a row before it (zero-order hold, as a
    controller holds a command and `load_bag` the bag's topics); before its first value a
    duty is 0 (a record starts at rest) and ambient and setpoint take that first value
    (`HELD_SIGNALS`). A column without any value is a duty of 0 throughout, or no ambient
    or setpoint at all. notes receives one line per column filled.
    """
    from ..bag.arrays import zero_order_hold

    rows = np.arange(len(cols['time']))
    for name, before in HELD_SIGNALS.items():
        values = cols.get(name)
        if values is None or not np.isnan(values).any():
            continue
        known = np.isfinite(values)
        if not known.any() and before is None:
            del cols[name]
            text = 'holds no value: left out'
        elif not known.any():
            cols[name] = np.full(rows.size, before)
            text = f'holds no value: {before:g} throughout'
        else:
            start = values[known][0] if before is None else before
            cols[name] = zero_order_hold(rows[known], values[known], rows, before=start)
            text = (f'is empty or NaN on {np.count_nonzero(~known)} row(s) (the first on line '
                    f'{lines[np.argmin(known)]}): held from the last value above it ('
                    + ('the first value' if before is None else f'{before:g}')
                    + ' before the first)')
        if notes is not None:
            notes.append(f'{path}: {name} {text}')


def fill_missing_positions(path: PathLike, cols: dict, lines: np.ndarray,
                           notes: Optional[list] = None) -> Optional[np.ndarray]:
    """
    Interpolate the positions a CSV lacks (NaN) in `cols`; return the measured times [s].

    None when every row has a position. The duties of such rows are known, so the model
    runs through them, as through a bag's gap (`load_bag`); which of them are scored is
    `measured_on_grid`'s. A record needs MIN_SAMPLES rows with a position.
    """
    position, time = cols['position'], cols['time']
    measured = np.isfinite(position)
    if measured.all():
        return None
    count = int(np.count_nonzero(measured))
    if count < MIN_SAMPLES:
        raise DataError(f'{path}: {count} row(s) with a position; a dynamic record needs at '
                        f'least {MIN_SAMPLES}')
    cols['position'] = np.interp(time, time[measured], position[measured])
    if notes is not None:
        notes.append(f'{path}: {position.size - count} row(s) without a position (NaN or '
                     f'empty; the first on line {lines[np.argmin(measured)]}): interpolated '
                     'from the rows around them, held at the ends')
    return time[measured]


def measured_on_grid(measured_time: np.ndarray, grid: np.ndarray) -> np.ndarray:
    """
    Return which times of `grid` [s] have a measured position (True), given its times [s].

    The bag's rule (`bag.arrays.unmeasured`): strictly inside a gap of more than
    MAX_BRIDGED_STEPS median steps between measured positions the interpolated position is
    no measurement; one missing reading is bridged. Before the first measured position and
    after the last there is none either.
    """
    from ..bag.arrays import unmeasured

    def ns(t: np.ndarray) -> np.ndarray:
        return np.round((t - measured_time[0]) * 1e9).astype(np.int64)

    # a resampled grid may end a rounding error after the last time
    slack = 1e-6 * float(np.median(np.diff(measured_time)))
    inside = (grid >= measured_time[0] - slack) & (grid <= measured_time[-1] + slack)
    return inside & ~unmeasured(ns(measured_time), ns(grid), MAX_BRIDGED_STEPS)


def check_time_unit(path: PathLike, time: np.ndarray) -> None:
    """
    `DataError` for a time column without a unit that may count milliseconds.

    Whole numbers at least COUNTER_MIN_STEP_S apart on average, within the rate limits: a
    logger's millisecond counter (``millis()``) at 100 Hz reads as a 0.1 Hz record in
    seconds, and a fit of it ends at the time constant's bound. Naming the unit
    (``time[ms]``, ``time[s]``) settles it; other columns are left to `check_time`.
    """
    if time.size < 2 or not np.all(np.isfinite(time)):
        return
    period = float((time[-1] - time[0]) / (time.size - 1))
    if (period < COUNTER_MIN_STEP_S or limits.period_problem(period)
            or not np.array_equal(time, np.round(time))):
        return
    raise DataError(f"{path}: column 'time' counts whole numbers {period:g} apart: "
                    f'{1 / period:g} Hz if seconds, {1e3 / period:g} Hz if milliseconds; name '
                    "its unit, time[ms] or time[s] (--column 'time[ms]=HEADER' names it without "
                    'editing the file)')


def check_time(path: PathLike, time: np.ndarray, lines: np.ndarray) -> Tuple[np.ndarray, float]:
    """
    Return (the time steps [s], their mean) of a time column; `DataError` naming the line.

    Time must rise strictly. The mean, duration / (samples − 1), is exact under clock
    jitter and rounded stamps; a dropped sample lengthens it by one part in the number of
    samples. It must lie within the rate limits.
    """
    steps = np.diff(time)
    bad = np.flatnonzero(steps <= 0)
    if bad.size:
        k = bad[0] + 1
        what = 'repeats' if steps[bad[0]] == 0 else 'goes back from'
        raise DataError(f"{path}: line {lines[k]}, column 'time': {time[k]:g} {what} "
                        f'{time[k - 1]:g} on line {lines[k - 1]} (time must increase strictly)')
    period = float((time[-1] - time[0]) / steps.size)
    problem = limits.period_problem(period)
    if problem:
        raise DataError(f"{path}: column 'time': mean {problem}; time is in seconds (or name "
                        'its unit: time[ms])')
    return steps, period


def steady_columns(path: PathLike, cols: dict, lines: np.ndarray) -> Tuple[dict, Optional[str]]:
    """
    Return (the columns on a steady time grid, a note saying what was done or None).

    Steps that `DynamicData` accepts as uniform (`datakinds.uniform_steps`) are kept as
    they are. Otherwise (clock jitter, stamps rounded to fewer digits than the rate needs,
    a dropped sample) the record is resampled at its mean step T from its first time
    (`resample_columns`: each duty the one in effect, other signals interpolated at their
    measured times). A step over MAX_BRIDGED_STEPS T is a gap: a `DataError` naming the
    line (split the record there).
    """
    time = cols['time']
    steps, period = check_time(path, time, lines)
    if uniform_steps(steps):
        return cols, None
    median = float(np.median(steps))
    gaps = np.flatnonzero(steps > MAX_BRIDGED_STEPS * period)
    if gaps.size:
        k = gaps[0] + 1
        raise DataError(f"{path}: line {lines[k]}, column 'time': a gap of {steps[k - 1]:g} s "
                        f'after {time[k - 1]:g} s, where the median step is {median:g} s '
                        '(samples are missing; split the record at the gap)')
    spread = float(np.max(np.abs(steps - period)) / period)
    return (resample_columns(cols, period),
            f'time steps vary by up to {100 * spread:.0f} % of the mean {period:.4g} s; '
            f'resampled to a steady {1.0 / period:.4g} Hz (duties held, the rest interpolated)')


def resample_columns(cols: dict, period: float) -> dict:
    """
    Return the columns on the grid time[0] + k period [s] up to the last time.

    Duties (zero-order hold) are the ones in effect at each new time; the other signals
    are interpolated linearly. Columns that are None stay None.
    """
    time = cols['time']
    t = np.arange(time[0], time[-1] + 0.5 * period, period)
    t = t[t <= time[-1] + 1e-9]
    held = np.clip(np.searchsorted(time, t, side='right') - 1, 0, len(time) - 1)
    out = {'time': t}
    for name, x in cols.items():
        if name != 'time':
            out[name] = None if x is None else (
                x[held] if name.startswith('duty') else np.interp(t, time, x))
    return out

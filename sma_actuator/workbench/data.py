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
Load workbench DATA: a dynamic CSV, a static curve CSV or an MCAP bag.

Formats (header row first; lines starting with '#' and blank lines are skipped, column
names are case-insensitive and spaces in them read as ``_``, column order is free, extra
columns are ignored; fields are separated by commas, or by semicolons, tabs or spaces when
the header row has no comma, and then a field with one comma and no point has a decimal
comma, ``0,25``; UTF-8, a Windows code page or UTF-16; a header written as the comment
above the numbers, as ``numpy.savetxt`` writes it, and a row of units under the header
are read, `tablelayout`):

* dynamic CSV  ``time,duty_a[,duty_b],position[,ambient_temperature][,setpoint]``
  (one wire: ``duty`` for ``duty_a`` when the header has neither duty_a nor duty_b);
  time strictly increasing, in s (or the unit of a ``time[ms]`` header, or ISO 8601
  clock times, `csv_table`); a record whose steps vary by more than 1 % (clock jitter,
  rounded stamps, one dropped sample) is resampled to its mean step (`timegrid`); a
  longer gap is an error; a row whose position is empty or NaN (a reading the sensor did
  not deliver) keeps its duties: the position is interpolated there and, over more than
  one row, neither fitted nor scored, as in a bag's gap; an empty or NaN duty, ambient
  or setpoint holds the value above it;
  duties [0, 1] (or ``duty_a[%]``, ``duty_a[1/255]`` for counts of a PWM timer whose top
  is 255), position and setpoint in the unit the header (``position[mm]``), a
  comment (``# ... position in mm``) or the caller names (default rad), ambient
  temperature [°C]; without duty_b (or with duty_b always 0) the rig is one wire against
  a bias spring (layout 'single');
* static CSV   ``input,output[,curve]`` or ``curve,voltage,deflection`` (quasi-static
  loops, e.g. the morphing-wing data: voltage [V] -> deflection [mm]); curve ids are
  integers, all rows belong to curve 0 without a curve column;
* MCAP bag     a ``.mcap`` file or a bag directory with the package's topics, read by
  `sma_actuator.bag.arrays.load_run`.

Every problem raises `DataError` (a ValueError, `formats`) whose message names the file
and, where there is one, the line (1-based, as an editor shows it) and the column. Units:
`units`.
"""
from pathlib import Path
from typing import Any, Dict, Iterable, Optional

import numpy as np

from . import limits
from .csv_table import base_name, comment_unit, read_csv_table, table_columns
from .formats import (COLUMN_HINT, COLUMN_NAMES, DataError, DYNAMIC_OPTIONAL, DYNAMIC_REQUIRED,
                      FORMATS_HELP, MAX_BRIDGED_STEPS, MAX_CURVE_ID, MCAP_MAGIC, MIN_SAMPLES,
                      PathLike, STATIC_LAYOUTS)
from .timegrid import (check_time_unit, fill_missing_positions, hold_missing_signals,
                       leave_out_glitches, measured_on_grid, steady_columns)
from .units import parse_unit, units_from_header
from ..core.datakinds import DynamicData, StaticData


def load_data(path: PathLike, rate_hz: Optional[float] = None,
              position_unit: Optional[str] = None, notes: Optional[list] = None,
              default_unit: str = 'rad', renames: Optional[Dict[str, str]] = None,
              keep_glitches: bool = False) -> Any:
    """
    Load DATA from `path`: a `DynamicData` (dynamic CSV or bag) or a `StaticData`.

    rate_hz: resampling rate [Hz] for bags (default: the joint-state rate); ignored for CSV.
    position_unit: overrides the unit the data names (header ``position[mm]``, a comment
    ``# ... position in mm``); default_unit: a CSV's unit when it names none ('' leaves
    that to the caller). notes: a list that receives a line when an unsteady record is
    resampled, a CSV's missing values are filled or its cut-off last row is left out, a
    bag was recovered from a cut-off or damaged file or has gaps in its joint states
    (`load_bag`). renames: a CSV's own column names -> the formats' names
    (`parse_column_map`). keep_glitches: read a dynamic record's sensor glitches as
    measured positions (`leave_out_glitches` bridges them by default). Raises `DataError`
    with a clear message on any problem.
    """
    path = Path(path)
    if not path.exists():
        raise DataError(f'{path}: no such file or directory')
    if is_bag(path):
        data = load_bag(path, rate_hz, notes, keep_glitches)
        if position_unit:
            data.position_unit = parse_unit(position_unit, path)
        return data
    if path.is_dir():
        raise DataError(f'{path}: is a directory without an .mcap file (expected a CSV file '
                        'or an MCAP bag)')
    header, rows, lines = read_csv_table(path, notes, renames)
    header, named, scales = units_from_header(path, header)
    for column, scale in scales.items():
        rows[:, header.index(column)] *= scale
    if 'time' in header:
        if 'time' not in scales:
            check_time_unit(path, rows[:, header.index('time')])
        unit = position_unit or named or comment_unit(path)
        return dynamic_from_table(path, header, rows, lines,
                                  parse_unit(unit, path) if unit else default_unit, notes,
                                  keep_glitches)
    if any(name in header for layout in STATIC_LAYOUTS for name in layout):
        return static_from_table(path, header, rows, lines)
    raise DataError(f'{path}: cannot tell the data kind from the header {", ".join(header)}; '
                    f'{FORMATS_HELP}; {COLUMN_HINT}')


def apply_layout(data: Any, layout: Optional[str], source: Any) -> None:
    """
    Set a dynamic record's rig layout to `layout` ('single' | 'antagonistic'; None: keep).

    Records are 'single' when duty_b is always 0 (`make_dynamic`); 'antagonistic' fits such
    a record as a pair whose wire b stays cold. DataError if 'single' meets a duty_b in use.
    """
    if not layout or not data.joinable:
        return
    if layout == 'single' and np.any(data.duty_b):
        raise DataError(f'{source}: --layout single, but duty_b is used (up to '
                        f'{np.max(data.duty_b):.3g})')
    data.layout = layout


def is_bag(path: PathLike) -> bool:
    """Return True if `path` is an MCAP file (suffix or magic bytes) or a folder with one."""
    path = Path(path)
    if path.is_dir():
        return any(path.glob('*.mcap'))
    if path.suffix.lower() == '.mcap':
        return True
    try:
        with open(path, 'rb') as fh:
            return fh.read(len(MCAP_MAGIC)) == MCAP_MAGIC
    except OSError as err:
        raise DataError(f'{path}: cannot read: {err.strerror}') from None


# ------------------------------------------------------------------------------ CSV
def parse_column_map(pairs: Iterable[str]) -> Dict[str, str]:
    """
    Return {header name: column name} from ``NAME=HEADER`` texts (``--column``).

    NAME is one of `COLUMN_NAMES`, with a unit if it takes one (``position[mm]``); HEADER is
    a file's own name for it (compared without case). ValueError names a malformed pair.
    """
    renames = {}
    for pair in pairs:
        name, sep, source = (part.strip() for part in pair.partition('='))
        if not sep or not source or base_name(name.lower()) not in COLUMN_NAMES:
            raise ValueError(f'{pair!r} is not NAME=HEADER with NAME one of '
                             f'{", ".join(COLUMN_NAMES)} (a unit may follow: position[mm])')
        if source.lower() in renames:
            raise ValueError(f'{source!r} is given twice (case is ignored)')
        renames[source.lower()] = name.lower()
    return renames


def dynamic_from_table(path: PathLike, header: list, rows: np.ndarray, lines: np.ndarray,
                       unit: str = 'rad', notes: Optional[list] = None,
                       keep_glitches: bool = False) -> DynamicData:
    """
    `DynamicData` from a parsed dynamic CSV, after time and duty checks naming the line.

    An unsteady time column is resampled (`steady_columns`) and sensor glitches are
    bridged unless kept (`leave_out_glitches`); notes receives the lines saying so.
    """
    cols = table_columns(path, header, rows, DYNAMIC_REQUIRED, DYNAMIC_OPTIONAL)
    hold_missing_signals(path, cols, lines, notes)
    if 'duty_b' not in cols:   # one wire against a bias spring
        cols['duty_b'] = np.zeros(len(rows))
    if len(rows) < MIN_SAMPLES:
        raise DataError(f'{path}: {len(rows)} data row(s); a dynamic record needs at least '
                        f'{MIN_SAMPLES}')
    for name in ('duty_a', 'duty_b'):
        bad = np.flatnonzero((cols[name] < 0) | (cols[name] > 1))
        if bad.size:
            k = bad[0]
            raise DataError(f"{path}: line {lines[k]}, column '{name}': {cols[name][k]:g} is "
                            f'outside [0, 1] (duty is a fraction; name its unit: {name}[%] for '
                            f'a percentage, {name}[1/255] for counts of a PWM timer whose top '
                            'is 255)')
    measured_time = fill_missing_positions(path, cols, lines, notes)
    cols, note = steady_columns(path, cols, lines)
    if note and notes is not None:
        notes.append(f'{path}: {note}')
    scored = None
    if measured_time is not None:
        scored = measured_on_grid(measured_time, cols['time'])
        if scored.all():
            scored = None
        elif notes is not None:
            notes.append(f'{path}: the {np.count_nonzero(~scored)} samples in gaps of the '
                         f'position (over {MAX_BRIDGED_STEPS:g} median steps, or before its '
                         'first or after its last reading) are simulated but neither fitted '
                         'nor scored')
    if not keep_glitches:
        scored = leave_out_glitches(path, cols, scored, notes)
    return make_dynamic(path, cols, unit, scored=scored)


def make_dynamic(source: Any, cols: dict, unit: str = 'rad',
                 scored: Optional[np.ndarray] = None) -> DynamicData:
    """
    Return a `DynamicData` from a dict with the dynamic column names; errors name `source`.

    The layout is 'single' (one wire against a bias spring) when duty_b is always 0.
    scored: the measured samples (None: all of them).
    """
    layout = 'single' if not np.any(cols['duty_b']) else 'antagonistic'
    try:
        return DynamicData(cols['time'], cols['duty_a'], cols['duty_b'], cols['position'],
                           ambient=cols.get('ambient_temperature'),
                           setpoint=cols.get('setpoint'), position_unit=unit, layout=layout,
                           scored=scored)
    except ValueError as err:
        raise DataError(f'{source}: {err}') from None


def static_from_table(path: PathLike, header: list, rows: np.ndarray,
                      lines: np.ndarray) -> StaticData:
    """`StaticData` from a parsed static CSV (either layout), curve ids checked."""
    layout = next((lay for lay in STATIC_LAYOUTS if all(c in header for c in lay)), None)
    if layout is None:
        want = ' or '.join(','.join(lay) for lay in STATIC_LAYOUTS)
        raise DataError(f'{path}: missing column(s): a static CSV needs {want} (found '
                        f'{", ".join(header)})')
    cols = table_columns(path, header, rows, tuple(layout), ('curve',))
    values = {field: cols[name] for name, field in layout.items()}
    if 'curve' in cols:
        curve = cols['curve']
        bad = np.flatnonzero((curve != np.round(curve)) | (curve < 0) | (curve > MAX_CURVE_ID))
        if bad.size:
            k = bad[0]
            raise DataError(f"{path}: line {lines[k]}, column 'curve': {curve[k]:g} is not a "
                            f'curve number (integer 0 to {MAX_CURVE_ID})')
        curve = curve.astype(int)
    else:
        curve = np.zeros(len(rows), int)
    return make_static(path, values['input'], values['output'], curve)


def make_static(source: Any, u: np.ndarray, y: np.ndarray, curve: np.ndarray) -> StaticData:
    """Return `StaticData(input, output, curve)`; needs an even (training) curve."""
    if not (curve % 2 == 0).any():
        raise DataError(f'{source}: no even-numbered curve to train on (curves train on even '
                        'ids and validate on odd ones)')
    for cid in np.unique(curve):
        if np.count_nonzero(curve == cid) < 2:
            raise DataError(f'{source}: curve {cid} has a single point (a curve needs at '
                            'least two)')
    try:
        return StaticData(u, y, curve)
    except ValueError as err:
        raise DataError(f'{source}: {err}') from None


# ------------------------------------------------------------------------------ bags
def load_bag(path: PathLike, rate_hz: Optional[float] = None,
             notes: Optional[list] = None, keep_glitches: bool = False) -> DynamicData:
    """
    `DynamicData` from an MCAP bag via `sma_actuator.bag.arrays.load_run`.

    The setpoint before the first setpoint message (NaN in load_run) is filled with the
    first setpoint; a bag without any setpoint message has none. Joint-state gaps longer
    than MAX_BRIDGED_STEPS median steps (the CSV's bridging rule) are not measured: their
    samples are simulated but neither fitted nor scored (`DynamicData.scored`), and so are
    sensor glitches unless kept (`leave_out_glitches`). notes: receives what a cut-off or
    damaged file kept and lost, those gaps, the glitches, whether the duty is the one the
    hardware applied (`/sma/applied_duty`) or the commands, and the commands a node held or
    clamped.
    """
    try:
        from ..bag.arrays import load_run
        arrays = load_run(path, rate_hz=rate_hz, notes=notes, bridged_steps=MAX_BRIDGED_STEPS)
    except ImportError as err:
        raise DataError(f'{path}: cannot read MCAP bags here ({err})') from None
    except ValueError as err:   # BagError and friends name the file already
        text = str(err)
        raise DataError(text if str(path) in text else f'{path}: {text}') from None
    except OSError as err:
        raise DataError(f'{path}: cannot read: {err.strerror or err}') from None
    setpoint = arrays.get('setpoint')
    if setpoint is not None:
        known = np.flatnonzero(np.isfinite(setpoint))
        if known.size == 0:
            arrays.pop('setpoint')
        else:
            arrays['setpoint'] = np.where(np.isfinite(setpoint), setpoint, setpoint[known[0]])
    if len(arrays['time']) >= 2:
        problem = limits.period_problem(float(arrays['time'][1] - arrays['time'][0]))
        if problem:
            raise DataError(f'{path}: resampled {problem}; choose --rate in that range')
    measured = arrays.pop('position_measured')
    if np.count_nonzero(measured) < MIN_SAMPLES:
        raise DataError(f'{path}: {np.count_nonzero(measured)} measured samples after '
                        f'resampling; a dynamic record needs at least {MIN_SAMPLES}')
    if notes is not None and not measured.all():
        notes.append(f'{path}: the {np.count_nonzero(~measured)} samples in the gaps are '
                     'simulated but neither fitted nor scored')
    scored = None if measured.all() else measured
    if not keep_glitches:
        scored = leave_out_glitches(path, arrays, scored, notes)
    return make_dynamic(path, arrays, scored=scored)


# ------------------------------------------------------------------------------ checks
def check_excitation(data: Any, source: str = 'DATA', to_fit: bool = True) -> None:
    """
    Raise `DataError` if the record cannot identify the model: constant output or input.

    to_fit False: if it cannot test a fitted model (`excitation_problem`).
    """
    problem = data.excitation_problem(to_fit)
    if problem:
        raise DataError(f'{source}: too little excitation: {problem}')


def describe(data: Any) -> str:
    """One line saying what was loaded, e.g. 'dynamic record: 2400 samples at 40 Hz (60 s)'."""
    return data.describe()

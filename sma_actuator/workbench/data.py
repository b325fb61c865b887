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
  clock times, `_clock_column`); a record whose
  steps vary by more than 1 % (clock jitter, rounded stamps, one dropped sample) is
  resampled to its mean step (`steady_columns`); a longer gap is an error;
  a row whose position is empty or NaN (a reading the sensor did not deliver) keeps its
  duties: the position is interpolated there and, over more than one row, neither fitted
  nor scored, as in a bag's gap (`fill_missing_positions`, `measured_on_grid`); an
  empty or NaN duty, ambient or setpoint holds the value above it (`hold_missing_signals`);
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

Every problem raises `DataError` (a ValueError) whose message names the file and, where
there is one, the line (1-based, as an editor shows it) and the column.
"""
import csv
from dataclasses import replace
import datetime
import os
from pathlib import Path
import re
from typing import Any, Dict, Iterable, Optional, Tuple, Union

import numpy as np

from . import limits
from .glitches import glitch_mask, max_glitch_samples
from .tablelayout import (binary_kind, column_name, decode_text, field_separator,
                          join_unit_tokens, unit_field)
from ..core.datakinds import DynamicData, StaticData, uniform_steps

DYNAMIC_REQUIRED = ('time', 'duty_a', 'position')
# without duty_b (or with duty_b always 0) the rig is one wire against a bias spring
DYNAMIC_OPTIONAL = ('duty_b', 'ambient_temperature', 'setpoint')
#: position units the workbench knows (lower-case spelling -> how it is shown)
UNITS = {'rad': 'rad', 'mrad': 'mrad', 'deg': 'deg', 'degree': 'deg', 'degrees': 'deg',
         'm': 'm', 'cm': 'cm', 'mm': 'mm', 'um': 'um', 'µm': 'um', 'in': 'in', 'v': 'V',
         'mv': 'mV', 'counts': 'counts', '%': '%', '°': 'deg'}
#: position units of one quantity convert into each other: unit -> (quantity, its size in
#: the quantity's first unit here: mm, rad, V)
UNIT_SIZES = {'mm': ('length', 1.0), 'm': ('length', 1000.0), 'cm': ('length', 10.0),
              'um': ('length', 1e-3), 'in': ('length', 25.4), 'rad': ('angle', 1.0),
              'mrad': ('angle', 1e-3), 'deg': ('angle', np.pi / 180.0),
              'V': ('voltage', 1.0), 'mV': ('voltage', 1e-3)}
# a unit in a column name: position[mm], position [mm], position (mm), time [s], duty_a[%]
_UNIT_IN_NAME = re.compile(r'^(time|position|setpoint|duty_a|duty_b|duty|ambient_temperature)'
                           r'\s*[\[(]\s*([^\])]*?)\s*[\])]$')
# a unit as a name suffix: position_mm, time_ms (only units these columns know)
_UNIT_SUFFIX = re.compile(r'^(time|position|setpoint)_([a-zµ]+)$')
#: time units a header may name -> seconds per unit
TIME_UNITS = {'s': 1.0, 'sec': 1.0, 'ms': 1e-3, 'us': 1e-6, 'µs': 1e-6, 'ns': 1e-9}
#: duty units a header may name -> fraction per unit
DUTY_UNITS = {'-': 1.0, '1': 1.0, 'fraction': 1.0, '%': 0.01}
# ... and counts of a PWM timer whose top is N: duty_a[1/255] (a fraction of 1/N per unit)
_DUTY_COUNTS = re.compile(r'1/([1-9][0-9]{0,6})')
#: ambient temperature units a header may name (the model works in °C)
AMBIENT_UNITS = dict.fromkeys(('°c', 'degc', 'c'), 1.0)
# the unit table and its name in messages of each column a header may give a scaled unit
_SCALED_COLUMNS = {'time': (TIME_UNITS, 'time'), 'duty_a': (DUTY_UNITS, 'duty'),
                   'duty_b': (DUTY_UNITS, 'duty'), 'duty': (DUTY_UNITS, 'duty'),
                   'ambient_temperature': (AMBIENT_UNITS, 'ambient')}
# a time field that is a clock time, after a date or alone (ISO 8601):
# 2026-12-04T13:36:54.120, 2026-12-04 13:36:54+01:00, 13:36:54.120
_CLOCK_TIME = re.compile(r'(\d{4}-\d{2}-\d{2}[T ])?\d{2}:\d{2}:\d{2}')
SECONDS_PER_DAY = 86400.0
# a unit in a comment line: '# ... Position in mm ...'
_UNIT_IN_COMMENT = re.compile(r'\bposition\s+in\s+([^\s,;.()]+)', re.IGNORECASE)
#: accepted static layouts: file column -> StaticData field
STATIC_LAYOUTS = ({'input': 'input', 'output': 'output'},
                  {'voltage': 'input', 'deflection': 'output'})
FORMATS_HELP = ('a dynamic CSV needs columns time,duty_a,duty_b,position'
                '[,ambient_temperature][,setpoint] (one wire: time,duty_a,position or '
                'time,duty,position); a static CSV input,output[,curve] or '
                'curve,voltage,deflection')
COLUMN_HINT = ('fit, compare, diagnose and batch read a column named otherwise: '
               '--column NAME=HEADER')
# a one-wire record may name its duty column plainly
SINGLE_DUTY = 'duty'
#: every column name the formats know (`--column NAME=HEADER` may give any of them)
COLUMN_NAMES = (*DYNAMIC_REQUIRED, *DYNAMIC_OPTIONAL, SINGLE_DUTY, 'curve',
                *dict.fromkeys(name for layout in STATIC_LAYOUTS for name in layout))
# a curve id is a label of a loop: far beyond any real count, and still an int64 when cast
MAX_CURVE_ID = 10**9
MIN_SAMPLES = 10
MCAP_MAGIC = b'\x89MCAP'
# an unsteady record is resampled only if no step exceeds this many mean steps (one
# dropped sample is bridged, a longer gap is not invented)
MAX_BRIDGED_STEPS = 2.5
# a time column without a unit, of whole numbers at least this far apart, may count ms [s]
COUNTER_MIN_STEP_S = 1.0
#: signals a logger may leave empty or NaN between their samples (written only when they
#: change, or streams of several rates merged on one time column) -> the value before the
#: first sample: each holds its last value, as a bag's duty, ambient and setpoint do
#: (`bag.arrays.load_run`, `load_bag`); None holds the first value backwards
HELD_SIGNALS = {'duty_a': 0.0, 'duty_b': 0.0, 'ambient_temperature': None, 'setpoint': None}
# columns whose empty or NaN fields are missing values, not malformed rows: a position the
# sensor did not deliver (interpolated) and the held signals (a one-wire `duty` is duty_a)
MAY_MISS = ('position', SINGLE_DUTY, *HELD_SIGNALS)

PathLike = Union[str, os.PathLike]


class DataError(ValueError):
    """DATA cannot be used as given; the message names file, line and column."""


def parse_unit(text: str, source: Any) -> str:
    """Return the canonical spelling of position unit `text`; `DataError` if unknown."""
    unit = UNITS.get(str(text).strip().lower())
    if unit is None:
        raise DataError(f'{source}: unknown position unit {text!r}; known: '
                        f'{", ".join(sorted(set(UNITS.values())))}')
    return unit


def unit_factor(unit: str, into: str) -> Optional[float]:
    """
    Return the factor that converts a position in `unit` into `into`, or None.

    y_into = factor · y_unit, factor = size(unit) / size(into) (`UNIT_SIZES`: 1 um =
    0.001 mm, 1 deg = π/180 rad); None for units of different quantities (mm and deg) or
    without a size (counts, %).
    """
    if unit == into:
        return 1.0
    have, want = UNIT_SIZES.get(unit), UNIT_SIZES.get(into)
    if have is None or want is None or have[0] != want[0]:
        return None
    return have[1] / want[1]


def in_unit(data: DynamicData, unit: str) -> Optional[DynamicData]:
    """
    Return `data` with position and setpoint in `unit` (`unit_factor`), or None.

    A copy when the unit changes; `data` itself in its own unit; None for a unit of
    another quantity.
    """
    factor = unit_factor(data.position_unit, unit)
    if factor is None or data.position_unit == unit:
        return data if factor is not None else None
    setpoint = None if data.setpoint is None else data.setpoint * factor
    return replace(data, position=data.position * factor, setpoint=setpoint,
                   position_unit=unit)


def comment_unit(path: PathLike) -> Optional[str]:
    """Return the unit named by a '# ... position in UNIT' comment of a CSV file, or None."""
    try:
        text = read_text(path)
    except DataError:
        return None
    for line in text.splitlines():
        if line.lstrip().startswith('#'):
            m = _UNIT_IN_COMMENT.search(line)
            if m:
                return m.group(1)
    return None


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
    header, named, scales = _units_from_header(path, header)
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
        if not sep or not source or _base_name(name.lower()) not in COLUMN_NAMES:
            raise ValueError(f'{pair!r} is not NAME=HEADER with NAME one of '
                             f'{", ".join(COLUMN_NAMES)} (a unit may follow: position[mm])')
        if source.lower() in renames:
            raise ValueError(f'{source!r} is given twice (case is ignored)')
        renames[source.lower()] = name.lower()
    return renames


def read_text(path: PathLike) -> str:
    """
    Return the text of a CSV file (`tablelayout.decode_text`); `DataError` if it is not one.

    UTF-8, a Windows code page or UTF-16 with its byte-order mark; a file over
    `limits.MAX_CSV_BYTES`, or holding binary data, is an error.
    """
    try:
        size = Path(path).stat().st_size
        if size > limits.MAX_CSV_BYTES:
            raise DataError(f'{path}: {size} bytes is over the limit of {limits.MAX_CSV_BYTES} '
                            'bytes for a CSV file (split or decimate the record)')
        raw = Path(path).read_bytes()
    except OSError as err:
        raise DataError(f'{path}: cannot read: {err.strerror}') from None
    text = decode_text(raw)
    if text is None:
        raise DataError(f'{path}: not a text CSV file ({binary_kind(raw)})')
    return text


def read_csv_table(path: PathLike, notes: Optional[list] = None,
                   renames: Optional[Dict[str, str]] = None) -> tuple:
    """
    Parse a numeric CSV: (header names lower-cased, float rows (n, m), file line numbers).

    renames: {header name: column name} (`parse_column_map`): the file's own names of the
    columns, read as the formats' names.

    Skips '#' comment lines and blank lines. Only the columns of the formats
    (`COLUMN_NAMES`) are read; the others are NaN. Raises `DataError` for an empty file, a
    column of the formats named twice, a row with the wrong number of fields, or a field
    read that is not a finite number; an empty or NaN position, duty, ambient or setpoint
    is a missing value (NaN, `MAY_MISS`). One exception: a file that ends inside its last row
    (no line end after it, as a log stopped while it was written) whose last row does not
    parse, or lacks a value, loses that row only; `notes` receives a line saying so.
    """
    text = read_text(path)
    all_lines = text.splitlines()
    numbered = [(i + 1, line) for i, line in enumerate(all_lines)
                if line.strip() and not line.lstrip().startswith('#')]
    if not numbered:
        raise DataError(f'{path}: empty file (no header row); {FORMATS_HELP}')
    if len(numbered) - 1 > limits.MAX_ROWS:
        raise DataError(f'{path}: {len(numbered) - 1} data rows is over the limit of '
                        f'{limits.MAX_ROWS} rows (split or decimate the record)')
    header_line, header_text = numbered[0]
    data_rows = numbered[1:]
    commented = _commented_header(path, all_lines, header_line, header_text, renames)
    if commented is not None:
        header_line, header_text = commented
        data_rows = numbered
    delimiter = field_separator(header_text)
    header = _header(_csv_fields(path, header_line, header_text, delimiter), delimiter,
                     renames)
    # beside another separator a comma is a decimal comma (a spreadsheet of many locales)
    decimal_comma = delimiter != ','
    if data_rows:
        with_units = _units_row(path, header, *data_rows[0], delimiter, decimal_comma)
        if with_units is not None:
            header, data_rows = with_units, data_rows[1:]
    _check_header(path, header_line, header)
    clock = _clock_column(path, header, data_rows, delimiter, notes)
    # other columns (a pandas index, a logger's state text) are neither read nor checked
    read = {h for h in header if _base_name(h) in COLUMN_NAMES}
    may_miss = {h for h in read if _base_name(h) in MAY_MISS}
    rows, lines = [], []
    progress = limits.LoadProgress(Path(path).name, len(data_rows))
    # no line end after the file's last line: it was cut off, perhaps inside that row
    cut_line = None if text.endswith(('\n', '\r')) else len(all_lines)
    for line_no, text_line in data_rows:
        try:
            # a missing value on the cut-off line is where the log stopped, not a reading
            rows.append(_parse_row(path, line_no, header,
                                   _csv_fields(path, line_no, text_line, delimiter), read,
                                   may_miss if line_no != cut_line else frozenset(),
                                   decimal_comma, clock))
        except DataError:
            if line_no != cut_line:
                raise
            if notes is not None:
                notes.append(f'{path}: the file ends inside line {line_no} (a log stopped '
                             f'while it was written): that row is left out, {len(rows)} '
                             'rows read')
            break
        lines.append(line_no)
        progress(len(rows))
    if not rows:
        raise DataError(f'{path}: no data rows after the header (line {header_line})')
    table = np.array(rows, float)
    if clock is not None:
        column = header.index(clock)
        table[:, column] = past_midnight(table[:, column])
    return header, table, np.array(lines)


def _csv_fields(path: PathLike, line_no: int, text: str,
                delimiter: Optional[str] = ',') -> list:
    """
    Split one CSV line into fields; a malformed or oversized field is a `DataError`.

    delimiter None splits at runs of whitespace (`tablelayout.field_separator`).
    """
    if delimiter is None:
        return text.split()
    try:
        return next(csv.reader([text], delimiter=delimiter), [])
    except csv.Error as err:
        raise DataError(f'{path}: line {line_no}: not a valid CSV row ({err})') from None


def _header(fields: list, delimiter: Optional[str],
            renames: Optional[Dict[str, str]]) -> list:
    """
    Return the column names of a header row's fields (`tablelayout.column_name`).

    A field `renames` names (``--column``) takes the formats' name it is given; a header
    split at whitespace has its bracketed units joined to their names first.
    """
    if delimiter is None:
        fields = join_unit_tokens(fields)
    renames = renames or {}
    names = []
    for field in fields:
        name = field.strip().lower()
        name = name if name in renames else column_name(field)
        names.append(renames.get(name, name))
    return names


def _commented_header(path: PathLike, all_lines: list, first_line: int, first_text: str,
                      renames: Optional[Dict[str, str]]) -> Optional[tuple]:
    """
    Return (line number, text) of a header written as a comment, or None.

    ``numpy.savetxt(..., header='time,duty_a,position')`` writes ``# time,duty_a,position``
    above its numbers. The comment line right above a first row that holds only numbers is
    the header when it splits into as many fields as that row and names two columns of the
    formats; any other comment stays a comment.
    """
    above = first_line - 2
    while above >= 0 and not all_lines[above].strip():
        above -= 1
    if above < 0 or not all_lines[above].lstrip().startswith('#'):
        return None
    text = all_lines[above].lstrip().lstrip('#').strip()
    delimiter = field_separator(text)
    try:
        names = _header(_csv_fields(path, above + 1, text, delimiter), delimiter, renames)
        row = _csv_fields(path, first_line, first_text, delimiter)
    except DataError:   # a comment that is no CSV row stays a comment
        return None
    numbers = all(_reads_as_number(f, delimiter != ',') for f in row)
    known = sum(_base_name(name) in COLUMN_NAMES for name in names)
    return (above + 1, text) if numbers and len(row) == len(names) and known >= 2 else None


def _units_row(path: PathLike, header: list, line_no: int, text: str,
               delimiter: Optional[str], decimal_comma: bool) -> Optional[list]:
    """
    Return the header with the units of the row under it, or None if that row is data.

    A data logger may write the units in a row of their own (``time,duty_a,position`` then
    ``s,%,mm``): a row whose fields under the formats' columns hold no number but the
    dimensionless ``1``, no clock time, and at least one word. Each unit joins its
    column's name (``duty_a[%]``), and goes the way of a unit in the name
    (`_units_from_header`); a column that names its unit already, or takes none
    (``curve``), keeps its name.
    """
    fields = _csv_fields(path, line_no, text, delimiter)
    if len(fields) != len(header):
        return None
    under = [field.strip() for name, field in zip(header, fields)
             if _base_name(name) in COLUMN_NAMES]
    words = [f for f in under if f and not _reads_as_number(f, decimal_comma)]
    if not words or any(f != '1' and _reads_as_number(f, decimal_comma) for f in under if f):
        return None
    if any(_CLOCK_TIME.match(f) for f in words):   # the first row of a clock-time column
        return None
    named = []
    for name, field in zip(header, fields):
        unit = unit_field(field)
        joined = f'{name}[{unit}]'
        takes_unit = (_unit_in_name(joined) or ('',))[0] == name
        named.append(joined if unit and takes_unit and not _unit_in_name(name) else name)
    return named


def _clock_column(path: PathLike, header: list, data_rows: list, delimiter: Optional[str],
                  notes: Optional[list]) -> Optional[str]:
    """
    Return the time column's name if it holds clock times, renamed to seconds; else None.

    A logger that stamps each row with the clock time, after the date or alone (ISO 8601:
    ``2026-12-04T13:36:54.120``, ``2026-12-04 13:36:54.120+01:00`` as Python's
    ``datetime.isoformat`` and pandas write them, or ``13:36:54.120``), gives the time in
    seconds once each stamp is read as seconds (`_clock_seconds`). `header` then names the
    column ``time[s]``, and `notes` receives a line.
    """
    names = [_base_name(name) for name in header]
    if 'time' not in names or not data_rows:
        return None
    column = names.index('time')
    fields = _csv_fields(path, data_rows[0][0], data_rows[0][1], delimiter)
    first = fields[column].strip() if column < len(fields) else ''
    if not _CLOCK_TIME.match(first):
        return None
    header[column] = 'time[s]'
    if notes is not None:
        notes.append(f"{path}: column 'time' holds clock times (the first {first}): read as "
                     'seconds from it')
    return header[column]


def past_midnight(seconds: np.ndarray) -> np.ndarray:
    """
    Return clock times of day [s] that pass midnight counted on: +86400 s from each pass.

    A step back by more than 12 h is a new day: t[k] + 86400 · (number of such steps up to
    k). POSIX seconds never step back so far in a record, so they pass unchanged.
    """
    days = np.concatenate([[0], np.cumsum(np.diff(seconds) < -SECONDS_PER_DAY / 2)])
    return seconds + SECONDS_PER_DAY * days


def _clock_seconds(path: PathLike, line_no: int, text: str) -> float:
    """
    Return the seconds of a clock-time field; `DataError` if it is none.

    A date and time is POSIX seconds (a stamp without a zone counts as UTC: only the
    differences are used); a clock time alone is seconds from midnight (`past_midnight`
    counts on through midnight).
    """
    try:
        match = _CLOCK_TIME.match(text)
        if not match:
            raise ValueError(text)
        if not match.group(1):
            of_day = datetime.time.fromisoformat(text)
            return (of_day.hour * 3600.0 + of_day.minute * 60.0 + of_day.second
                    + of_day.microsecond * 1e-6)
        stamp = datetime.datetime.fromisoformat(text)
    except ValueError:
        raise DataError(f"{path}: line {line_no}, column 'time': {text[:40]!r} is not a clock "
                        "time as the first row's (ISO 8601: 2026-12-04T13:36:54.120 or "
                        '13:36:54.120)') from None
    if stamp.tzinfo is None:
        stamp = stamp.replace(tzinfo=datetime.timezone.utc)
    return stamp.timestamp()


def _with_point(text: str, decimal_comma: bool) -> str:
    """Return a field with its decimal comma as a point (``0,25`` -> ``0.25``), if it has one."""
    comma = decimal_comma and text.count(',') == 1 and '.' not in text
    return text.replace(',', '.') if comma else text


def _reads_as_number(text: str, decimal_comma: bool) -> bool:
    """Return whether a field reads as a number, a decimal comma (``0,25``) included."""
    return _is_number(_with_point(text.strip(), decimal_comma))


def _base_name(name: str) -> str:
    """Return a header name without its unit (``position[mm]`` -> ``position``)."""
    return (_unit_in_name(name) or (name,))[0]


def _check_header(path: PathLike, line_no: int, header: list) -> None:
    """Raise `DataError` for a numeric header or a column of the formats named twice."""
    if all(_is_number(h) for h in header if h):
        raise DataError(f'{path}: line {line_no}: the first row holds numbers, not column '
                        f'names; {FORMATS_HELP}')
    seen = set()
    for h in header:
        if h in seen and _base_name(h) in COLUMN_NAMES:
            raise DataError(f"{path}: line {line_no}: column '{h}' appears twice in the header")
        seen.add(h)


def _is_number(text: str) -> bool:
    """Return True if `text` parses as a number."""
    return limits.is_number(text)


def _parse_row(path: PathLike, line_no: int, header: list, fields: list, read: set,
               may_miss: frozenset = frozenset(), decimal_comma: bool = False,
               clock: Optional[str] = None) -> list:
    """
    Return the finite numbers of one CSV row; `DataError` naming line and column.

    Only the columns in `read` are parsed; the others are NaN. A field of a column in
    `may_miss` that is empty or NaN is a missing value: NaN. decimal_comma: a field with
    one comma and no point is read with the comma as the point (``0,25``). clock: the
    column that holds clock times (`_clock_column`), read as seconds.
    """
    if len(fields) != len(header):
        raise DataError(f'{path}: line {line_no}: {len(fields)} field(s), the header has '
                        f'{len(header)} ({",".join(header)})')
    values = []
    for name, field in zip(header, fields):
        text = field.strip()
        if name not in read:
            values.append(np.nan)
            continue
        if not text and name in may_miss:
            values.append(np.nan)
            continue
        if not text:
            raise DataError(f"{path}: line {line_no}, column '{name}': empty value")
        if name == clock:
            values.append(_clock_seconds(path, line_no, text))
            continue
        try:
            value = limits.parse_number(_with_point(text, decimal_comma))
        except ValueError:
            raise DataError(f"{path}: line {line_no}, column '{name}': {text[:40]!r} is not a "
                            'number (write plain ASCII decimals such as 1.5 or 2e-3)') from None
        if np.isnan(value) and name in may_miss:
            values.append(np.nan)
            continue
        if not np.isfinite(value):
            raise DataError(f"{path}: line {line_no}, column '{name}': {text} (NaN or "
                            'infinite values are not allowed; drop or fill the row)')
        values.append(value)
    return values


def _columns(path: PathLike, header: list, rows: np.ndarray, needed: tuple,
             optional: tuple = ()) -> dict:
    """Return a dict name -> column of the needed (error if missing) and present optional names."""
    missing = [c for c in needed if c not in header]
    if missing:
        raise DataError(f'{path}: missing column(s) {", ".join(missing)} (found '
                        f'{", ".join(header)}); {FORMATS_HELP}; {COLUMN_HINT}')
    return {c: rows[:, header.index(c)] for c in (*needed, *optional) if c in header}


def _unit_in_name(name: str) -> Optional[tuple]:
    """Return (column, unit) of a header name carrying a unit (``time [ms]``), else None."""
    m = _UNIT_IN_NAME.match(name)
    if m:
        return m.group(1), m.group(2)
    m = _UNIT_SUFFIX.match(name)
    known = TIME_UNITS if m and m.group(1) == 'time' else UNITS
    return (m.group(1), m.group(2)) if m and m.group(2) in known else None


def _column_scale(path: PathLike, column: str, unit: str) -> float:
    """Return the factor to seconds (time), to a fraction (duties) or 1 (ambient in °C)."""
    table, what = _SCALED_COLUMNS[column]
    counts = _DUTY_COUNTS.fullmatch(unit) if what == 'duty' else None
    if counts:
        return 1.0 / int(counts.group(1))
    if unit not in table:
        also = ', 1/N (counts of a PWM timer whose top is N)' if what == 'duty' else ''
        raise DataError(f'{path}: unknown {what} unit {unit!r}; known: {", ".join(table)}'
                        f'{also} (column {column!r})')
    return table[unit]


def _units_from_header(path: PathLike, header: list) -> tuple:
    """
    Return (header with units stripped, the position unit or None, {column: scale}).

    Units in brackets or parentheses (``time [ms]``, ``duty_a[%]``, ``position (mm)``) or as
    a suffix of time and position (``time_ms``, ``position_mm``). Scales convert time to
    seconds and duties to fractions. A plain ``duty`` column is duty_a when the header has
    no duty_a and no duty_b (one wire).
    """
    out, unit, scales = [], None, {}
    for h in header:
        named = _unit_in_name(h)
        column = named[0] if named else h
        if named and column in ('position', 'setpoint'):
            if unit is not None and named[1] != unit:
                raise DataError(f'{path}: position and setpoint columns name different units '
                                f'({unit}, {named[1]})')
            unit = named[1]
        elif named:
            scales[column] = _column_scale(path, column, named[1])
        out.append(column)
    if SINGLE_DUTY in out and not {'duty_a', 'duty_b'} & set(out):
        out[out.index(SINGLE_DUTY)] = 'duty_a'
        if SINGLE_DUTY in scales:
            scales['duty_a'] = scales.pop(SINGLE_DUTY)
    return out, unit, scales


def dynamic_from_table(path: PathLike, header: list, rows: np.ndarray, lines: np.ndarray,
                       unit: str = 'rad', notes: Optional[list] = None,
                       keep_glitches: bool = False) -> DynamicData:
    """
    `DynamicData` from a parsed dynamic CSV, after time and duty checks naming the line.

    An unsteady time column is resampled (`steady_columns`) and sensor glitches are
    bridged unless kept (`leave_out_glitches`); notes receives the lines saying so.
    """
    cols = _columns(path, header, rows, DYNAMIC_REQUIRED, DYNAMIC_OPTIONAL)
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
    cols = _columns(path, header, rows, tuple(layout), ('curve',))
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
    damaged file kept and lost, those gaps and the glitches.
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

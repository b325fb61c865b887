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
Read a text table into its header and rows of numbers (the CSV half of `data.load_data`).

Lines starting with '#' and blank lines are skipped, the header may be the comment above
the numbers and a row of units may follow it (`tablelayout` gives the encoding, separator
and names); clock-time stamps become seconds (`_clock_column`); a cut-off last row is left
out with a note; every other malformed row is a `DataError` naming its line and column.
"""
import csv
import datetime
from pathlib import Path
import re
from typing import Dict, Optional

import numpy as np

from . import limits
from .formats import COLUMN_HINT, COLUMN_NAMES, DataError, FORMATS_HELP, MAY_MISS, PathLike
from .tablelayout import (binary_kind, column_name, decode_text, field_separator,
                          join_unit_tokens, unit_field)
from .units import unit_in_name

# a time field that is a clock time, after a date or alone (ISO 8601):
# 2026-12-04T13:36:54.120, 2026-12-04 13:36:54+01:00, 13:36:54.120
_CLOCK_TIME = re.compile(r'(\d{4}-\d{2}-\d{2}[T ])?\d{2}:\d{2}:\d{2}')
SECONDS_PER_DAY = 86400.0
# a unit in a comment line: '# ... Position in mm ...'
_UNIT_IN_COMMENT = re.compile(r'\bposition\s+in\s+([^\s,;.()]+)', re.IGNORECASE)


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
    read = {h for h in header if base_name(h) in COLUMN_NAMES}
    may_miss = {h for h in read if base_name(h) in MAY_MISS}
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
    known = sum(base_name(name) in COLUMN_NAMES for name in names)
    return (above + 1, text) if numbers and len(row) == len(names) and known >= 2 else None


def _units_row(path: PathLike, header: list, line_no: int, text: str,
               delimiter: Optional[str], decimal_comma: bool) -> Optional[list]:
    """
    Return the header with the units of the row under it, or None if that row is data.

    A data logger may write the units in a row of their own (``time,duty_a,position`` then
    ``s,%,mm``): a row whose fields under the formats' columns hold no number but the
    dimensionless ``1``, no clock time, and at least one word. Each unit joins its
    column's name (``duty_a[%]``), and goes the way of a unit in the name
    (`units_from_header`); a column that names its unit already, or takes none
    (``curve``), keeps its name.
    """
    fields = _csv_fields(path, line_no, text, delimiter)
    if len(fields) != len(header):
        return None
    under = [field.strip() for name, field in zip(header, fields)
             if base_name(name) in COLUMN_NAMES]
    words = [f for f in under if f and not _reads_as_number(f, decimal_comma)]
    if not words or any(f != '1' and _reads_as_number(f, decimal_comma) for f in under if f):
        return None
    if any(_CLOCK_TIME.match(f) for f in words):   # the first row of a clock-time column
        return None
    named = []
    for name, field in zip(header, fields):
        unit = unit_field(field)
        joined = f'{name}[{unit}]'
        takes_unit = (unit_in_name(joined) or ('',))[0] == name
        named.append(joined if unit and takes_unit and not unit_in_name(name) else name)
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
    names = [base_name(name) for name in header]
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


def base_name(name: str) -> str:
    """Return a header name without its unit (``position[mm]`` -> ``position``)."""
    return (unit_in_name(name) or (name,))[0]


def _check_header(path: PathLike, line_no: int, header: list) -> None:
    """Raise `DataError` for a numeric header or a column of the formats named twice."""
    if all(_is_number(h) for h in header if h):
        raise DataError(f'{path}: line {line_no}: the first row holds numbers, not column '
                        f'names; {FORMATS_HELP}')
    seen = set()
    for h in header:
        if h in seen and base_name(h) in COLUMN_NAMES:
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


def table_columns(path: PathLike, header: list, rows: np.ndarray, needed: tuple,
                  optional: tuple = ()) -> dict:
    """Return a dict name -> column of the needed (error if missing) and present optional names."""
    missing = [c for c in needed if c not in header]
    if missing:
        raise DataError(f'{path}: missing column(s) {", ".join(missing)} (found '
                        f'{", ".join(header)}); {FORMATS_HELP}; {COLUMN_HINT}')
    return {c: rows[:, header.index(c)] for c in (*needed, *optional) if c in header}

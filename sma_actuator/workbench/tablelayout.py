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
How a logger or a scientific tool lays out a text table: encoding, separator, names, units.

The CSV reader (`csv_table.read_csv_table`) reads what these return. They cover what rigs'
loggers write besides a plain UTF-8 CSV: a Windows code page (``°C``, ``µm`` as single
bytes), UTF-16 with its byte-order mark (a spreadsheet's "Unicode text"), fields separated
by spaces (``numpy.savetxt``'s default, Octave, gnuplot), column names with spaces
(``Duty A``) and units written apart from the names (``time (s)`` as two tokens, a row of
units under the header); and a binary file given as a CSV is named by what it seems to be
(docs/workbench.md, "DATA formats").
"""
import codecs
import re
from typing import List, Optional

# tried in order on a file without a UTF-16 byte-order mark, before latin-1, which reads
# any byte: a file without NUL bytes is always text
TEXT_ENCODINGS = ('utf-8-sig', 'cp1252')
# field separators tried, in order, when the header row has no comma
OTHER_SEPARATORS = (';', '\t')
# what a binary file given as a CSV most likely is, by its first bytes, and what to do
BINARY_KINDS = (
    (b'PK\x03\x04', 'a zip archive: an .xlsx workbook? save the sheet as CSV'),
    (b'\xd0\xcf\x11\xe0', 'an OLE file: an .xls workbook? save the sheet as CSV'),
    (b'MATLAB', 'a MATLAB .mat file: write its arrays to a CSV (writematrix)'),
    (b'\x89HDF', 'an HDF5 file (a MATLAB v7.3 .mat?): write its arrays to a CSV'),
    (b'SQLite format 3\x00', 'an SQLite file: a rosbag2 .db3 bag? convert it to MCAP '
     '(ros2 bag convert)'),
)
# the part of a column name before its unit: 'Duty A [%]' -> 'Duty A', ' [%]'
_NAME_AND_UNIT = re.compile(r'([^\[(]*)(.*)', re.DOTALL)
# a unit written as its own token or field: '[mm]', '(s)', 'mm'
_BRACKETED = re.compile(r'^[\[(]\s*(.*?)\s*[\])]$')


def decode_text(raw: bytes) -> Optional[str]:
    """
    Return the text of a file's bytes, or None if they are not text.

    UTF-16 when the bytes start with its byte-order mark; otherwise the first of
    `TEXT_ENCODINGS` that decodes them (UTF-8, then the Windows code page 1252, then
    latin-1). Bytes holding a NUL outside UTF-16 are binary data (None).
    """
    if raw.startswith((codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE)):
        try:
            return raw.decode('utf-16')
        except UnicodeDecodeError:
            return None
    if b'\x00' in raw:
        return None
    for encoding in TEXT_ENCODINGS:
        try:
            return raw.decode(encoding)
        except UnicodeDecodeError:
            continue
    return raw.decode('latin-1')


def binary_kind(raw: bytes) -> str:
    """Return what binary data (`decode_text` None) most likely is, for the error line."""
    return next((kind for magic, kind in BINARY_KINDS if raw.startswith(magic)),
                'it holds binary data')


def field_separator(header_text: str) -> Optional[str]:
    """
    Return the field separator a header row uses; None for runs of spaces or tabs.

    A comma if the row has one, else a semicolon, else a tab, else whitespace when the row
    holds several words (``time duty_a position``), else a comma (one column).
    """
    if ',' in header_text:
        return ','
    found = next((sep for sep in OTHER_SEPARATORS if sep in header_text), None)
    if found is not None:
        return found
    return None if len(header_text.split()) > 1 else ','


def join_unit_tokens(tokens: List[str]) -> List[str]:
    """
    Return whitespace-split header tokens with each bracketed unit joined to its name.

    ``['time', '(s)', 'position', '[mm]']`` -> ``['time (s)', 'position [mm]']``: a
    header separated by spaces writes a name and its unit as two tokens.
    """
    names: List[str] = []
    for token in tokens:
        if names and _BRACKETED.match(token):
            names[-1] = f'{names[-1]} {token}'
        else:
            names.append(token)
    return names


def column_name(field: str) -> str:
    """
    Return a header field as the reader compares names: lower case, spaces in the name as _.

    ``'Duty A [%]'`` -> ``'duty_a [%]'``, ``'Ambient temperature'`` ->
    ``'ambient_temperature'``; the unit part and the space before it stay as written.
    """
    text = field.strip().lower()
    name, unit = _NAME_AND_UNIT.fullmatch(text).groups()
    joined = '_'.join(name.split())
    return joined + (' ' if unit and name != name.rstrip() else '') + unit


def unit_field(field: str) -> str:
    """Return the unit a units row writes for a column, without brackets (``'[mm]'`` -> mm)."""
    text = field.strip()
    m = _BRACKETED.match(text)
    return (m.group(1) if m else text).lower()

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
Units of the workbench's records: position units and their sizes, and units in headers.

A position is kept in the unit its DATA names (`parse_unit`; nothing is labelled rad
unless it is rad) and converted only between units of one quantity (`unit_factor`,
`in_unit`). Time, duty and ambient columns may name a unit in the header (``time[ms]``,
``duty_a[%]``, ``duty_a[1/255]``); `units_from_header` gives each column's scale.
"""
from dataclasses import replace
import re
from typing import Any, Optional

import numpy as np

from .formats import DataError, PathLike, SINGLE_DUTY
from ..core.datakinds import DynamicData

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


def unit_in_name(name: str) -> Optional[tuple]:
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


def units_from_header(path: PathLike, header: list) -> tuple:
    """
    Return (header with units stripped, the position unit or None, {column: scale}).

    Units in brackets or parentheses (``time [ms]``, ``duty_a[%]``, ``position (mm)``) or as
    a suffix of time and position (``time_ms``, ``position_mm``). Scales convert time to
    seconds and duties to fractions. A plain ``duty`` column is duty_a when the header has
    no duty_a and no duty_b (one wire).
    """
    out, unit, scales = [], None, {}
    for h in header:
        named = unit_in_name(h)
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

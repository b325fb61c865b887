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
What the workbench's DATA formats are: their columns and limits, and the one error type.

The readers (`data`, `csv_table`, `units`, `timegrid`) share these; a problem with DATA
raises `DataError`, whose message names the file, the line and the column.
"""
import os
from typing import Union

DYNAMIC_REQUIRED = ('time', 'duty_a', 'position')
# without duty_b (or with duty_b always 0) the rig is one wire against a bias spring
DYNAMIC_OPTIONAL = ('duty_b', 'ambient_temperature', 'setpoint')
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

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

"""Copies of a measured CSV with some of its position readings changed (glitches, gaps)."""
from pathlib import Path

#: Column of the position in the shared wire records (time, duty_a, duty_b, position)
POSITION_FIELD = 3


def edit_positions(source, path, edits):
    """
    Copy CSV `source` to `path` with {data row (0-based): old field -> new} on its position.

    Comment lines and the header are kept; the data rows count from the line after the
    header (the first line that starts with `time`).
    """
    lines = Path(source).read_text().splitlines()
    first = next(k for k, line in enumerate(lines) if line.startswith('time'))
    for k, edit in edits.items():
        fields = lines[first + 1 + k].split(',')
        fields[POSITION_FIELD] = edit(fields[POSITION_FIELD])
        lines[first + 1 + k] = ','.join(fields)
    path = Path(path)
    path.write_text('\n'.join(lines) + '\n')
    return path


def shifted(offset):
    """Return an edit of `edit_positions` that adds `offset` to a reading (4 decimals)."""
    return lambda field: f'{float(field) + offset:.4f}'

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
Input limits of workbench DATA, strict number parsing and load progress (docs/workbench.md).

Numbers in a CSV are plain ASCII decimals (``-1.5``, ``2e-3``, ``.5``): Python's ``float()``
also takes ``'١'`` (Arabic-Indic one), ``'１'`` (full-width one) and ``'1_0'`` (ten), which in
a measurement file are far more likely damage than intent.
"""
from __future__ import annotations

import re
import sys
import time
from typing import IO, Optional

#: Largest CSV read [bytes] (2 million rows of 6 columns take about 150 MB).
MAX_CSV_BYTES = 256 * 1024 * 1024
#: Most data rows read from a CSV.
MAX_ROWS = 2_000_000
#: Sample period range of a dynamic record [s] (10 kHz to 0.1 Hz).
MIN_SAMPLE_PERIOD_S = 1e-4
MAX_SAMPLE_PERIOD_S = 10.0
MIN_RATE_HZ = 1.0 / MAX_SAMPLE_PERIOD_S
MAX_RATE_HZ = 1.0 / MIN_SAMPLE_PERIOD_S
#: Records sampled faster are averaged down to this rate or below for fitting [Hz]: the
#: model's fastest dynamics (tens of ms) sit well inside its 50 Hz band, and diagnose's
#: detection is measured on records at 20 to 100 Hz.
MAX_FIT_RATE_HZ = 100.0
#: Files with at least this many rows report their load progress on stderr.
PROGRESS_MIN_ROWS = 100_000
PROGRESS_STEP_PERCENT = 10

_NUMBER = re.compile(r'[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?', re.ASCII)
_NON_FINITE = re.compile(r'[+-]?(?:nan|inf|infinity)', re.ASCII | re.IGNORECASE)


def parse_number(text: str) -> float:
    """
    Return the float an ASCII decimal number ``text`` spells; raise ValueError otherwise.

    ``nan``, ``inf`` and numbers beyond the float range parse (to NaN or infinity) so that the
    caller can name them; digits of other scripts, underscores and spaces inside do not.
    """
    if _NUMBER.fullmatch(text) or _NON_FINITE.fullmatch(text):
        return float(text)
    raise ValueError(f'{text[:40]!r} is not a number')


def is_number(text: str) -> bool:
    """Return whether ``text`` is a number as :func:`parse_number` reads it."""
    try:
        parse_number(text)
    except ValueError:
        return False
    return True


def period_problem(dt_s: float) -> Optional[str]:
    """Return why a sample period [s] is outside the limits, or None if it is fine."""
    if not MIN_SAMPLE_PERIOD_S <= dt_s <= MAX_SAMPLE_PERIOD_S:
        return (f'sample period {dt_s:g} s is outside {MIN_SAMPLE_PERIOD_S:g} s to '
                f'{MAX_SAMPLE_PERIOD_S:g} s ({MAX_RATE_HZ:g} Hz to {MIN_RATE_HZ:g} Hz)')
    return None


class LoadProgress:
    """
    Progress of reading a large file: one stderr line per 10 % with rows and seconds.

    Plain lines (no terminal control), so they read well in a log; files under
    :data:`PROGRESS_MIN_ROWS` rows stay silent.
    """

    def __init__(self, name: str, total_rows: int, stream: Optional[IO[str]] = None):
        self.name = name
        self.total = total_rows
        self.stream = stream or sys.stderr
        self.enabled = total_rows >= PROGRESS_MIN_ROWS
        self.next_percent = PROGRESS_STEP_PERCENT
        self.start = time.monotonic()

    def __call__(self, rows: int) -> None:
        """Report ``rows`` read so far (prints when the next 10 % step is reached)."""
        if not self.enabled or 100 * rows < self.next_percent * self.total:
            return
        percent = 100 * rows // self.total
        self.stream.write(f'sma-model: reading {self.name}: {percent} % ({rows} of '
                          f'{self.total} rows, {time.monotonic() - self.start:.1f} s)\n')
        self.stream.flush()
        self.next_percent = (percent // PROGRESS_STEP_PERCENT + 1) * PROGRESS_STEP_PERCENT

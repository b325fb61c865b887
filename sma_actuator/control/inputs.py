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

"""Validation of incoming setpoints and duties: reject bad values, keep the last valid one."""
from __future__ import annotations

import math
from typing import Any, Callable, Iterable, Optional


def setpoint_problem(value: Any, lower: float, upper: float) -> Optional[str]:
    """Why a setpoint [rad] is unusable (NaN, ±inf, outside [lower, upper]), or None if fine."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        return f'setpoint {value!r} is not a number'
    if not math.isfinite(x):
        return f'setpoint {x} is not finite'
    if not lower <= x <= upper:
        return f'setpoint {x:.4g} rad outside [{lower:.4g}, {upper:.4g}]'
    return None


def duty_problem(values: Iterable[float]) -> Optional[str]:
    """Why a duty pair is unusable (wrong length, NaN, ±inf, outside [0, 1]), or None."""
    values = list(values)
    if len(values) != 2:
        return f'duty must have 2 entries [duty_a, duty_b], got {len(values)}'
    for name, d in zip(('duty_a', 'duty_b'), values):
        if not math.isfinite(d):
            return f'{name} {d} is not finite'
        if not 0.0 <= d <= 1.0:
            return f'{name} {d:.4g} outside [0, 1]'
    return None


class LastValid:
    """Holds the last accepted value of an input stream and counts rejections."""

    def __init__(self, check: Callable[[Any], Optional[str]], initial: Any = None):
        self.check = check          # value -> problem string or None
        self.value = initial
        self.rejected = 0
        self.last_problem = None

    def offer(self, value: Any) -> Optional[str]:
        """Accept `value` if `check` finds no problem; return the problem (None if accepted)."""
        problem = self.check(value)
        if problem is None:
            self.value = value
        else:
            self.rejected += 1
            self.last_problem = problem
        return problem

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
Antagonistic split of a signed command into the two wire duties (Fig. 14).

u > 0 heats wire a (shaft towards +φ), u < 0 heats wire b: duty_a = clip(u, 0, lim_a),
duty_b = clip(−u, 0, lim_b). `exclusive` then enforces the invariant that the two wires
are never both driven above a threshold (two hot wires only fight each other and
overstress the pair): if both exceed it, the smaller one is cut to the threshold.
"""
from __future__ import annotations

from typing import Tuple

from ..core.validate import finite_scalar


def split(u: float, limit_a: float = 1.0, limit_b: float = 1.0) -> Tuple[float, float]:
    """Signed command u [duty] -> (duty_a, duty_b), each in [0, its limit]."""
    u = finite_scalar('u', u)
    return min(max(u, 0.0), limit_a), min(max(-u, 0.0), limit_b)


def exclusive(duty_a: float, duty_b: float, threshold: float) -> Tuple[float, float]:
    """Enforce min(duty_a, duty_b) <= threshold by cutting the smaller duty."""
    if duty_a > threshold and duty_b > threshold:
        if duty_a >= duty_b:
            duty_b = threshold
        else:
            duty_a = threshold
    return duty_a, duty_b

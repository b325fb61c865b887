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
On-off mode (the paper's six-legged robot): one wire fully heated, the other cooled.

The shaft is driven to one of its two end positions ("fully stretched / fully
contracted"), chosen by the setpoint: a relay, eq. (4) with thresholds ±band, on
r − φ0 (φ0: the model's rest angle). r − φ0 > band heats wire a (end at +φ), r − φ0 < −band
heats wire b, in between the previous choice is kept; the relay's hysteresis stops a
setpoint that dithers around φ0 from toggling the wires. The measured angle is not used:
the end stops (full contraction) are the positions.
"""
from __future__ import annotations

from ..core.validate import finite_scalar


class OnOffRelay:
    """Signed command ±on_duty from the setpoint offset r − φ0 [rad] with a ±band relay."""

    def __init__(self, band_rad: float = 0.05, on_duty: float = 1.0):
        self.band_rad = finite_scalar('band_rad', band_rad)
        self.on_duty = finite_scalar('on_duty', on_duty)
        if self.band_rad < 0 or not 0 <= self.on_duty <= 1:
            raise ValueError('band_rad must be >= 0 and on_duty in [0, 1]')
        self.reset()

    def reset(self) -> None:
        """Relay off (both wires cooling) until the setpoint leaves the band."""
        self.state = 0

    def step(self, offset_rad: float) -> float:
        """Signed command for r − φ0 [rad]: +on_duty heats a, −on_duty heats b, 0 both cool."""
        x = finite_scalar('offset_rad', offset_rad)
        if x > self.band_rad:
            self.state = 1
        elif x < -self.band_rad:
            self.state = -1
        return self.state * self.on_duty

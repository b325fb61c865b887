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

"""Potentiometer ADC counts to shaft angle and velocity, for the hardware bridge."""
from __future__ import annotations

import math

import numpy as np
from sma_actuator.hardware.mcu_core import elapsed_us


class AdcCalibration:
    """
    ADC counts -> shaft angle [rad].

    Linear: angle = offset_rad + scale_rad_per_count * counts. If `polynomial` is given
    (coefficients in rad, highest power of counts first, as numpy.polyval), it replaces
    the linear map, e.g. to correct a non-linear potentiometer track.
    """

    def __init__(self, offset_rad: float = 0.0, scale_rad_per_count: float = 1.0,
                 polynomial=()) -> None:
        self.offset_rad = float(offset_rad)
        self.scale_rad_per_count = float(scale_rad_per_count)
        self.polynomial = tuple(float(c) for c in polynomial)
        values = (self.offset_rad, self.scale_rad_per_count) + self.polynomial
        if not all(math.isfinite(v) for v in values):
            raise ValueError(f'ADC calibration must be finite: offset {offset_rad}, '
                             f'scale {scale_rad_per_count}, polynomial {list(polynomial)}')
        if not self.polynomial and self.scale_rad_per_count == 0:
            raise ValueError('ADC calibration scale_rad_per_count must not be 0')

    def angle_rad(self, counts: int) -> float:
        """Shaft angle [rad] for raw ADC counts."""
        if self.polynomial:
            return float(np.polyval(self.polynomial, counts))
        return self.offset_rad + self.scale_rad_per_count * counts


class VelocityEstimator:
    """
    Shaft velocity [rad/s]: finite differences over MCU tick times, low-passed.

    First-order filter with time constant tau_s (0: raw differences). Tick differences
    wrap like the MCU's uint32 microsecond counter.
    """

    def __init__(self, tau_s: float = 0.02) -> None:
        if not tau_s >= 0:
            raise ValueError(f'velocity filter tau_s must be >= 0, got {tau_s}')
        self.tau_s = float(tau_s)
        self.reset()

    def reset(self) -> None:
        """Forget the history (e.g. after a reconnect: MCU time may have restarted)."""
        self._last = None
        self.velocity_rad_s = 0.0

    def update(self, ticks_us: int, angle_rad: float) -> float:
        """Add a sample; returns the filtered velocity [rad/s]."""
        if self._last is not None:
            dt = elapsed_us(ticks_us, self._last[0]) * 1e-6
            if dt > 0:
                raw = (angle_rad - self._last[1]) / dt
                alpha = dt / (self.tau_s + dt)
                self.velocity_rad_s += alpha * (raw - self.velocity_rad_s)
        self._last = (ticks_us, angle_rad)
        return self.velocity_rad_s

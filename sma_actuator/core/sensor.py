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

"""Potentiometer on the output shaft read by an ADC (the feedback sensor of Fig. 14)."""
from typing import Optional, Union

import numpy as np
from numpy.typing import ArrayLike

from .validate import finite_scalar

#: span of the potentiometer and its ADC [rad]: the plant, the emulator and the hardware
#: bridge's default calibration (about ±1 rad of travel with margin)
POT_RANGE_RAD = (-1.2, 1.2)
#: resolution of the actuator's ADC [bit]
ADC_BITS = 12
#: no shaft angle beyond ±this is physical [rad] (half a turn with margin): readings and
#: setpoints outside are rejected as a broken sensor or a wrong unit
ANGLE_LIMIT_RAD = 3.2


class Potentiometer:
    """
    Linear potentiometer + `bits`-bit ADC spanning [angle_min_rad, angle_max_rad].

    counts = round((φ − φ_min) / (φ_max − φ_min) · (2^bits − 1)), clipped to the ADC range,
    with optional Gaussian noise of `noise_rad` added to φ before conversion.
    """

    def __init__(self, bits: int = ADC_BITS, angle_min_rad: float = POT_RANGE_RAD[0],
                 angle_max_rad: float = POT_RANGE_RAD[1], noise_rad: float = 0.0) -> None:
        self.bits = int(bits)
        if not 1 <= self.bits <= 24:
            raise ValueError(f'bits must be in 1..24, got {bits}')
        self.angle_min_rad = finite_scalar('angle_min_rad', angle_min_rad)
        self.angle_max_rad = finite_scalar('angle_max_rad', angle_max_rad)
        if self.angle_max_rad <= self.angle_min_rad:
            raise ValueError('angle_max_rad must exceed angle_min_rad')
        self.noise_rad = finite_scalar('noise_rad', noise_rad)
        if self.noise_rad < 0:
            raise ValueError(f'noise_rad must be non-negative, got {noise_rad}')

    @property
    def full_scale(self) -> int:
        """Largest ADC count, 2^bits − 1."""
        return (1 << self.bits) - 1

    @property
    def resolution_rad(self) -> float:
        """Angle per ADC count [rad] (the quantisation step)."""
        return (self.angle_max_rad - self.angle_min_rad) / self.full_scale

    def counts(self, angle_rad: float, rng: Optional[np.random.Generator] = None) -> int:
        """Return the ADC counts for a shaft angle [rad], with noise_rad Gaussian noise if rng."""
        phi = finite_scalar('angle_rad', angle_rad)
        if rng is not None and self.noise_rad > 0:
            phi += rng.normal(0.0, self.noise_rad)
        c = round((phi - self.angle_min_rad) / self.resolution_rad)
        return int(min(max(c, 0), self.full_scale))

    def angle(self, counts: ArrayLike) -> Union[float, np.ndarray]:
        """Return the shaft angle [rad] for ADC counts (inverse calibration); arrays too."""
        c = np.asarray(counts, dtype=float)
        if np.any((c < 0) | (c > self.full_scale)) or not np.all(np.isfinite(c)):
            raise ValueError(f'counts must be within 0..{self.full_scale}')
        out = self.angle_min_rad + c * self.resolution_rad
        return float(out) if out.ndim == 0 else out

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
import numpy as np

from .validate import finite_scalar


class Potentiometer:
    """
    Linear potentiometer + `bits`-bit ADC spanning [angle_min_rad, angle_max_rad].

    counts = round((φ − φ_min) / (φ_max − φ_min) · (2^bits − 1)), clipped to the ADC range,
    with optional Gaussian noise of `noise_rad` added to φ before conversion.
    """

    def __init__(self, bits=12, angle_min_rad=-1.2, angle_max_rad=1.2, noise_rad=0.0):
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
    def full_scale(self):
        """Largest ADC count, 2^bits − 1."""
        return (1 << self.bits) - 1

    @property
    def resolution_rad(self):
        """Angle per ADC count [rad] (the quantisation step)."""
        return (self.angle_max_rad - self.angle_min_rad) / self.full_scale

    def counts(self, angle_rad, rng=None):
        """ADC counts for a shaft angle [rad]; adds noise_rad Gaussian noise when rng is given."""
        phi = finite_scalar('angle_rad', angle_rad)
        if rng is not None and self.noise_rad > 0:
            phi += rng.normal(0.0, self.noise_rad)
        c = round((phi - self.angle_min_rad) / self.resolution_rad)
        return int(min(max(c, 0), self.full_scale))

    def angle(self, counts):
        """Shaft angle [rad] for ADC counts (inverse calibration); works on arrays too."""
        c = np.asarray(counts, dtype=float)
        if np.any((c < 0) | (c > self.full_scale)) or not np.all(np.isfinite(c)):
            raise ValueError(f'counts must be within 0..{self.full_scale}')
        out = self.angle_min_rad + c * self.resolution_rad
        return float(out) if out.ndim == 0 else out

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
Setpoint profiles r(t) [rad] of the setpoint node (the paper's Figs. 15-17 and more).

With A = amplitude, r0 = offset, P = period_s and τ = t − delay_s (r = r0 for τ < 0):

  constant  r = r0
  step      r = r0 + A                                       (Fig. 15)
  ramp      r = r0 + A · min(τ / P, 1): one ramp over P, then hold   (Fig. 16)
  sine      r = r0 + A sin(2π τ / P)                          (Fig. 17)
  square    r = r0 + A for the first half of each period, r0 − A for the second
  chirp     r = r0 + A sin(2π (f0 τ + (f1 − f0) τ² / (2 D))), f0 = 1/P, sweeping
            linearly to f1 = chirp_end_hz over D = chirp_duration_s, then staying at f1
"""
from __future__ import annotations

from dataclasses import dataclass
import math
from typing import Tuple

from .core.validate import finite_scalar

PROFILES = ('constant', 'step', 'ramp', 'sine', 'square', 'chirp')


@dataclass(frozen=True)
class Profile:
    """A setpoint profile; call it with the time since start [s] to get r(t) [rad]."""

    kind: str = 'step'
    amplitude: float = 0.5
    offset: float = 0.0
    period_s: float = 20.0
    delay_s: float = 1.0
    chirp_end_hz: float = 0.2
    chirp_duration_s: float = 60.0

    def __post_init__(self) -> None:
        """Check the kind and that every number is finite and in range."""
        if self.kind not in PROFILES:
            raise ValueError(f'profile must be one of {PROFILES}, got {self.kind!r}')
        for name in ('amplitude', 'offset', 'period_s', 'delay_s', 'chirp_end_hz',
                     'chirp_duration_s'):
            finite_scalar(name, getattr(self, name))
        if self.period_s <= 0 or self.chirp_duration_s <= 0 or self.chirp_end_hz <= 0:
            raise ValueError('period_s, chirp_end_hz and chirp_duration_s must be positive')
        if self.delay_s < 0:
            raise ValueError(f'delay_s must be non-negative, got {self.delay_s}')

    def bounds(self) -> Tuple[float, float]:
        """Return (min, max) of r over all time [rad] (to check against the controller's range)."""
        lo, hi = sorted((self.offset, self.offset + self.amplitude))
        if self.kind in ('sine', 'square', 'chirp'):
            lo, hi = self.offset - abs(self.amplitude), self.offset + abs(self.amplitude)
        return (self.offset, self.offset) if self.kind == 'constant' else (lo, hi)

    def __call__(self, t: float) -> float:
        """Return r(t) [rad] at time t [s] since the profile started."""
        tau = finite_scalar('t', t) - self.delay_s
        if self.kind == 'constant' or tau < 0:
            return self.offset
        a, p = self.amplitude, self.period_s
        if self.kind == 'step':
            return self.offset + a
        if self.kind == 'ramp':
            return self.offset + a * min(tau / p, 1.0)
        if self.kind == 'sine':
            return self.offset + a * math.sin(2 * math.pi * tau / p)
        if self.kind == 'square':
            return self.offset + (a if (tau % p) < 0.5 * p else -a)
        return self.offset + a * math.sin(2 * math.pi * self._chirp_cycles(tau))

    def _chirp_cycles(self, tau: float) -> float:
        """Return the accumulated cycles of the linear chirp (its phase / 2π) at τ [s]."""
        f0, f1, d = 1.0 / self.period_s, self.chirp_end_hz, self.chirp_duration_s
        if tau <= d:
            return f0 * tau + (f1 - f0) * tau * tau / (2 * d)
        return f0 * d + (f1 - f0) * d / 2 + f1 * (tau - d)

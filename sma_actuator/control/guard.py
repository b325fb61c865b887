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
Thermal guard: duty limits that keep the estimated wire temperature under a maximum.

For each wire the core's exact thermal step (eq. 7d/7f, `core.thermal.thermal_step`)
is affine in the held duty d over a horizon H:

    θ(t+H) = A + B d,   A = θ(t+H) at d = 0,   B = θ(t+H) at d = 1 − A

so the largest duty that keeps θ(t+H) <= θ_max is d_max = (θ_max − A) / B, clipped to
[0, 1]. Because a first-order response under a held duty is monotone, no intermediate
sample overshoots either. As θ → θ_max the limit tends to the steady-state bound
(θ_max − θa)/G, so the guard throttles before the maximum instead of switching off at it.
The gain used is the worst case over the model's phase-resistance factor (1 + κ). With
the fast lag τ (tau_fast_s) the lag state is taken at its steady value G d, so the bound
then holds within about 1 K: leave that margin in max_temp_c.
"""
from __future__ import annotations

from typing import Optional, Sequence, Tuple

import numpy as np

from ..core.actuator import ActuatorParams
from ..core.thermal import thermal_step
from ..core.validate import finite_scalar


class ThermalGuard:
    """Per-wire duty limits from estimated temperatures (model `ActuatorParams`)."""

    def __init__(self, params: ActuatorParams, max_temp_c: float = 110.0,
                 horizon_s: float = 0.5):
        self.params = params
        self.max_temp_c = finite_scalar('max_temp_c', max_temp_c)
        self.horizon_s = finite_scalar('horizon_s', horizon_s)
        if self.horizon_s <= 0:
            raise ValueError(f'horizon_s must be positive, got {horizon_s}')
        self._wires = None     # derived once: the model does not change under a guard

    def _wire(self, j: int) -> Tuple[float, float]:
        """(worst-case gain G [K], time constant T [s]) of wire j, from the model."""
        if self._wires is None:
            p = self.params
            gain, tau = p.gain_k * (1.0 + max(p.phase_kappa, 0.0)), p.tau_s
            self._wires = ((gain, tau), (gain * p.gain_ratio_b, tau * p.tau_ratio_b))
        return self._wires[j]

    def limits(self, theta_c: Sequence[float], last_duty: Sequence[float] = (0.0, 0.0),
               ambient_c: Optional[float] = None) -> Tuple[float, float]:
        """(limit_a, limit_b) in [0, 1] for estimated temperatures θ̂ [°C] (2,)."""
        amb = self.params.ambient_c if ambient_c is None else finite_scalar('ambient_c', ambient_c)
        out = []
        for j in range(2):
            gain, tau = self._wire(j)
            q = gain * last_duty[j]   # heat-input lag state (matters only with tau_fast_s > 0)
            a, _ = thermal_step(float(theta_c[j]), q, amb, 0.0, self.horizon_s, tau,
                                self.params.tau_fast_s)
            full, _ = thermal_step(float(theta_c[j]), q, amb, gain, self.horizon_s, tau,
                                   self.params.tau_fast_s)
            b = full - a
            out.append(float(np.clip((self.max_temp_c - a) / b, 0.0, 1.0)) if b > 0 else 0.0)
        return tuple(out)

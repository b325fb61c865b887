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
Discrete PI controller with anti-windup (the paper's PI, sampling time 25 ms).

    e(k) = r(k) − y(k)
    v(k) = u_ff(k) + Kp e(k) + I(k)                      unsaturated command
    u(k) = clip(v(k), u_min, u_max)                      applied command
    I(k+1) = I(k) + Ki Ts e(k)   unless u is saturated and e pushes further into the limit

Anti-windup is conditional integration (clamping): the integrator freezes while the
output sits on a limit and the error would drive it further, and the integrator itself
is kept inside [u_min − u_ff, u_max − u_ff] so a limit change (thermal guard) cannot leave
a wound-up state behind. Units: e in rad, u in duty (signed, see `split`), Kp in 1/rad,
Ki in 1/(rad s).
"""
from __future__ import annotations

from ..core.validate import finite_scalar


class DiscretePI:
    """PI with conditional-integration anti-windup; limits may change every step."""

    def __init__(self, kp: float, ki: float):
        self.set_gains(kp, ki)
        self.reset()

    def set_gains(self, kp: float, ki: float) -> None:
        """Change Kp [1/rad] and Ki [1/(rad s)]; the integral state is kept (bumpless)."""
        kp, ki = finite_scalar('kp', kp), finite_scalar('ki', ki)
        if kp < 0 or ki < 0:
            raise ValueError(f'gains must be non-negative, got kp={kp}, ki={ki}')
        self.kp, self.ki = kp, ki

    def reset(self, integral: float = 0.0) -> None:
        """Clear the integrator (to `integral`, in command units)."""
        self.integral = finite_scalar('integral', integral)
        self.saturated = False

    def step(self, error: float, dt: float, u_min: float, u_max: float,
             feedforward: float = 0.0) -> float:
        """One sample: return u(k) in [u_min, u_max] for error e(k) [rad] held over dt [s]."""
        error, dt = finite_scalar('error', error), finite_scalar('dt', dt)
        if dt <= 0:
            raise ValueError(f'dt must be positive, got {dt}')
        if u_min > u_max:
            raise ValueError(f'u_min {u_min} exceeds u_max {u_max}')
        # a limit that moved (thermal guard) must not strand the integrator outside it
        self.integral = min(max(self.integral, u_min - feedforward), u_max - feedforward)
        v = feedforward + self.kp * error + self.integral
        u = min(max(v, u_min), u_max)
        self.saturated = u != v
        pushing_out = (v > u_max and error > 0) or (v < u_min and error < 0)
        if not pushing_out:
            self.integral += self.ki * dt * error
            self.integral = min(max(self.integral, u_min - feedforward), u_max - feedforward)
        return u

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
Thermal dynamics of one wire, eq. (7): C dθ/dt = R i² − hA (θ − θa), and Fig. 13.

The PWM amplifier switches the supply V across the wire (resistance R) through a current
limiter I_max, so the on-current is i_on = min(V/R, I_max) and the mean Joule power at
duty d is P = d · R · i_on² (duty held constant over a sample: zero-order hold).

With T = C / hA (basic time constant, Fig. 13) and G = R i_on² / hA (steady temperature
rise at full duty) eq. (7) is T dθ/dt = −(θ − θa) + G d. Its exact discretisation for
a sample time dt (not forward Euler) is

    θ(k+1) = θa + (θ(k) − θa) e^{−dt/T} + (1 − e^{−dt/T}) · G d(k)                  (7d)

The unmodelled fast dynamics τ of Fig. 13 are a first-order lag q on the heat input,
τ dq/dt = −q + G d, feeding T dθ/dt = −(θ − θa) + q. For a held input its exact step is

    q(k+1) = q∞ + (q − q∞) e^{−dt/τ},   q∞ = G d
    θ(k+1) = θa + q∞ + x0 e^{−dt/T} + (q − q∞) · τ/(τ − T) · (e^{−dt/τ} − e^{−dt/T})    (7f)

with x0 = θ(k) − θa − q∞ (the τ → T limit uses (dt/T) e^{−dt/T}). The disturbance x of
Fig. 13 enters as an additive temperature [K] at the hysteresis input.
"""
import math
from typing import Tuple

from numba import njit

from .validate import finite_scalar, positive


def on_current_a(supply_v: float, resistance_ohm: float, current_limit_a: float) -> float:
    """Return the PWM on-state current [A]: min(V/R, I_max) (the current limiter of section 3)."""
    supply_v = positive('supply_v', supply_v)
    resistance_ohm = positive('resistance_ohm', resistance_ohm)
    current_limit_a = positive('current_limit_a', current_limit_a)
    return min(supply_v / resistance_ohm, current_limit_a)


def heating_power_w(duty: float, supply_v: float, resistance_ohm: float,
                    current_limit_a: float) -> float:
    """Return the mean Joule power [W] at duty d in [0, 1]: P = d R min(V/R, I_max)² (eq. 7)."""
    d = finite_scalar('duty', duty)
    if not 0.0 <= d <= 1.0:
        raise ValueError(f'duty must be in [0, 1], got {d}')
    return d * resistance_ohm * on_current_a(supply_v, resistance_ohm, current_limit_a) ** 2


def time_constant_s(heat_capacity_j_per_k: float, conductance_w_per_k: float) -> float:
    """Return the basic time constant T = C / hA [s] of eq. (7)."""
    return positive('heat_capacity_j_per_k', heat_capacity_j_per_k) / positive(
        'conductance_w_per_k', conductance_w_per_k)


@njit(cache=True)
def thermal_step(theta: float, q: float, theta_amb: float, q_inf: float, dt: float, tau_s: float,
                 tau_fast_s: float) -> Tuple[float, float]:
    """Return one exact ZOH step of eq. (7d) (tau_fast_s = 0) or (7f): (theta, q) [°C, K]."""
    a = math.exp(-dt / tau_s)
    if tau_fast_s <= 0.0:
        return theta_amb + (theta - theta_amb) * a + (1.0 - a) * q_inf, q_inf
    b = math.exp(-dt / tau_fast_s)
    x0 = theta - theta_amb - q_inf
    dq = q - q_inf
    if abs(tau_fast_s - tau_s) < 1e-9 * tau_s:
        coupling = dt / tau_s * a
    else:
        coupling = tau_fast_s / (tau_fast_s - tau_s) * (b - a)
    theta_new = theta_amb + q_inf + x0 * a + dq * coupling
    return theta_new, q_inf + dq * b

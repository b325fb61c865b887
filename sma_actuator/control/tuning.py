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
Default PI gains from the fitted model: SIMC rules (Skogestad 2003).

The rules are applied to a first-order-plus-delay reading of the model.

The controlled process, duty u -> measured angle φ, is read from the model as a first-order
lag with dead time around the transformation:

    φ(s) / u(s) = K e^{−θ s} / (T s + 1)
    K = g G h'          [rad per unit duty]: stroke g (`stroke_rad`) x steady rise at full
                        duty G (`gain_k`) x secant slope h' of the hysteresis's heating
                        branch from the cold wire at ambient to 90 % contraction [1/K] (the
                        large-signal gain: a wire starts from the dead band below As)
    T = tau_s           [s]: the thermal time constant
    θ = D + τ_f + Ts/2  [s]: transport delay (`delay_s`), fast lag (`tau_fast_s`, the half
                        rule puts a small second lag into the dead time) and the sample hold

SIMC PI for that process, with closed-loop time constant τc:

    Kp = T / (K (τc + θ)),   Ti = min(T, 4 (τc + θ)),   Ki = Kp / Ti

Both are clipped to `KP_RANGE` / `KI_RANGE` (a degenerate fit must not give an absurd PI).
τc = max(θ, τc,min): the SIMC choice τc = θ (about 3 of gain margin, 70 % of the delay
margin), bounded below by `TAU_C_MIN_S` because the hysteresis slope varies along the loop
(the PI must stay stable where the branch is steeper than its secant). A long delay
therefore gives a proportionally gentler PI. In `pi_inverse` with the Smith predictor the
delay is taken out of the nominal loop (θ without D) but kept as a lower bound on τc: the
prediction is only as good as the model, and what it gets wrong still comes back through
the delay.
"""
from __future__ import annotations

import math
from typing import Tuple

import numpy as np

from ..core.actuator import ActuatorParams
from ..core.hysteresis import PlayHysteresis

# lower bound of the closed-loop time constant [s]: within the transformation the branch
# is several times steeper than its secant slope
TAU_C_MIN_S = 0.15
# sanity bounds of the derived gains [duty/rad], [duty/(rad s)]: a degenerate fit (a heating
# branch that barely moves within ambient + G) must not give an absurd PI
KP_RANGE = (0.05, 20.0)
KI_RANGE = (0.01, 40.0)


def heating_branch(params: ActuatorParams) -> Tuple[np.ndarray, np.ndarray]:
    """
    Return (u [°C], y) of the model's heating branch from the cold wire at ambient.

    y(u) = H[u] along u rising from the cold state at the model's ambient θa to θa + G
    (kept non-decreasing), on 2001 points: what a wire at rest shows when heated.
    """
    h = PlayHysteresis.from_dict(params.hysteresis.to_dict())
    amb, top = params.ambient_c, params.ambient_c + max(params.gain_k, 1.0)
    u = np.linspace(amb, top, 2001)
    return u, np.maximum.accumulate(h.simulate(u, h.initial_state(amb)))


def heating_slope_per_k(params: ActuatorParams) -> float:
    """
    Return the secant slope h' [1/K] of the heating branch, ambient to 90 % contraction.

    h' = 0.9 (y(θa + G) − y(θa)) / (u90 − θa), u90 where the branch (`heating_branch`)
    reaches 90 % of its span.
    """
    u, y = heating_branch(params)
    amb = params.ambient_c
    span = float(y[-1] - y[0])
    if span <= 1e-9:
        return 1.0 / 50.0
    u90 = float(np.interp(y[0] + 0.9 * span, y, u))
    return 0.9 * span / max(u90 - amb, 1.0)


def transformation_start_c(params: ActuatorParams, fraction: float = 0.02) -> float:
    """
    Return θs [°C], the model's As: where a heated cold wire starts to move.

    θs is the first u of the heating branch (`heating_branch`) with y(u) >= y(θa) +
    fraction (y(θa + G) − y(θa)); below it a heated wire does not move.
    """
    u, y = heating_branch(params)
    span = float(y[-1] - y[0])
    if span <= 1e-9:
        return float(u[-1])
    return float(u[np.argmax(y >= y[0] + fraction * span)])


def process_model(params: ActuatorParams, dt_s: float = 0.025,
                  smith: bool = False) -> Tuple[float, float, float]:
    """
    Return (K [rad/duty], T [s], θ [s]) of the first-order-plus-delay process (module doc).

    smith: the Smith predictor removes the transport delay from the nominal loop.
    """
    k = abs(params.stroke_rad) * params.gain_k * heating_slope_per_k(params)
    delay = 0.0 if smith else params.delay_s
    return max(k, 1e-3), params.tau_s, delay + params.tau_fast_s + 0.5 * dt_s


def simc_gains(params: ActuatorParams, dt_s: float = 0.025, smith: bool = False,
               tau_c_min_s: float = TAU_C_MIN_S) -> Tuple[float, float]:
    """
    Return SIMC (kp [duty/rad], ki [duty/(rad s)]) for the model (module docstring).

    With smith=True the delay leaves θ but still bounds τc from below; tau_c_min_s is the
    lower bound of τc [s].
    """
    k, t, theta = process_model(params, dt_s, smith)
    tau_c = max(theta, tau_c_min_s, params.delay_s if smith else 0.0)
    kp = t / (k * (tau_c + theta))
    ti = min(t, 4.0 * (tau_c + theta))
    if not (math.isfinite(kp) and math.isfinite(ti)) or ti <= 0:
        raise ValueError('model gives no finite PI gains (check tau_s, gain_k, stroke_rad)')
    return (min(max(kp, KP_RANGE[0]), KP_RANGE[1]),
            min(max(kp / ti, KI_RANGE[0]), KI_RANGE[1]))

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
Inverse compensation of mode `pi_inverse`: desired angle -> feed-forward duties.

Chain (actuator steps 4 -> 1 inverted, model = the identified `ActuatorParams`):

  1. shaft   Δy* = (φ* − φ0) / g                      contraction difference (step 4)
  2. split   Δy* >= 0: y_a* = Δy*, wire b idle;  Δy* < 0: y_b* = −Δy* / s_b, wire a idle
  3. H^-1    u_j* = H^-1[y_j*] from the wire's current hysteresis state (exact inverse of
             the modified PI, eq. 6, `InversePlayHysteresis`), θ_j* = u_j* + σ ŷ_other
  4. thermal d_j = (θ_j* − θa) / G_j                    static map of eq. (7), clipped
             or, with horizon_s = h > 0, the exact inverse of the thermal step (7d) over h:
             the duty that takes the estimated θ̂_j to θ_j* in h seconds,
             d_j = (θ_j* − θa − (θ̂_j − θa) e^{−h/T}) / (G_j (1 − e^{−h/T})).
             h → ∞ gives the static map back; a finite h also inverts the thermal lag T
             (faster reversals, where the passive cooling is the bottleneck).

Branch holding: the exact inverse jumps to the other branch, a loop width (~2r, 26 K for
Flexinol) away, for any error of the wire against its target however small. Driven from
the estimated wire state, any overshoot on a rising reference (thermal lag, the PI's
share) would then flip it to the cooling branch and back, and a fast thermal inverse
chatters and walks the shaft in steps. So a wire's target that lies on the far side of
its present contraction *against* the direction its target is moving is met by holding
the present temperature: the reference comes back to the wire instead of the wire
cycling 2r around it. Only a real reversal of the reference selects the other branch
(before the target has moved at all, the exact inverse decides).

The inverse is stateful. Its state is not advanced by its own targets but by the
estimated hysteresis inputs of the wires (`track`, fed from `WireEstimator`), so H^-1 is
always solved from the branch the wire is actually on, even when the thermal lag or the
guard kept the wire from reaching the previous target. An idle wire gets zero
feed-forward: holding it at the temperature where y just reaches 0 would only waste heat.
"""
from __future__ import annotations

from typing import Optional, Sequence, Tuple, TYPE_CHECKING

import numpy as np

from ..core.actuator import CONVECTION_REF_K
from ..core.hysteresis import PlayHysteresis
from ..core.thermal import thermal_step
from ..core.validate import finite_scalar

if TYPE_CHECKING:
    from ..core.actuator import ActuatorParams

# |Δy*| below this counts as "both wires idle": on the flat cold branch any temperature up
# to the knee gives y = 0, and the inverse would otherwise pick the knee and heat needlessly
IDLE_CONTRACTION = 1e-3
# |Δy*| beyond which the loop heats only the wire on the target's side (`target_side`)
ONE_SIDED_MARGIN = 0.1


class InverseFeedforward:
    """Feed-forward duties (d_a, d_b) for a desired shaft angle, from a model `ActuatorParams`."""

    def __init__(self, params: ActuatorParams, duty_max: float = 1.0,
                 horizon_s: float = 0.0) -> None:
        self.params = params
        self.horizon_s = horizon_s
        self.duty_max = finite_scalar('duty_max', duty_max)
        h = params.hysteresis
        if (h.w < 0).any() or h.k1 < 0:
            raise ValueError('model hysteresis is not invertible (negative weights)')
        self._plays = [PlayHysteresis.from_dict(h.to_dict()) for _ in range(2)]
        # H^-1 of each wire, solved from the wire's estimated state (`track`), not its own
        self._inverses = [play.inverse() for play in self._plays]
        # derived model constants (the model is fixed for the life of this object)
        self._y_max = h.output_range()[1]
        self._gains = (params.gain_k, params.gain_k * params.gain_ratio_b)
        self._taus = (params.tau_s, params.tau_s * params.tau_ratio_b)
        self.reset()

    def reset(self, theta_c: Optional[float] = None) -> None:
        """Put both wires' inverse state on the cold branch at θ (default: model ambient)."""
        theta = self.params.ambient_c if theta_c is None else finite_scalar('theta_c', theta_c)
        self._u = [theta, theta]
        self._y = [0.0, 0.0]
        self._last_target = [None, None]   # y_j* of the previous call (None: wire was idle)
        self._direction = [0, 0]           # +1 target rising, -1 falling, 0 not moved yet
        self.cooling_short = [False, False]
        for j, play in enumerate(self._plays):
            play.reset(theta)
            self._y[j] = play.step(theta)

    def track(self, hysteresis_inputs: Sequence[float]) -> None:
        """Advance each wire's inverse state along its estimated hysteresis input [°C]."""
        for j in range(2):
            self._u[j] = float(hysteresis_inputs[j])
            self._y[j] = self._plays[j].step(self._u[j])

    def target_contractions(
        self, angle_rad: float, offset_rad: Optional[float] = None,
        stroke_rad: Optional[float] = None,
    ) -> Tuple[Optional[float], Optional[float]]:
        """
        Return (y_a*, y_b*) for a desired true angle [rad]; an idle wire's target is None.

        offset_rad, stroke_rad: drift-corrected φ0 and g (default: the model's).
        """
        p = self.params
        offset = p.offset_rad if offset_rad is None else offset_rad
        stroke = p.stroke_rad if stroke_rad is None else stroke_rad
        dy = (finite_scalar('angle_rad', angle_rad) - offset) / stroke
        y_max = self._y_max
        if abs(dy) <= IDLE_CONTRACTION:
            return None, None
        if dy > 0:
            return min(dy, y_max), None
        ratio = p.stroke_ratio_b if p.stroke_ratio_b > 0 else 1.0
        return None, min(-dy / ratio, y_max)

    def target_side(self, angle_rad: float, offset_rad: Optional[float] = None,
                    stroke_rad: Optional[float] = None,
                    margin: Optional[float] = None) -> int:
        """
        Return +1 (−1) when the target Δy* = (φ* − φ0) / g lies beyond +margin (−margin).

        0 in between. Far on one side the antagonist, below its transformation start, only
        heats without moving, and must be let go; margin defaults to `ONE_SIDED_MARGIN`.
        """
        p = self.params
        offset = p.offset_rad if offset_rad is None else offset_rad
        stroke = p.stroke_rad if stroke_rad is None else stroke_rad
        dy = (angle_rad - offset) / stroke
        m = ONE_SIDED_MARGIN if margin is None else margin
        return 1 if dy > m else (-1 if dy < -m else 0)

    def wire_tau(self, j: int) -> float:
        """Return wire j's thermal time constant T_j [s]."""
        return self._taus[j]

    def wire_gain(self, j: int) -> float:
        """Return wire j's steady rise at full duty G_j [K]."""
        return self._gains[j]

    def thermal_duty(self, j: int, theta_target: float, theta_est: Optional[float],
                     ambient: float, y_own: float = 0.0,
                     horizon_s: Optional[float] = None) -> float:
        """
        Return wire j's duty that brings θ̂_j to θ* (step 4, every thermal effect inverted).

        `commanded_duty` of `effective_duty` of the same arguments.
        """
        return self.commanded_duty(
            self.effective_duty(j, theta_target, theta_est, ambient, y_own, horizon_s))

    def commanded_duty(self, d_eff: float) -> float:
        """
        Return the commanded duty in [0, duty_max] that gives the effective duty d_eff.

        The current limiter's saturation inverted: a hard limit d_lim cannot be exceeded
        (any target beyond it asks for full duty), the smooth one d_eff = d_lim x / (1 +
        x^n)^(1/n), x = d / d_lim, is inverted exactly, x = z / (1 − z^n)^(1/n), z = d_eff /
        d_lim.
        """
        p = self.params
        return float(np.clip(current_limit_inverse(d_eff, p.duty_limit,
                                                   p.duty_limit_sharpness, self.duty_max),
                             0.0, self.duty_max))

    def effective_duty(self, j: int, theta_target: float, theta_est: Optional[float],
                       ambient: float, y_own: float = 0.0,
                       horizon_s: Optional[float] = None) -> float:
        """
        Return the effective duty d_eff that takes θ̂_j to θ* in h, not clipped.

        d_eff = (θ* − θa − (θ̂ − θa) e^{−h/T}) / (G (1 − e^{−h/T})) (eq. 7d inverted; h = 0
        or no estimate: the static map (θ* − θa) / G). The heating gain is wire j's G
        (asymmetric wires) x (1 + κ (1 − y_j)) (phase resistance), G and T divided by the
        convection factor (|θ − θa| / 50 K)^n taken between θ̂ and θ*. Below 0 when even
        zero duty leaves the wire above θ* after h. horizon_s: h (None: `horizon_s` of the
        object).
        """
        p = self.params
        gain = self.wire_gain(j) * (1.0 + p.phase_kappa * (1.0 - y_own))
        tau = self.wire_tau(j)
        if p.convection_exponent != 0.0:
            ref = theta_target if theta_est is None else 0.5 * (theta_target + theta_est)
            f = max((max(abs(ref - ambient), 0.5) / CONVECTION_REF_K) ** p.convection_exponent,
                    0.05)
            gain, tau = gain / f, tau / f
        h = self.horizon_s if horizon_s is None else horizon_s
        if h > 0 and theta_est is not None:
            a, _ = thermal_step(float(theta_est), 0.0, ambient, 0.0, h, tau, 0.0)
            return float((theta_target - a) / ((1.0 - np.exp(-h / tau)) * gain))
        return float((theta_target - ambient) / gain)

    def duties(
        self, angle_rad: float, ambient_c: Optional[float] = None,
        contraction: Sequence[float] = (0.0, 0.0),
        theta_est: Optional[Sequence[float]] = None, offset_rad: Optional[float] = None,
        stroke_rad: Optional[float] = None,
    ) -> Tuple[Tuple[float, float], Tuple[float, float]]:
        """
        Return steps 1-4: (d_a, d_b) in [0, duty_max] and the target temperatures θ* [°C].

        The duty heats to θ* + λ (y* − y_j): the latent heat that the transformation to y*
        absorbs (gives back, on cooling) comes on top of the heat balance. `cooling_short`
        [j] is set when wire j's thermal inverse asks for less than zero duty: cooling
        freely, the wire cannot reach its target within the horizon h.
        """
        p = self.params
        amb = p.ambient_c if ambient_c is None else finite_scalar('ambient_c', ambient_c)
        duties, temps = [0.0, 0.0], [amb, amb]
        self.cooling_short = [False, False]
        targets = self.target_contractions(angle_rad, offset_rad, stroke_rad)
        for j, y_star in enumerate(targets):
            if y_star is None:
                self._last_target[j], self._direction[j] = None, 0
                continue
            gain = self.wire_gain(j)
            last, self._last_target[j] = self._last_target[j], y_star
            if last is not None and y_star != last:
                self._direction[j] = 1 if y_star > last else -1
            ahead = self._y[j] - y_star            # > 0: the wire is past its target going up
            if ahead * self._direction[j] > 0:
                u_star = self._u[j]       # hold: see "branch holding" in the module doc
            else:
                u_star = self._inverses[j].solve(y_star, self._plays[j].state, self._u[j],
                                                 amb - 50.0, amb + gain * self.duty_max)
            theta = u_star + p.stress_k * float(contraction[1 - j])
            temps[j] = theta
            est = None if theta_est is None else float(theta_est[j])
            # the heat the transformation to y* absorbs (latent heat) comes on top
            heat_to = theta + p.latent_heat_k * (y_star - float(contraction[j]))
            d_eff = self.effective_duty(j, heat_to, est, amb, float(contraction[j]))
            duties[j] = self.commanded_duty(d_eff)
            self.cooling_short[j] = d_eff < 0.0
        return tuple(duties), tuple(temps)


def current_limit_inverse(d_eff: float, d_lim: float, sharpness: float,
                          duty_max: float = 1.0) -> float:
    """
    Return the commanded duty whose current-limited effective duty is d_eff.

    Inverse of the kernel's limiter (`core.actuator`, step 1): hard min(d, d_lim) for
    sharpness 0, else d_lim x / (1 + x^n)^(1/n). Unreachable targets give duty_max.
    """
    if d_eff <= 0.0:
        return 0.0
    if d_lim >= 1.0 and sharpness <= 0.0:
        return d_eff
    z = d_eff / d_lim
    if sharpness <= 0.0:
        return d_eff if z < 1.0 else duty_max
    if z >= 1.0 - 1e-9:
        return duty_max
    return d_lim * z / (1.0 - z ** sharpness) ** (1.0 / sharpness)

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
Wire state estimate, Smith prediction and drift correction from the core model.

Real wires have no temperature sensor, so the controller runs the identified model
(`core.AntagonisticActuator`, the plant's own implementation) open loop on what it
commanded. The thermal guard reads the estimated temperatures; the inverse feed-forward
reads the estimated hysteresis inputs so its H^-1 state follows the wire's actual
(estimated) trajectory.

Smith prediction (delay D = the model's `delay_s`): the measurement the plant will show
D from now is predicted as

    y_pred(t + D) = y_meas(t) + ŷ(t) − ŷ(t − D)

with ŷ the model's sensed angle without and with its delay. The model's own output
carries the nominal response, the measurement corrects for everything the model gets
wrong (that part still arrives delayed).

Drift (`DriftEstimator`): runs on other days rest elsewhere and reach another stroke. The
measured angle, linearised through the sensor inverse, is regressed on the model's
contraction difference Δŷ = ŷ_a − s_b ŷ_b delayed by D:

    φ_meas ≈ φ0' + g' Δŷ(t − D)

by recursive least squares with exponential forgetting (time constant `drift_time_s`), and
φ0', g' are clipped to φ0 ± `DRIFT_OFFSET_BOUND_RAD` and g × [1 − b, 1 + b],
b = `DRIFT_STROKE_BOUND`. A sample teaches only while the contraction difference moves
(its spread over the memory exceeds `MIN_SPREAD`), so a long hold cannot trade offset for
stroke. The inverse uses an estimate only once it leaves a dead band around the model's
value (`DRIFT_DEADBAND_RAD`, `DRIFT_DEADBAND_STROKE` of g): the regressor Δŷ carries the
model's own errors, which bias g' low by about 2 % on a matched plant.
"""
from __future__ import annotations

from collections import deque
from typing import Optional, Sequence

import numpy as np

from ..core.actuator import ActuatorParams, AntagonisticActuator

DRIFT_OFFSET_BOUND_RAD = 0.15
DRIFT_STROKE_BOUND = 0.3
MIN_SPREAD = 0.05
# dead band of the correction: estimates this close to the model's φ0 [rad] and g [fraction]
# are not used (the regression's own bias, about 2 % of the stroke, stays out of the loop)
DRIFT_DEADBAND_RAD = 0.02
DRIFT_DEADBAND_STROKE = 0.05


class WireEstimator:
    """θ̂_a, θ̂_b [°C] and ŷ_a, ŷ_b [0..1] from the model and the commanded duty history."""

    def __init__(self, params: ActuatorParams):
        self.params = params
        self.model = AntagonisticActuator(params)
        self.reading_delayed = 0.0

    def reset(self) -> None:
        """Both wires at the model's ambient, cold (martensite)."""
        self.model.reset()
        self.reading_delayed = self.model.reading_now

    def update(self, duty_a: float, duty_b: float, dt: float,
               ambient_c: Optional[float] = None) -> np.ndarray:
        """Advance by dt [s] with the duties that were applied over it; return θ̂ [°C] (2,)."""
        self.reading_delayed = self.model.step(duty_a, duty_b, dt, ambient_c)
        return self.model.temperature_c

    @property
    def temperature_c(self) -> np.ndarray:
        """Estimated wire temperatures [θ̂_a, θ̂_b] in °C."""
        return self.model.temperature_c

    @property
    def contraction(self) -> np.ndarray:
        """Estimated contraction fractions [ŷ_a, ŷ_b]."""
        return self.model.contraction

    def smith_correction(self) -> float:
        """ŷ(t) − ŷ(t − D) [rad]: add to the measurement to predict it D ahead."""
        return self.model.reading_now - self.reading_delayed

    def hysteresis_inputs(self) -> np.ndarray:
        """Return each wire's hysteresis input θ̂_j − σ ŷ_other [°C] (actuator step 3)."""
        th, y = self.temperature_c, self.contraction
        sigma = self.params.stress_k
        return np.array([th[0] - sigma * y[1], th[1] - sigma * y[0]])


class DriftEstimator:
    """Slow offset φ0' [rad] and stroke g' [rad] from measurements (module docstring)."""

    def __init__(self, params: ActuatorParams, time_s: float = 30.0):
        self.offset0, self.stroke0 = params.offset_rad, params.stroke_rad
        self.ratio_b = params.stroke_ratio_b
        self.delay_s = params.delay_s
        self.time_s = float(time_s)
        self.reset()

    @property
    def offset(self) -> float:
        """Offset φ0' [rad] for the inverse: the estimate outside the dead band, else φ0."""
        if abs(self.offset_est - self.offset0) > DRIFT_DEADBAND_RAD:
            return self.offset_est
        return self.offset0

    @property
    def stroke(self) -> float:
        """Stroke g' [rad] for the inverse: the estimate outside the dead band, else g."""
        if abs(self.stroke_est - self.stroke0) > DRIFT_DEADBAND_STROKE * abs(self.stroke0):
            return self.stroke_est
        return self.stroke0

    def reset(self) -> None:
        """Back to the model's offset and stroke."""
        self.offset_est, self.stroke_est = self.offset0, self.stroke0
        self._p = np.diag([1e-2, 1e-2])     # covariance of (offset, stroke) [rad²]
        self._history = deque()             # (time, Δŷ) for the delay
        self._recent = deque()              # Δŷ over the forgetting memory
        self._t = 0.0

    def update(self, contraction: Sequence[float], angle_measured_rad: float,
               dt: float) -> None:
        """Add one sample: model contractions (ŷ_a, ŷ_b) now, linearised measured angle."""
        self._t += dt
        dy = float(contraction[0] - self.ratio_b * contraction[1])
        self._history.append((self._t, dy))
        while len(self._history) > 1 and self._history[1][0] <= self._t - self.delay_s:
            self._history.popleft()
        x = np.array([1.0, self._history[0][1]])
        self._recent.append(x[1])
        if len(self._recent) > max(2, int(self.time_s / dt)):
            self._recent.popleft()
        if np.ptp(self._recent) < MIN_SPREAD:
            return
        lam = float(np.exp(-dt / self.time_s))
        theta = np.array([self.offset_est, self.stroke_est])
        px = self._p @ x
        gain = px / (lam + x @ px)
        theta = theta + gain * (angle_measured_rad - x @ theta)
        self._p = (self._p - np.outer(gain, px)) / lam
        self._p = np.minimum(self._p, 1.0)      # bounded covariance: no wind-up on holds
        b = DRIFT_STROKE_BOUND * abs(self.stroke0)
        self.offset_est = float(np.clip(theta[0], self.offset0 - DRIFT_OFFSET_BOUND_RAD,
                                        self.offset0 + DRIFT_OFFSET_BOUND_RAD))
        self.stroke_est = float(np.clip(theta[1], self.stroke0 - b, self.stroke0 + b))

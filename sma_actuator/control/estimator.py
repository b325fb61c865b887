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
Wire state estimate: the core actuator model driven by the commanded duties.

Real wires have no temperature sensor, so the controller runs the identified model
(`core.AntagonisticActuator`) open loop on what it commanded. The thermal guard reads
the estimated temperatures; the inverse feed-forward reads the estimated hysteresis
inputs so its H^-1 state follows the wire's actual (estimated) trajectory.
"""
import numpy as np

from ..core.actuator import AntagonisticActuator


class WireEstimator:
    """θ̂_a, θ̂_b [°C] and ŷ_a, ŷ_b [0..1] from the model and the commanded duty history."""

    def __init__(self, params):
        self.params = params
        self.model = AntagonisticActuator(params)

    def reset(self):
        """Both wires at the model's ambient, cold (martensite)."""
        self.model.reset()

    def update(self, duty_a, duty_b, dt, ambient_c=None):
        """Advance by dt [s] with the duties that were applied over it; return θ̂ [°C] (2,)."""
        self.model.step(duty_a, duty_b, dt, ambient_c)
        return self.model.temperature_c

    @property
    def temperature_c(self):
        """Estimated wire temperatures [θ̂_a, θ̂_b] in °C."""
        return self.model.temperature_c

    @property
    def contraction(self):
        """Estimated contraction fractions [ŷ_a, ŷ_b]."""
        return self.model.contraction

    def hysteresis_inputs(self):
        """Input of each wire's hysteresis operator: θ̂_j − σ ŷ_other [°C] (actuator step 3)."""
        th, y = self.temperature_c, self.contraction
        sigma = self.params.stress_k
        return np.array([th[0] - sigma * y[1], th[1] - sigma * y[0]])

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

"""Thermal guard (sma_actuator.control.guard) against the core actuator model."""
import numpy as np
import pytest
from sma_actuator.control.guard import ThermalGuard
from sma_actuator.core.actuator import ActuatorParams, AntagonisticActuator


def test_cold_wires_may_use_full_duty():
    guard = ThermalGuard(ActuatorParams(), max_temp_c=110.0)
    assert guard.limits([22.0, 22.0]) == (1.0, 1.0)


def test_limit_tends_to_the_steady_state_bound_at_the_maximum():
    p = ActuatorParams()
    guard = ThermalGuard(p, max_temp_c=100.0)
    lim_a, _ = guard.limits([100.0, 22.0])
    assert lim_a == pytest.approx((100.0 - p.ambient_c) / p.gain_k, rel=1e-9)


@pytest.mark.parametrize('params', [ActuatorParams(),
                                    ActuatorParams(tau_fast_s=0.2, gain_ratio_b=1.3,
                                                   tau_ratio_b=0.7)])
def test_full_demand_never_pushes_the_model_past_the_maximum(params):
    """Drive both wires 'full on' through the guard for 30 s: temperatures stay below max."""
    guard = ThermalGuard(params, max_temp_c=90.0, horizon_s=0.5)
    plant = AntagonisticActuator(params)
    duty = (0.0, 0.0)
    peak = np.zeros(2)
    for _ in range(1200):
        duty = guard.limits(plant.temperature_c, duty)
        plant.step(*duty, 0.025)
        peak = np.maximum(peak, plant.temperature_c)
    # the lag state q is approximated by its steady value G d, hence ~1 K slack with tau_fast
    assert (peak <= 90.0 + (1.0 if params.tau_fast_s > 0 else 1e-6)).all()
    assert (peak >= 85.0).all()                # and it does not throttle far too early


def test_invalid_horizon_is_rejected():
    with pytest.raises(ValueError):
        ThermalGuard(ActuatorParams(), horizon_s=0.0)

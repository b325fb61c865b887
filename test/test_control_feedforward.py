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
Inverse feed-forward of mode pi_inverse (sma_actuator.control.feedforward).

With the model equal to the plant and no feedback at all, the feed-forward alone must
bring the shaft to the desired angle, from either side of the hysteresis loop.
"""
import numpy as np
import pytest
from sma_actuator.control.estimator import WireEstimator
from sma_actuator.control.feedforward import InverseFeedforward
from sma_actuator.core.actuator import ActuatorParams, AntagonisticActuator
from sma_actuator.core.hysteresis import PlayHysteresis


def open_loop(params, targets, seconds_each, horizon_s=0.0, dt=0.025):
    """Feed-forward only, tracked by the estimator like the controller does; final angles."""
    plant, est = AntagonisticActuator(params), WireEstimator(params)
    ff = InverseFeedforward(params, horizon_s=horizon_s)
    duty, finals = (0.0, 0.0), []
    for target in targets:
        for _ in range(int(seconds_each / dt)):
            angle = plant.step(*duty, dt)
            est.update(*duty, dt)
            ff.track(est.hysteresis_inputs())
            duty, _ = ff.duties(target, contraction=est.contraction,
                                theta_est=est.temperature_c)
        finals.append(angle)
    return np.array(finals)


@pytest.mark.parametrize('horizon_s', [0.0, 0.5])
def test_feedforward_alone_reaches_targets_on_both_branches(horizon_s):
    targets = [0.3, 0.7, 0.3, -0.4, -0.8, -0.2, 0.5]   # up, down (minor loops), both wires
    finals = open_loop(ActuatorParams(), targets, 20.0, horizon_s)
    np.testing.assert_allclose(finals, targets, atol=0.02)


def test_inverse_needs_its_state_tracked():
    """The descending-branch target is only reached because the state follows the wire."""
    p = ActuatorParams()
    ff = InverseFeedforward(p)
    ff.track([80.0, 22.0])                     # wire a was driven hot (y_a = 1)
    (d_hot, _), (theta_hot, _) = ff.duties(0.5)
    fresh = InverseFeedforward(p)              # same target from the cold branch
    (d_cold, _), (theta_cold, _) = fresh.duties(0.5)
    assert theta_hot < theta_cold - 10.0       # the loop width separates the branches
    assert d_hot < d_cold


def test_idle_wire_and_zero_target_get_no_heat():
    ff = InverseFeedforward(ActuatorParams())
    assert ff.duties(0.0)[0] == (0.0, 0.0)
    d_a, d_b = ff.duties(-0.5)[0]
    assert d_a == 0.0 and d_b > 0.0


def test_duty_is_capped_by_duty_max():
    ff = InverseFeedforward(ActuatorParams(), duty_max=0.3)
    assert ff.duties(0.99)[0][0] <= 0.3


def test_overshoot_on_a_rising_target_holds_the_temperature_instead_of_flipping_branch():
    """Wire past its target while the target rises: hold θ; once the target falls: cool."""
    p = ActuatorParams()
    ff = InverseFeedforward(p)
    ff.track([72.0, 22.0])                          # wire a part-way up its heating branch
    y_now = PlayHysteresis.from_dict(p.hysteresis.to_dict()).simulate([22.0, 72.0])[-1]
    ff.duties(y_now - 0.05)
    _, (theta_hold, _) = ff.duties(y_now - 0.04)    # rising target, still below the wire
    assert theta_hold == pytest.approx(72.0)
    _, (theta_cool, _) = ff.duties(y_now - 0.06)    # the target reverses: cooling branch
    assert theta_cool < 72.0 - 10.0

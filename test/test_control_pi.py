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

"""Discrete PI with anti-windup (sma_actuator.control.pi)."""
import pytest
from sma_actuator.control.pi import DiscretePI


def test_proportional_and_integral_terms_follow_the_difference_equation():
    pi = DiscretePI(kp=2.0, ki=4.0)
    dt, e = 0.025, 0.1
    u0 = pi.step(e, dt, -10, 10)
    u1 = pi.step(e, dt, -10, 10)
    assert u0 == pytest.approx(2.0 * e)                   # I(0) = 0
    assert u1 == pytest.approx(2.0 * e + 4.0 * dt * e)    # I(1) = Ki Ts e(0)


def test_output_is_clamped_to_the_limits_of_each_step():
    pi = DiscretePI(kp=100.0, ki=0.0)
    assert pi.step(1.0, 0.025, -0.3, 0.7) == 0.7
    assert pi.step(-1.0, 0.025, -0.3, 0.7) == -0.3
    assert pi.saturated


def test_anti_windup_recovers_as_soon_as_the_error_reverses():
    """A long saturation must not leave a wound-up integrator holding the output on the limit."""
    pi = DiscretePI(kp=0.5, ki=2.0)
    for _ in range(2000):                      # 50 s pinned on the upper limit
        pi.step(1.0, 0.025, -1.0, 1.0)
    assert pi.integral <= 1.0
    u = pi.step(-0.5, 0.025, -1.0, 1.0)
    assert u < 1.0                             # leaves saturation on the first reversed sample


def test_integrator_is_pulled_inside_a_limit_that_shrinks():
    pi = DiscretePI(kp=0.0, ki=10.0)
    for _ in range(40):
        pi.step(1.0, 0.025, -1.0, 1.0)
    assert pi.integral == pytest.approx(1.0)
    assert pi.step(0.0, 0.025, -1.0, 0.2) == pytest.approx(0.2)   # guard cut the limit
    assert pi.integral <= 0.2 + 1e-12


def test_feedforward_adds_to_the_command_and_shifts_the_integrator_bounds():
    pi = DiscretePI(kp=1.0, ki=0.0)
    assert pi.step(0.1, 0.025, -1, 1, feedforward=0.3) == pytest.approx(0.4)
    assert pi.step(1.0, 0.025, -1, 1, feedforward=0.3) == 1.0


def test_gain_change_keeps_the_integral_for_a_bumpless_transfer():
    pi = DiscretePI(kp=1.0, ki=1.0)
    for _ in range(10):
        pi.step(0.2, 0.025, -1, 1)
    before = pi.integral
    pi.set_gains(3.0, 0.5)
    assert pi.integral == before
    assert pi.step(0.0, 0.025, -1, 1) == pytest.approx(before)


@pytest.mark.parametrize('kp,ki', [(-1, 0), (0, -1), (float('nan'), 0), (0, float('inf'))])
def test_invalid_gains_are_rejected(kp, ki):
    with pytest.raises(ValueError):
        DiscretePI(kp, ki)


def test_invalid_step_arguments_are_rejected():
    pi = DiscretePI(1, 1)
    with pytest.raises(ValueError):
        pi.step(float('nan'), 0.025, -1, 1)
    with pytest.raises(ValueError):
        pi.step(0.1, 0.0, -1, 1)
    with pytest.raises(ValueError):
        pi.step(0.1, 0.025, 1, -1)

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

"""Validation of setpoints and duties (sma_actuator.control.inputs)."""
import math

import pytest
from sma_actuator.control.inputs import duty_problem, LastValid, setpoint_problem


@pytest.mark.parametrize('value', [math.nan, math.inf, -math.inf, 1.5, -1.01, 'x', None])
def test_bad_setpoints_are_named(value):
    assert setpoint_problem(value, -1.0, 1.0) is not None


def test_good_setpoints_pass():
    for v in (-1.0, 0.0, 0.37, 1.0):
        assert setpoint_problem(v, -1.0, 1.0) is None


@pytest.mark.parametrize('value', [[0.1], [0.1, 0.2, 0.3], [math.nan, 0], [0, math.inf],
                                   [-0.01, 0], [0, 1.01]])
def test_bad_duties_are_named(value):
    assert duty_problem(value) is not None


def test_last_valid_value_survives_rejections():
    gate = LastValid(lambda v: setpoint_problem(v, -1, 1), initial=0.0)
    assert gate.offer(0.4) is None
    assert 'not finite' in gate.offer(math.nan)
    assert gate.offer(7.0) is not None
    assert gate.value == 0.4 and gate.rejected == 2

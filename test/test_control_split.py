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

"""Antagonistic split and the never-both-above invariant (sma_actuator.control.split)."""
import numpy as np
import pytest
from sma_actuator.control.split import exclusive, split


def test_positive_command_heats_wire_a_negative_heats_wire_b():
    assert split(0.4) == (0.4, 0.0)
    assert split(-0.3) == (0.0, 0.3)
    assert split(0.0) == (0.0, 0.0)


def test_each_duty_is_limited_separately():
    assert split(0.9, limit_a=0.5) == (0.5, 0.0)
    assert split(-0.9, limit_b=0.2) == (0.0, 0.2)


def test_non_finite_command_is_rejected():
    with pytest.raises(ValueError):
        split(float('nan'))


def test_never_both_above_threshold_for_random_pairs():
    rng = np.random.default_rng(1)
    for a, b, t in rng.uniform(0, 1, size=(500, 3)):
        da, db = exclusive(a, b, t)
        assert min(da, db) <= t + 1e-15
        assert max(da, db) == max(a, b)        # the dominant wire is left alone
        assert da <= a and db <= b             # only ever reduces

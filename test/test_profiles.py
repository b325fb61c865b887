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

"""Setpoint profiles (sma_actuator.profiles)."""
import math

import numpy as np
import pytest
from sma_actuator.profiles import Profile, PROFILES


def test_every_profile_holds_the_offset_before_its_delay():
    for kind in PROFILES:
        p = Profile(kind, amplitude=0.4, offset=0.1, period_s=4.0, delay_s=2.0)
        assert p(0.0) == p(1.99) == 0.1


def test_step_jumps_by_the_amplitude():
    p = Profile('step', 0.4, 0.1, delay_s=1.0)
    assert p(1.0) == pytest.approx(0.5) and p(100.0) == pytest.approx(0.5)


def test_ramp_is_linear_over_one_period_then_holds():
    p = Profile('ramp', 0.6, 0.0, period_s=3.0, delay_s=0.0)
    t = np.linspace(0, 3, 31)
    np.testing.assert_allclose([p(x) for x in t], 0.2 * t, atol=1e-12)
    assert p(10.0) == pytest.approx(0.6)


def test_sine_has_its_period_and_amplitude():
    p = Profile('sine', 0.5, 0.2, period_s=20.0, delay_s=0.0)
    t = np.linspace(0, 40, 4001)
    r = np.array([p(x) for x in t])
    assert r.max() == pytest.approx(0.7, abs=1e-6) and r.min() == pytest.approx(-0.3, abs=1e-6)
    assert p(5.0) == pytest.approx(p(25.0))
    assert p(5.0) == pytest.approx(0.7)


def test_square_alternates_half_periods():
    p = Profile('square', 0.3, 0.0, period_s=2.0, delay_s=0.0)
    assert [p(x) for x in (0.1, 0.9, 1.1, 1.9, 2.1)] == [0.3, 0.3, -0.3, -0.3, 0.3]


def test_chirp_frequency_sweeps_from_one_over_period_to_the_end_frequency():
    p = Profile('chirp', 1.0, 0.0, period_s=10.0, delay_s=0.0, chirp_end_hz=1.0,
                chirp_duration_s=20.0)
    t = np.arange(0, 30, 0.001)
    r = np.array([p(x) for x in t])
    up = t[1:][(r[:-1] < 0) & (r[1:] >= 0)]        # upward zero crossings: one per cycle
    periods = np.diff(up)
    assert periods[0] > 2.0                       # starts slow (f0 = 0.1 Hz)
    late = periods[up[1:] > 21.0]
    assert late.mean() == pytest.approx(1.0, rel=0.02)   # after the sweep: f1 = 1 Hz
    assert (np.diff(periods[up[1:] < 20.0]) < 1e-3).all()   # monotone sweep


def test_bounds_contain_every_value():
    rng = np.random.default_rng(0)
    for kind in PROFILES:
        p = Profile(kind, amplitude=-0.3, offset=0.2, period_s=3.0, delay_s=0.5)
        lo, hi = p.bounds()
        vals = [p(t) for t in rng.uniform(0, 60, 500)]
        assert lo - 1e-12 <= min(vals) and max(vals) <= hi + 1e-12


@pytest.mark.parametrize('kwargs', [{'kind': 'triangle'}, {'period_s': 0.0},
                                    {'amplitude': math.nan}, {'delay_s': -1.0},
                                    {'chirp_end_hz': 0.0}])
def test_invalid_profiles_are_rejected(kwargs):
    with pytest.raises(ValueError):
        Profile(**kwargs)

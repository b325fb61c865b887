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

"""Tracking metrics (sma_actuator.control.metrics)."""
import numpy as np
import pytest
from sma_actuator.control import metrics


def test_rms_and_max_of_a_sine_error_match_their_definitions():
    t = np.linspace(0, 10, 10001)
    e = 0.2 * np.sin(2 * np.pi * t)
    assert metrics.rms_error(e, np.zeros_like(e)) == pytest.approx(0.2 / np.sqrt(2), rel=1e-3)
    assert metrics.max_error(np.zeros_like(e), e) == pytest.approx(0.2, rel=1e-6)


def test_settling_time_of_an_exponential_is_tau_ln_of_the_ratio():
    tau, tol, dt = 1.5, 0.02, 0.001
    t = np.arange(0, 20, dt)
    y = 1 - np.exp(-t / tau)
    ts = metrics.settling_time(t, np.ones_like(t), y, tol)
    assert ts == pytest.approx(tau * np.log(1 / tol), abs=2 * dt)


def test_settling_time_is_none_when_the_run_ends_outside_the_band():
    t = np.linspace(0, 5, 50)
    assert metrics.settling_time(t, np.ones(50), np.zeros(50), 0.1) is None


def test_summary_ignores_samples_before_t_start():
    t = np.arange(10.0)
    r = np.zeros(10)
    y = np.where(t < 5, 1.0, 0.01)
    s = metrics.summarize(t, r, y, 0.05, t_start=5)
    assert s['max_error'] == pytest.approx(0.01) and s['settling_time'] == 0.0


def test_mismatched_lengths_raise():
    with pytest.raises(ValueError):
        metrics.rms_error([0, 1], [0])

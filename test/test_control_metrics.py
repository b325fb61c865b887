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


def _second_order_step(zeta, wn, t):
    """Return the unit step response of wn² / (s² + 2 ζ wn s + wn²), underdamped (exact)."""
    wd = wn * np.sqrt(1 - zeta ** 2)
    phi = np.arccos(zeta)
    return 1 - np.exp(-zeta * wn * t) * np.sin(wd * t + phi) / np.sqrt(1 - zeta ** 2)


def test_overshoot_of_a_second_order_step_is_exp_of_minus_pi_zeta():
    t = np.arange(0, 30, 1e-3)
    for zeta in (0.2, 0.5, 0.7):
        y = _second_order_step(zeta, 2.0, t)
        expected = 100 * np.exp(-np.pi * zeta / np.sqrt(1 - zeta ** 2))
        assert metrics.overshoot_pct(t, np.ones_like(t), y) == pytest.approx(expected, rel=1e-3)


def test_rise_time_of_a_first_order_step_is_tau_ln_9():
    tau, dt = 0.8, 1e-4
    t = np.arange(0, 10, dt)
    y = 0.5 * (1 - np.exp(-t / tau))     # a 0.5 rad step
    expected = tau * np.log(9)
    assert metrics.rise_time(t, np.full_like(t, 0.5), y) == pytest.approx(expected, abs=2 * dt)
    assert metrics.overshoot_pct(t, np.full_like(t, 0.5), y) == 0.0


def test_rise_time_is_none_when_ninety_percent_is_never_reached():
    t = np.linspace(0, 5, 501)
    assert metrics.rise_time(t, np.ones_like(t), 0.8 * (1 - np.exp(-t))) is None


def test_a_downward_step_counts_overshoot_below_the_setpoint():
    t = np.arange(0, 30, 1e-3)
    y = -0.5 * _second_order_step(0.5, 2.0, t)
    expected = 100 * np.exp(-np.pi * 0.5 / np.sqrt(0.75))
    assert metrics.overshoot_pct(t, np.full_like(t, -0.5), y) == pytest.approx(expected, rel=1e-3)


def test_steady_state_error_is_the_mean_error_of_the_last_window():
    t = np.arange(0, 10, 0.01)
    y = np.where(t < 7, 0.0, 0.47)
    assert metrics.steady_state_error(t, np.full_like(t, 0.5), y, window_s=2.0) == \
        pytest.approx(0.03, abs=1e-3)


def test_phase_lag_of_a_delayed_sine_is_the_delay():
    period, delay = 20.0, 1.3
    t = np.arange(0, 60, 0.025)
    r = 0.5 * np.sin(2 * np.pi * t / period)
    y = 0.4 * np.sin(2 * np.pi * (t - delay) / period) + 0.01
    lag = metrics.phase_lag(t, r, y, period, t_start=20.0)
    assert lag['phase_lag_s'] == pytest.approx(delay, abs=1e-6)
    assert lag['phase_lag_deg'] == pytest.approx(360 * delay / period, abs=1e-4)
    assert lag['gain'] == pytest.approx(0.8, abs=1e-6)
    lead = metrics.phase_lag(t, r, 0.5 * np.sin(2 * np.pi * (t + 2.0) / period), period)
    assert lead['phase_lag_s'] == pytest.approx(-2.0, abs=1e-6)

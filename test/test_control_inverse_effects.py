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

"""pi_inverse uses every effect of the model; gains from the model; drift estimation."""
import inspect

import numpy as np
import pytest

from sma_actuator.control import ControllerCore, ControllerSettings
from sma_actuator.control.closed_loop import CorePlant, run_tracking
from sma_actuator.control.estimator import (DRIFT_OFFSET_BOUND_RAD, DRIFT_STROKE_BOUND,
                                            DriftEstimator)
from sma_actuator.control.feedforward import current_limit_inverse, InverseFeedforward
from sma_actuator.control.law import SensorMap
from sma_actuator.control.tuning import KI_RANGE, KP_RANGE, simc_gains
from sma_actuator.core.actuator import ActuatorParams, sensor_polynomial, simulate
from sma_actuator.profiles import Profile

DT = 0.025
SINE = Profile('sine', 0.5, period_s=20.0, delay_s=1.0)


def sine_rms(model, plant_params, **settings):
    """RMS error [rad] of pi_inverse on the 0.05 Hz sine after its first period."""
    ctrl = ControllerCore(model, ControllerSettings(mode='pi_inverse', **settings))
    run = run_tracking(ctrl, CorePlant(plant_params, DT), SINE, 41.0, DT)
    return run.summary(21.0)['rms_error']


def test_step_api_contract():
    params = inspect.signature(ControllerCore.step).parameters
    assert list(params)[1:] == ['setpoint_rad', 'measured_rad', 'dt_s', 'ambient_c']
    for mode in ('pi', 'pi_inverse'):
        ctrl = ControllerCore(ActuatorParams(), ControllerSettings(mode=mode))
        out = ctrl.step(0.3, 0.0, 0.025, 22.0)
        again = ctrl.step(setpoint_rad=0.3, measured_rad=0.01, dt_s=0.025, ambient_c=None)
        for o in (out, again):
            assert 0.0 <= o.duty_a <= 1.0 and 0.0 <= o.duty_b <= 1.0
        assert out.duty_a > 0.0 and out.duty_b == 0.0
    with pytest.raises(ValueError, match='dt_s'):
        ctrl.step(0.3, 0.0, 0.0, 22.0)


def test_sensor_inverse_round_trips_the_potentiometer_polynomial():
    model = ActuatorParams(sensor_c2_rad=0.15, sensor_c3_rad=-0.1, sensor_c4_rad=0.05)
    sensor = SensorMap(model)
    angles = np.linspace(-1.0, 1.0, 41)
    back = [sensor.angle(float(r)) for r in sensor_polynomial(model, angles)]
    np.testing.assert_allclose(back, angles, atol=1e-4)
    assert SensorMap(ActuatorParams()).angle(0.3) == 0.3
    # a rig whose travel is 5-17 mm: the table follows the travel, not ±2 about zero
    rig = ActuatorParams(sensor_centre_rad=11.0, sensor_half_span_rad=6.0, sensor_c2_rad=0.15,
                         sensor_c3_rad=-0.1)
    travel = np.linspace(5.0, 17.0, 41)
    back = [SensorMap(rig).angle(float(r)) for r in sensor_polynomial(rig, travel)]
    np.testing.assert_allclose(back, travel, atol=1e-3)


def test_the_thermal_inverse_uses_each_wires_own_parameters():
    model = ActuatorParams(gain_ratio_b=2.0, tau_ratio_b=0.5)
    ff = InverseFeedforward(model)
    d_a = ff.thermal_duty(0, 70.0, None, 22.0)
    d_b = ff.thermal_duty(1, 70.0, None, 22.0)
    assert d_b == pytest.approx(d_a / 2.0)
    # with the horizon, the faster wire b needs less overdrive to get there in time
    ff.horizon_s = 0.5
    fast_a, fast_b = ff.thermal_duty(0, 70.0, 30.0, 22.0), ff.thermal_duty(1, 70.0, 30.0, 22.0)
    assert fast_a > d_a and fast_b < fast_a / 2.0


def test_the_thermal_inverse_reaches_its_target_through_limit_and_convection():
    model = ActuatorParams(duty_limit=0.6, duty_limit_sharpness=4.0, convection_exponent=0.3)
    ff = InverseFeedforward(model)
    duty = ff.thermal_duty(0, 80.0, None, 22.0)
    n = int(30.0 / DT)
    theta = simulate(model, np.full(n, duty), np.zeros(n), DT).theta_a_c
    assert theta[-1] == pytest.approx(80.0, abs=1.0)


@pytest.mark.parametrize('sharpness', [0.0, 4.0])
def test_current_limit_inverse_inverts_the_kernels_limiter(sharpness):
    d_lim = 0.5
    for d in (0.1, 0.3, 0.45):
        x = d / d_lim
        eff = min(d, d_lim) if sharpness == 0 else d_lim * x / (1 + x ** sharpness) ** (
            1 / sharpness)
        assert current_limit_inverse(eff, d_lim, sharpness) == pytest.approx(d)
    assert current_limit_inverse(0.6, d_lim, sharpness, duty_max=0.9) == 0.9


def test_smith_prediction_cuts_the_tracking_error_on_a_delayed_plant():
    plant = ActuatorParams(delay_s=0.3)
    with_smith, without = sine_rms(plant, plant), sine_rms(plant, plant, smith=False)
    assert with_smith < 0.5 * without and with_smith < 0.03


def test_a_model_with_latent_heat_tracks_a_plant_that_has_it():
    # the estimate transforms as slowly as the plant, and the duty pays for the heat
    plant = ActuatorParams(latent_heat_k=20.0)
    knows, blind = sine_rms(plant, plant), sine_rms(ActuatorParams(), plant)
    assert knows < 0.5 * blind and knows < 0.01


def test_the_measured_ambient_drives_the_thermal_inverse():
    settings = ControllerSettings('pi_inverse', ff_horizon_s=0.0)
    cold = ControllerCore(ActuatorParams(ambient_gain=0.0), settings)
    warm = ControllerCore(ActuatorParams(ambient_gain=0.0), settings)
    cold_out, warm_out = cold.step(0.3, 0.3, DT, 22.0), warm.step(0.3, 0.3, DT, 32.0)
    assert 0.0 < warm_out.feedforward < cold_out.feedforward < 1.0
    assert warm_out.theta_est_c[0] > cold_out.theta_est_c[0]


def test_default_gains_come_from_the_model_and_get_gentler_with_delay():
    base = ActuatorParams()
    kp0, ki0 = simc_gains(base)
    kp1, ki1 = simc_gains(base.with_changes(delay_s=0.3))
    kp2, ki2 = simc_gains(base.with_changes(delay_s=0.8))
    assert kp0 > kp1 > kp2 > 0 and ki0 > ki1 > ki2 > 0
    ctrl = ControllerCore(base, ControllerSettings(mode='pi'))
    assert (ctrl.pi.kp, ctrl.pi.ki) == pytest.approx((kp0, ki0))
    assert ControllerCore(base, ControllerSettings(kp=2.0, ki=1.0)).gains() == (2.0, 1.0)
    # a stronger actuator (more stroke per duty) gets a smaller gain
    assert simc_gains(base.with_changes(stroke_rad=2.0))[0] == pytest.approx(kp0 / 2.0)
    # a degenerate fit (almost no stroke) gets bounded gains, not absurd ones
    assert simc_gains(base.with_changes(stroke_rad=1e-4)) == (KP_RANGE[1], KI_RANGE[1])


def test_drift_estimator_converges_and_stays_within_its_bounds():
    model = ActuatorParams()
    rng = np.random.default_rng(0)
    for offset, stroke, want_offset, want_stroke in (
            (0.05, 0.9, 0.05, 0.9), (0.5, 2.0, DRIFT_OFFSET_BOUND_RAD, 1 + DRIFT_STROKE_BOUND)):
        est = DriftEstimator(model, time_s=20.0)
        for k in range(4000):
            y_a = max(0.0, 0.8 * np.sin(2 * np.pi * k * DT / 10.0))
            y_b = max(0.0, -0.8 * np.sin(2 * np.pi * k * DT / 10.0))
            measured = offset + stroke * (y_a - y_b) + rng.normal(0, 0.002)
            est.update((y_a, y_b), measured, DT)
        assert est.offset == pytest.approx(want_offset, abs=0.01)
        assert est.stroke == pytest.approx(want_stroke, abs=0.02)


@pytest.mark.slow
def test_drift_correction_helps_when_the_plants_offset_differs_from_the_model():
    model = ActuatorParams()
    plant = model.with_changes(offset_rad=0.08, stroke_rad=0.9)
    ctrl = ControllerCore(model, ControllerSettings('pi_inverse', drift_correction=True))
    run = run_tracking(ctrl, CorePlant(plant, DT), SINE, 81.0, DT)
    corrected = run.summary(41.0)['rms_error']
    plain = ControllerCore(model, ControllerSettings('pi_inverse', drift_correction=False))
    uncorrected = run_tracking(plain, CorePlant(plant, DT), SINE, 81.0, DT).summary(41.0)
    assert corrected < 0.7 * uncorrected['rms_error']
    assert ctrl.drift.offset == pytest.approx(0.08, abs=0.02)

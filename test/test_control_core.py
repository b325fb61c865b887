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

"""ControllerCore (modes pi, pi_inverse, on_off) in closed loop with the core plant, no ROS."""
import numpy as np
import pytest
from sma_actuator.control.law import ControllerCore, ControllerSettings
from sma_actuator.control.metrics import summarize
from sma_actuator.core.actuator import ActuatorParams, AntagonisticActuator
from sma_actuator.profiles import Profile

DT = 0.025


def closed_loop(settings, profile, seconds, plant_params=None, model=None):
    """Run plant + controller at 25 ms; return time, reference, angle, duties, plant θ."""
    plant = AntagonisticActuator(plant_params or ActuatorParams())
    ctrl = ControllerCore(model or ActuatorParams(), settings)
    duty, rows = (0.0, 0.0), []
    for k in range(int(seconds / DT)):
        angle = plant.step(*duty, DT)
        r = profile(k * DT)
        out = ctrl.step(r, angle, DT)
        duty = (out.duty_a, out.duty_b)
        rows.append((k * DT, r, angle, *duty, *plant.temperature_c))
    return np.array(rows)


@pytest.mark.parametrize('mode', ['pi', 'pi_inverse'])
@pytest.mark.parametrize('amplitude', [0.4, -0.4])
def test_step_settles_on_both_wires(mode, amplitude):
    run = closed_loop(ControllerSettings(mode=mode), Profile('step', amplitude, delay_s=1.0), 15)
    m = summarize(run[:, 0], run[:, 1], run[:, 2], tolerance_rad=0.02, t_start=1.0)
    assert m['settling_time'] is not None and m['settling_time'] < 8.0


def test_inverse_compensation_beats_plain_pi_on_the_paper_sine():
    sine = Profile('sine', 0.5, period_s=20.0, delay_s=1.0)
    rms = {}
    for mode in ('pi', 'pi_inverse'):
        run = closed_loop(ControllerSettings(mode=mode), sine, 41)
        rms[mode] = summarize(run[:, 0], run[:, 1], run[:, 2], 0.02, t_start=21.0)['rms_error']
    assert rms['pi_inverse'] < 0.5 * rms['pi']


def test_duties_are_never_both_above_the_threshold_and_within_limits():
    s = ControllerSettings(mode='pi_inverse', duty_max=0.6, both_threshold=0.05)
    run = closed_loop(s, Profile('square', 0.6, period_s=6.0, delay_s=0.5), 20)
    da, db = run[:, 3], run[:, 4]
    assert (np.minimum(da, db) <= 0.05).all()
    assert da.max() <= 0.6 and db.max() <= 0.6 and da.max() > 0.5


def test_thermal_guard_keeps_the_plant_below_its_maximum():
    """An unreachable setpoint saturates the PI; the guard must hold the wire under 75 °C."""
    s = ControllerSettings(mode='pi', max_temp_c=75.0, kp=10.0, ki=10.0)
    run = closed_loop(s, Profile('constant', offset=0.99), 20)
    assert run[:, 5].max() <= 75.0 + 0.05
    assert run[:, 5].max() > 73.0


def test_on_off_mode_fully_heats_one_wire():
    run = closed_loop(ControllerSettings(mode='on_off', on_off_band_rad=0.05, max_temp_c=200),
                      Profile('square', 0.5, period_s=10.0, delay_s=0.5), 10)
    da, db = run[:, 3], run[:, 4]
    assert set(np.unique(da)) <= {0.0, 1.0} and set(np.unique(db)) <= {0.0, 1.0}
    assert da[(run[:, 0] > 1) & (run[:, 0] < 5)].mean() == 1.0
    assert db[(run[:, 0] > 6) & (run[:, 0] < 10)].mean() == 1.0


def test_idle_zeroes_duty_and_clears_the_integrator():
    ctrl = ControllerCore(ActuatorParams())
    for _ in range(40):
        ctrl.step(0.1, 0.0, DT)
    assert ctrl.pi.integral > 0
    out = ctrl.idle(DT)
    assert (out.duty_a, out.duty_b) == (0.0, 0.0) and ctrl.pi.integral == 0.0
    assert ctrl.last_duty == (0.0, 0.0)


def test_runtime_reconfiguration_validates_and_resets_on_mode_change():
    ctrl = ControllerCore(ActuatorParams())
    for _ in range(20):
        ctrl.step(0.1, 0.0, DT)
    ctrl.configure(kp=3.0)
    assert ctrl.pi.kp == 3.0 and ctrl.pi.integral > 0
    ctrl.configure(mode='pi_inverse')
    assert ctrl.pi.integral == 0.0
    with pytest.raises(ValueError):
        ctrl.configure(mode='bang_bang')
    with pytest.raises(ValueError):
        ctrl.configure(duty_max=1.5)
    assert ctrl.settings.mode == 'pi_inverse' and ctrl.settings.duty_max == 1.0


def test_on_off_relay_ignores_a_setpoint_dithering_inside_its_band():
    ctrl = ControllerCore(ActuatorParams(), ControllerSettings(mode='on_off', on_off_band_rad=0.1,
                                                               max_temp_c=200))
    seq = [ctrl.step(r, 0.0, DT) for r in (0.3, 0.05, -0.05, 0.0, -0.3, -0.3, -0.3)]
    # the reversal waits out the interlock's dead time (two 25 ms steps) at zero duty
    assert [(s.duty_a, s.duty_b) for s in seq] == [(1, 0)] * 4 + [(0, 0), (0, 0), (0, 1)]

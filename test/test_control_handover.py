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

"""pi_inverse's handover at zero crossings: interlock kept, incoming wire heated early."""
import math

import numpy as np
import pytest

from sma_actuator.control import ControllerCore, ControllerSettings, handover, law
from sma_actuator.control.closed_loop import CorePlant, run_tracking
from sma_actuator.control.estimator import DriftEstimator
from sma_actuator.control.feedforward import InverseFeedforward
from sma_actuator.control.tuning import transformation_start_c
from sma_actuator.core.actuator import ActuatorParams
from sma_actuator.profiles import Profile

DT = 0.025
SINE = Profile('sine', 0.5, period_s=20.0, delay_s=1.0)


def sine_run(model, plant, seconds=41.0, **settings):
    """pi_inverse on the 0.05 Hz ±0.5 rad sine (crossings at 1, 11, 21, 31 s)."""
    ctrl = ControllerCore(model, ControllerSettings(mode='pi_inverse', **settings))
    return run_tracking(ctrl, CorePlant(plant, DT), SINE, seconds, DT)


def test_transformation_start_is_the_models_as():
    model = ActuatorParams()
    # Flexinol LT defaults: As 68 °C; a loop shifted by 10 K moves it by 10 K
    assert 64.0 < transformation_start_c(model) < 70.0
    h = model.hysteresis.to_dict()
    shifted = model.with_changes(hysteresis=type(model.hysteresis).from_dict(
        {**h, 'lo': list(np.asarray(h['lo']) + 10.0), 'hi': list(np.asarray(h['hi']) + 10.0),
         'y0': h['y0'] - 10.0 * float(np.sum(h['w']))}))
    assert transformation_start_c(shifted) == pytest.approx(
        transformation_start_c(model) + 10.0, abs=0.5)


def test_the_wires_never_heat_within_the_dead_time_of_each_other():
    model = ActuatorParams()
    for dead_time in (0.05, 0.1):
        run = sine_run(model, model, dead_time_s=dead_time)
        heated = run.duty > 0
        assert not np.any(heated[:, 0] & heated[:, 1])
        gap = int(round(dead_time / DT))
        last = {0: -10 ** 6, 1: -10 ** 6}     # last sample each wire was heated
        for k, row in enumerate(heated):
            for j in (0, 1):
                if row[j]:
                    assert k - last[1 - j] > gap, (dead_time, k * DT)
                    last[j] = k


def test_the_incoming_wire_is_heated_before_the_crossing_and_tracking_improves():
    model = ActuatorParams()
    run = sine_run(model, model)
    # crossing at 31 s (reference falling through 0): wire b comes in, and is heated
    # well before the reference gets there, so that it moves when the reference crosses
    window = (run.time_s > 29.5) & (run.time_s < 31.0)
    assert np.any(run.duty[window, 1] > 0.5)
    with_handover = run.summary(21.0)['rms_error']
    without = sine_run(model, model, preheat=False).summary(21.0)['rms_error']
    assert with_handover < 0.8 * without


def test_far_on_one_side_the_antagonist_pulls_back_only_an_overshoot_beyond_5_percent():
    model = ActuatorParams()
    ff = InverseFeedforward(model)
    assert ff.target_side(0.4) == 1 and ff.target_side(-0.4) == -1 and ff.target_side(0.0) == 0
    # the shaft reads a little above the setpoint (under 5 % of the stroke): on a reference
    # rising at 0.05 rad/s, away from any crossing, and on a held one, wire b, far below its
    # transformation start, would only heat, or pull the shaft back too far once it
    # transforms; an overshoot of 0.2 rad on a held setpoint is pulled back by b
    cases = {'moving': lambda k: (0.4 + 0.05 * k * DT, 0.44 + 0.05 * k * DT),
             'held': lambda k: (-0.4, -0.43), 'held, overshot': lambda k: (0.4, 0.6)}
    duties = {}
    for name, reading in cases.items():
        ctrl = ControllerCore(model, ControllerSettings(mode='pi_inverse'))
        steps = [ctrl.step(*reading(k), DT, 22.0) for k in range(80)]
        duties[name] = max(s.duty_b for s in steps), max(s.duty_a for s in steps)
    assert duties['moving'][0] == 0.0 and duties['held'][1] == 0.0
    assert duties['held, overshot'][0] > 0.0


def test_a_square_wave_settles_without_the_antagonist_bouncing_it_back():
    # ±0.2 rad, 20 s: after each step the shaft overshoots its held target a little; a cold
    # antagonist heated to pull it back would transform and throw it back too far
    model = ActuatorParams()
    square = Profile('square', 0.2, period_s=20.0, delay_s=1.0)
    rms = {mode: run_tracking(ControllerCore(model, ControllerSettings(mode=mode)),
                              CorePlant(model, DT), square, 61.0, DT).summary(21.0)['rms_error']
           for mode in ('pi', 'pi_inverse')}
    assert rms['pi_inverse'] < 0.95 * rms['pi']


def test_the_antagonist_pulls_a_shaft_that_trails_a_falling_target():
    model = ActuatorParams()
    # the reference falls at 0.1 rad/s on wire a's side, away from any crossing; the shaft
    # hangs above it by more than 5 % of the stroke (wire a cools too slowly): b pulls;
    # by less, b stays cold and a's cooling takes the shaft down
    duties_b = {}
    for above in (0.15, 0.03):
        ctrl = ControllerCore(model, ControllerSettings(mode='pi_inverse'))
        duties_b[above] = max(ctrl.step(0.6 - 0.1 * k * DT, 0.6 - 0.1 * k * DT + above, DT,
                                        22.0).duty_b for k in range(40))
    assert duties_b[0.15] > 0.0 and duties_b[0.03] == 0.0


def slow_wires(**changes):
    """Return the package's wires with three times the heat capacity (τ 6.6 s)."""
    model = ActuatorParams()
    return model.with_changes(heat_capacity_j_per_k=3 * model.heat_capacity_j_per_k, **changes)


def test_a_slow_wire_tracks_better_when_the_antagonist_may_pull(monkeypatch):
    # the exact model, a 0.1 Hz sine: the falling half outruns wire a's cooling
    slow = slow_wires()
    sine = Profile('sine', 0.5, period_s=10.0, delay_s=1.0)

    def rms():
        ctrl = ControllerCore(slow, ControllerSettings(mode='pi_inverse'))
        return run_tracking(ctrl, CorePlant(slow, DT), sine, 31.0, DT).summary(11.0)[
            'rms_error']
    with_pull = rms()
    monkeypatch.setattr(law, 'ANTAGONIST_LAG_SHARE', math.inf)
    assert with_pull < 0.9 * rms()


def test_the_antagonist_pulls_where_the_target_outruns_the_active_wires_cooling(monkeypatch):
    # the exact model of wires three times slower, the 0.05 Hz sine: after each peak the
    # active wire, cooling freely, falls behind the falling target
    slow = slow_wires()
    amb, hot = slow.ambient_c, slow.ambient_c + slow.gain_k
    cold_ff, hot_ff = (InverseFeedforward(slow, horizon_s=0.2) for _ in range(2))
    hot_ff.track([hot, amb])
    for ff, theta in ((cold_ff, amb), (hot_ff, hot)):
        ff.duties(0.3, theta_est=(theta, amb))
    # a cold wire heats to its target; a hot one cannot cool to it within 0.2 s
    assert cold_ff.cooling_short == [False, False] and hot_ff.cooling_short == [True, False]

    calls, outrun = [], law.ControllerCore._outrun

    def recorded(self, *args):
        calls.append(outrun(self, *args))
        return calls[-1]

    def rms():
        ctrl = ControllerCore(slow, ControllerSettings(mode='pi_inverse'))
        return run_tracking(ctrl, CorePlant(slow, DT), SINE, 61.0, DT).summary(21.0)[
            'rms_error']
    monkeypatch.setattr(law.ControllerCore, '_outrun', recorded)
    released = rms()
    assert any(a for a, _ in calls) and any(b for _, b in calls)
    monkeypatch.setattr(law.ControllerCore, '_outrun', lambda *a: (False, False))
    assert released < 0.95 * rms()


def test_the_free_preheat_window_is_counted_in_the_incoming_wires_heating_time():
    def window_and_heating_s(params):
        pre = ControllerCore(params, ControllerSettings(mode='pi_inverse')).handover
        return pre.free_lead_s, [pre.time_needed_s(j, params.ambient_c, params.ambient_c)
                                 for j in (0, 1)]
    window, heating_s = window_and_heating_s(ActuatorParams())
    assert heating_s[0] == pytest.approx(0.79, abs=0.02)
    assert window == (handover.FREE_LEAD_S, handover.FREE_LEAD_S)
    window, heating_s = window_and_heating_s(slow_wires())
    assert heating_s[0] == pytest.approx(3 * 0.79, abs=0.05)
    assert window == pytest.approx([handover.FREE_LEAD_HEATS * t for t in heating_s])
    # wire b heats 0.6 times as strongly: it needs longer, and gets the longer window
    window, heating_s = window_and_heating_s(slow_wires(gain_ratio_b=0.6))
    assert heating_s[1] > 1.5 * heating_s[0] and window[1] > 1.5 * window[0]


def test_a_slow_wire_tracks_better_with_the_preheat_window_in_its_own_time():
    # the exact model, the 0.05 Hz sine: after each peak the antagonist is preheated while
    # the active wire cools through its loop, as on the package's wire within 3 s
    slow = slow_wires()

    def rms(window_s=None):
        ctrl = ControllerCore(slow, ControllerSettings(mode='pi_inverse'))
        if window_s is not None:
            ctrl.handover.free_lead_s = (window_s, window_s)
        return run_tracking(ctrl, CorePlant(slow, DT), SINE, 61.0, DT).summary(21.0)[
            'rms_error']
    assert rms() < 0.85 * rms(handover.FREE_LEAD_S)


def test_drift_correction_leaves_a_matched_model_alone():
    model = ActuatorParams()
    est = DriftEstimator(model, time_s=20.0)
    for k in range(2000):
        dy = 0.8 * np.sin(2 * np.pi * k * DT / 10.0)
        # the estimate sits 2 % low, inside the dead band: the model's values are used
        est.update((max(dy, 0.0), max(-dy, 0.0)), 0.98 * dy, DT)
    assert est.stroke_est == pytest.approx(0.98, abs=0.005)
    assert est.stroke == model.stroke_rad and est.offset == model.offset_rad


def test_a_model_that_misses_the_plant_gets_no_handover():
    model = ActuatorParams()
    ctrl = ControllerCore(model, ControllerSettings(mode='pi_inverse'))
    assert ctrl.handover.trusted
    # the shaft reads 0.3 rad away from anything the model predicts, for 10 s
    for k in range(400):
        ctrl.step(SINE(k * DT), 0.3, DT, 22.0)
    assert not ctrl.handover.trusted
    assert ctrl.handover.duties(0, 0.5, (22.0, 50.0), 22.0, DT) is None
    ctrl.reset()
    assert ctrl.handover.trusted


def test_reference_reversal_is_seen_coming_on_a_sine_but_not_on_a_ramp():
    from sma_actuator.control.law import ReferencePredictor
    sine, ramp = ReferencePredictor(), ReferencePredictor()
    for k in range(200):       # up to 0.5 s before the peak of the 0.05 Hz sine at 6 s
        t = 0.5 + k * DT
        sine.update(SINE(t), DT)
        ramp.update(0.05 * t, DT)
    assert SINE(5.5) < SINE(6.0)
    turn = sine.reversal(SINE(5.5), 0.9)
    # r + L ṙ + L² r̈ / 2 past the peak: close to the sine 0.9 s ahead (ṙ, r̈ smoothed over
    # 0.1 / 0.2 s lag a little)
    assert turn is not None and turn == pytest.approx(SINE(6.4), abs=0.006)
    assert sine.reversal(SINE(5.5), 0.3) is None        # the turn is more than 0.3 s away
    assert ramp.reversal(0.05 * 5.5, 0.9) is None

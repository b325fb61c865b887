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

"""Bad input to the core raises ValueError naming the offending parameter (never a silent NaN)."""
import numpy as np
import pytest
from sma_actuator.core import actuator as act
from sma_actuator.core import identification as idn
from sma_actuator.core import static_fit
from sma_actuator.core.hysteresis import (
    ModifiedPrandtlIshlinskii,
    PlayHysteresis,
    PrandtlIshlinskii,
    PreisachModel,
)
from sma_actuator.core.major_loop import MajorLoopHysteresis
from sma_actuator.core.sensor import Potentiometer
from sma_actuator.core.thermal import heating_power_w, on_current_a

NAN, INF = float('nan'), float('inf')
PI = PrandtlIshlinskii([0.5, 1.0], [0.5, 0.5])


def data(**over):
    """Return DynamicData keyword arguments for a valid 20-sample run, with overrides."""
    t = np.arange(20) * 0.1
    kw = {'time': t, 'duty_a': np.full(20, 0.3), 'duty_b': np.zeros(20), 'position': np.sin(t)}
    kw.update(over)
    return kw


REPEATED_T = np.r_[0.0, 0.1, 0.1, np.arange(3, 20) * 0.1]     # one repeated time stamp
GAP_T = np.r_[np.arange(10) * 0.1, 1.5 + np.arange(10) * 0.1]  # a 0.6 s gap in 0.1 s sampling

CASES = {
    # non-finite inputs
    'pi_nan_input': (lambda: PI.simulate([0.0, NAN]), r'^u contains a non-finite'),
    'pi_step_inf': (lambda: PI.step(INF), r'^u must be finite'),
    'major_loop_nan': (lambda: MajorLoopHysteresis().simulate([20.0, NAN]), r'^u contains'),
    'preisach_nan': (lambda: PreisachModel.grid(5).simulate([NAN]), r'^u contains'),
    'weights_nan': (lambda: PlayHysteresis([1.0], [-1.0], [1.0], [NAN]), r'^w \(weights\)'),
    'params_nan': (lambda: act.ActuatorParams(length_m=NAN), r'^length_m must be finite'),
    'ambient_nan': (lambda: act.AntagonisticActuator().step(0.1, 0.0, 0.025, ambient_c=NAN),
                    r'^ambient_c'),
    'data_position_nan': (lambda: idn.DynamicData(**data(position=np.full(20, NAN))),
                          r'^position contains'),
    # wrong shapes
    'pi_2d_input': (lambda: PI.simulate(np.zeros((4, 2))), r'^u must be a 1-D'),
    'pi_length_mismatch': (lambda: PlayHysteresis([1.0, 2.0], [-1.0], [1.0], [1.0]),
                           r'\br\b.*\blo\b'),
    'static_length_mismatch': (lambda: static_fit.fit_static([0, 1, 2], [0, 1]), r'input.*output'),
    'duty_length_mismatch': (lambda: act.simulate(act.ActuatorParams(), [0.1] * 5, [0.1] * 4,
                                                  0.025), r'duty_a and duty_b'),
    'data_length_mismatch': (lambda: idn.DynamicData(**data(duty_b=np.zeros(19))), r'duty_b'),
    # transformation temperatures
    'as_ge_af': (lambda: MajorLoopHysteresis(As=80.0, Af=78.0), r'^As must be below Af'),
    'mf_ge_ms': (lambda: MajorLoopHysteresis(Ms=42.0, Mf=42.0), r'^Mf must be below Ms'),
    # hysteresis parameters
    'pi_negative_K': (lambda: PrandtlIshlinskii([1.0], [-1.0]), r'^K \(backlash slopes\)'),
    'pi_negative_h': (lambda: PrandtlIshlinskii([-1.0], [1.0]), r'^h \(backlash half-widths\)'),
    'modified_K_le_K1': (lambda: ModifiedPrandtlIshlinskii.from_paper([1.0], [0.5], [0.5], [1.0]),
                         r'^K \(backlash slope\) must exceed K1'),
    'negative_r': (lambda: PlayHysteresis([-0.1], [-1.0], [1.0], [1.0]), r'^r \(play'),
    'lo_gt_hi': (lambda: PlayHysteresis([0.1], [1.0], [-1.0], [1.0]), r'^lo .*hi'),
    'preisach_alpha_lt_beta': (lambda: PreisachModel([0.0], [0.5], [1.0]),
                               r'^alpha must be >= beta'),
    'inverse_negative_w': (lambda: PlayHysteresis([0.1], [-1.0], [1.0], [-1.0]).inverse(),
                           r'^w \(weights\)'),
    # duty outside [0, 1]
    'power_duty': (lambda: heating_power_w(1.5, 5.0, 13.75, 0.35), r'^duty must be in \[0, 1\]'),
    'simulate_duty': (lambda: act.simulate(act.ActuatorParams(), [1.2], [0.0], 0.025), r'^duty_a'),
    'step_duty': (lambda: act.AntagonisticActuator().step(0.0, -0.1, 0.025), r'^duty_b'),
    'data_duty': (lambda: idn.DynamicData(**data(duty_a=np.full(20, 2.0))), r'^duty_a'),
    'duty_limit': (lambda: act.ActuatorParams(duty_limit=0.0), r'^duty_limit'),
    # dt <= 0 and other positives
    'simulate_dt': (lambda: act.simulate(act.ActuatorParams(), [0.1], [0.0], 0.0),
                    r'^dt must be positive'),
    'step_dt': (lambda: act.AntagonisticActuator().step(0.1, 0.0, -0.025),
                r'^dt must be positive'),
    'supply_v': (lambda: on_current_a(0.0, 13.75, 0.35), r'^supply_v must be positive'),
    'tau_fast': (lambda: act.ActuatorParams(tau_fast_s=-1.0), r'^tau_fast_s'),
    'pot_bits': (lambda: Potentiometer(bits=0), r'^bits'),
    'pot_counts': (lambda: Potentiometer(bits=8).angle(256), r'^counts'),
    # time base of dynamic data
    'time_not_increasing': (lambda: idn.DynamicData(**data(time=REPEATED_T)),
                            r'^time must be strictly increasing'),
    'time_non_uniform': (lambda: idn.DynamicData(**data(time=GAP_T)),
                         r'^time must be uniformly sampled'),
    'unknown_param': (lambda: act.ActuatorParams.from_dict({'tau_s_typo': 1.0}), r'tau_s_typo'),
}


@pytest.mark.parametrize('case', sorted(CASES))
def test_bad_input_raises_value_error_naming_parameter(case):
    call, pattern = CASES[case]
    with pytest.raises(ValueError, match=pattern):
        call()


def test_fit_dynamic_rejects_too_little_excitation():
    n = 400
    flat = idn.DynamicData(np.arange(n) * 0.025, np.full(n, 0.3), np.zeros(n),
                           np.random.default_rng(0).normal(0, 0.01, n))
    with pytest.raises(ValueError, match=r'too little excitation: the duties'):
        idn.fit_dynamic(flat)
    da = np.where(np.arange(n) % 100 < 50, 0.5, 0.0)
    still = idn.DynamicData(np.arange(n) * 0.025, da, np.zeros(n), np.zeros(n))
    with pytest.raises(ValueError, match=r'too little excitation: the measured position'):
        idn.fit_dynamic(still)

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

"""
Records with one hidden effect made by the package's own plant model (what `plant_sim` publishes.

`sma_actuator.core.actuator.simulate` with a catalog effect switched on, 12-bit potentiometer with
Gaussian noise), under the rich simulator's open-loop excitation.

The counterpart of support.richsim for data a user makes with `plant_sim -p <effect>:=...`:
the workbench model can represent these exactly, so a miss here is a fitting failure.
"""
import numpy as np
from sma_actuator.core.actuator import ActuatorParams, simulate as simulate_plant

from .richsim_excitation import open_loop_duty

# plant parameters per effect at three magnitudes (weak, middle, strong), inside the
# plant node's parameter ranges; saturation is not an option of the plant (always modified PI)
EFFECTS = {
    'fast_dynamics': [{'tau_fast_s': v} for v in (0.2, 0.6, 1.5)],
    'delay': [{'delay_s': v} for v in (0.1, 0.3, 0.8)],
    'convection': [{'convection_exponent': v} for v in (0.25, 0.5, 1.0)],
    'ambient_drift': [{'ambient_gain': v} for v in (0.5, 1.0, 2.0)],
    'phase_resistance': [{'phase_kappa': v} for v in (0.15, 0.3, 0.5)],
    'latent_heat': [{'latent_heat_k': v} for v in (3.0, 10.0, 25.0)],
    'stress_coupling': [{'stress_k': v} for v in (5.0, 20.0, 45.0)],
    'asymmetric_wires': [{'gain_ratio_b': 1.2}, {'gain_ratio_b': 1.4, 'tau_ratio_b': 0.8},
                         {'gain_ratio_b': 0.6, 'stroke_ratio_b': 1.5}],
    'sensor_nonlinearity': [{'sensor_c2_rad': 0.03},
                            {'sensor_c2_rad': 0.06, 'sensor_c3_rad': -0.05},
                            {'sensor_c2_rad': 0.15, 'sensor_c3_rad': -0.1, 'sensor_c4_rad': 0.05}],
    'fatigue_drift': [{'fatigue_offset_rad': 0.04, 'fatigue_cycles': 100.0},
                      {'fatigue_offset_rad': 0.08, 'fatigue_offset_b_rad': -0.04,
                       'fatigue_stroke': 0.15, 'fatigue_cycles': 40.0},
                      {'fatigue_offset_rad': 0.2, 'fatigue_stroke': 0.3, 'fatigue_cycles': 200.0}],
    'current_limit': [{'duty_limit': v} for v in (0.55, 0.5, 0.45)],
}
DUTY_MAX = 0.6
ADC_BITS, ADC_HALF_RANGE_RAD = 12, 1.2


def simulate(effect, level, duration_s=480.0, rate_hz=40.0, noise_rad=0.001, seed=0):
    """
    Return a dict of arrays time, duty_a, duty_b, position of `effect` at level 0, 1 or 2.

    With ambient_temperature for ambient_drift (drifting by about ±9 K); 'none': any level.
    """
    changes = {} if effect == 'none' else EFFECTS[effect][level]
    return simulate_with(changes, duration_s, rate_hz, noise_rad, seed)


def simulate_with(changes, duration_s=480.0, rate_hz=40.0, noise_rad=0.001, seed=0):
    """
    Return the record of `simulate` for plant parameter `changes` (one effect or several).

    The ambient drifts (as for ambient_drift) when `changes` sets ambient_gain.
    """
    rng = np.random.default_rng(seed)
    cmd = open_loop_duty(rng, duration_s, duty_max=DUTY_MAX)
    dt = 1.0 / rate_hz
    t = np.arange(int(round(duration_s * rate_hz))) * dt
    tick = np.minimum((t / 0.025).astype(int), len(cmd) - 1)
    da, db = cmd[tick, 0], cmd[tick, 1]
    ambient = None
    if 'ambient_gain' in changes:
        ambient = 22 + 6 * np.sin(2 * np.pi * t / 300) + 3 * np.sin(2 * np.pi * t / 77 + 1)
    angle = simulate_plant(ActuatorParams(**changes), da, db, dt, ambient_c=ambient).position_rad
    lsb = 2 * ADC_HALF_RANGE_RAD / (2 ** ADC_BITS - 1)
    measured = angle + rng.normal(0.0, noise_rad, len(t))
    position = np.round((measured + ADC_HALF_RANGE_RAD) / lsb) * lsb - ADC_HALF_RANGE_RAD
    out = {'time': t, 'duty_a': da, 'duty_b': db, 'position': position}
    if ambient is not None:
        out['ambient_temperature'] = ambient
    return out

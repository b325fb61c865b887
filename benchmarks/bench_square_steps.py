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
Where a square wave's tracking error comes from: the steps or the holds.

    python benchmarks/bench_square_steps.py [--models DIR] [--amplitude 0.4] [--seed 7]

pi and pi_inverse track a ±amplitude rad square of 20 s on plant_sim's model
(`control.closed_loop.CorePlant`, noise seed --seed) with three models of it: plant_sim's own
parameters (exact), the committed config/controller_model.yaml, and with --models the plain
model `bench_tracking.py --models DIR` fitted. Prints the RMS error from 21 s [rad], the
integrated squared error [rad² s] of the first 1.5 s after each of the four steps from 21 s,
and of the rest; then, for each step, the temperatures [°C] of the wire that takes over and
of the wire that held the level, and when the shaft crosses zero [s after the step].
"""
import argparse
from pathlib import Path

import numpy as np
from sma_actuator.control import ControllerCore, ControllerSettings, load_model
from sma_actuator.control.closed_loop import CorePlant, run_tracking
from sma_actuator.core.actuator import ActuatorParams
from sma_actuator.nodes.common import config_path
from sma_actuator.profiles import Profile

STEPS_S = (21.0, 31.0, 41.0, 51.0)
STEP_WINDOW_S = 1.5


class LoggedPlant(CorePlant):
    """`CorePlant` that keeps the wire temperatures [°C] after each step."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.temperatures = []

    def step(self, duty_a, duty_b):
        """Step as `CorePlant`; log [θ_a, θ_b] at the step's end."""
        reading = super().step(duty_a, duty_b)
        self.temperatures.append(self.actuator.temperature_c[:2])
        return reading


def decomposition(model, mode, amplitude, seed):
    """
    Return (RMS from 21 s, [ISE of each step window], ISE of the rest, [step lines]).

    A step line: the taking-over and holding wires' temperatures at the step [°C] and the
    time from the step to the shaft's zero crossing [s].
    """
    reference = Profile('square', amplitude, period_s=20.0, delay_s=1.0)
    plant = LoggedPlant(ActuatorParams(), seed=seed)
    run = run_tracking(ControllerCore(model, ControllerSettings(mode)), plant, reference, 61.0)
    t, dt = run.time_s, run.time_s[1] - run.time_s[0]
    theta = np.array(plant.temperatures)   # theta[k]: at t[k + 1]
    squared = (run.setpoint - run.position) ** 2
    steps, lines = [], []
    for s in STEPS_S:
        steps.append(float(np.sum(squared[(t >= s) & (t < s + STEP_WINDOW_S)]) * dt))
        k = int(np.searchsorted(t, s))
        new = 0 if run.setpoint[k] > 0 else 1
        crossed = t[(t > s) & (np.sign(run.position) == np.sign(run.setpoint[k]))]
        lines.append(f'{theta[k - 1, new]:.0f}/{theta[k - 1, 1 - new]:.0f} °C '
                     f'{crossed[0] - s if crossed.size else np.inf:.2f} s')
    total = float(np.sum(squared[t >= STEPS_S[0]]) * dt)
    return run.summary(STEPS_S[0])['rms_error'], steps, total - sum(steps), lines


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    ap.add_argument('--models', type=Path, help="bench_tracking.py's --models directory")
    ap.add_argument('--amplitude', type=float, default=0.4, help='square amplitude [rad]')
    ap.add_argument('--seed', type=int, default=7, help="the plant's noise seed")
    args = ap.parse_args()
    models = {'exact': ActuatorParams(),
              'committed': load_model(config_path('controller_model.yaml'))}
    if args.models:
        models['refitted'] = load_model(args.models / 'plant_plain_base.yaml')
    print(f'square ±{args.amplitude:g} rad, 20 s, plant_sim, seed {args.seed}: RMS from 21 s '
          f'[rad]; ISE [rad² s] of the first {STEP_WINDOW_S:g} s after each step and of the rest')
    table = []
    for name, model in models.items():
        for mode in ('pi', 'pi_inverse'):
            rms, steps, rest, lines = decomposition(model, mode, args.amplitude, args.seed)
            print(f'{name:9s} {mode:10s} {rms:.4f}   steps '
                  + ' '.join(f'{x:.3f}' for x in steps) + f'   rest {rest:.3f}')
            table.append(f'{name:9s} {mode:10s} ' + ' | '.join(lines))
    print('at each step: taking-over / holding wire [°C], zero crossing [s after the step]')
    print('\n'.join(table))


if __name__ == '__main__':
    main()

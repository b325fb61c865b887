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
The fit of a record whose duties were logged as sent, behind the bridge's interlock.

    python benchmarks/bench_logged_duty.py [--seeds 0 1 2] [--seconds 300]

plant_sim's model (`control.closed_loop.CorePlant`) behind the bridge's 0.05 s dead-time
interlock; the record logs the duties sent, as `recorder` logs `/sma/duty`, and the base
model is fitted on it (`workbench.engine.fit_model`, what `sma-model fit` runs).

* Open loop: `sma-model excite`'s design (`core.excitation.rig_excitation`, τ 2 s,
  full-stroke duty 0.5, 40 Hz) without the switch gap, with it (`SWITCH_GAP_S`), and the
  duties the plant applied.
* Closed loop: the controller in mode pi with the committed model on a random staircase
  (levels in ±0.6 rad held 2-8 s), keeping no dead time (`dead_time_s=0`: it reverses at
  once) and keeping the bridge's.

Prints the commands the interlock held and the training / validation NRMSE [%].
"""
import argparse

import numpy as np
from sma_actuator.control import ControllerCore, ControllerSettings, load_model
from sma_actuator.control.closed_loop import CorePlant, run_tracking
from sma_actuator.control.interlock import DEFAULT_DEAD_TIME_S
from sma_actuator.core.actuator import ActuatorParams
from sma_actuator.core.datakinds import DynamicData
from sma_actuator.core.excitation import rig_excitation, SWITCH_GAP_S
from sma_actuator.nodes.common import config_path
from sma_actuator.workbench.engine import fit_model

DT = 0.025


def record(duty_a, duty_b, seed, logged):
    """Return (DynamicData of the run, commands held); logged: 'sent' or 'applied' duties."""
    plant = CorePlant(ActuatorParams(), DT, seed=seed + 1000)
    position, applied = [plant.measure()], [plant.interlock.applied]
    for a, b in zip(duty_a[:-1], duty_b[:-1]):
        position.append(plant.step(a, b))
        applied.append(plant.interlock.applied)
    if logged == 'applied':
        duty_a, duty_b = np.array(applied[1:] + [(duty_a[-1], duty_b[-1])]).T
    data = DynamicData(np.arange(len(duty_a)) * DT, duty_a, duty_b, np.array(position))
    return data, plant.interlock.held


def staircase(seconds, seed):
    """Return reference(t) [rad]: random levels in ±0.6 rad held 2-8 s, 0 for the first 1 s."""
    rng = np.random.default_rng(seed)
    n = int(seconds / 2) + 1
    levels, ends = rng.uniform(-0.6, 0.6, n), np.cumsum(rng.uniform(2.0, 8.0, n))
    return lambda t: float(levels[min(np.searchsorted(ends, t), n - 1)]) if t > 1.0 else 0.0


def closed_loop_record(seconds, seed, dead_time_s):
    """Return (DynamicData of a pi run logged as sent, commands held)."""
    plant = CorePlant(ActuatorParams(), DT, seed=seed + 1000)
    ctrl = ControllerCore(load_model(config_path('controller_model.yaml')),
                          ControllerSettings('pi', dead_time_s=dead_time_s))
    run = run_tracking(ctrl, plant, staircase(seconds, seed), seconds, DT)
    return (DynamicData(run.time_s, run.duty[:, 0], run.duty[:, 1], run.position),
            plant.interlock.held)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    ap.add_argument('--seeds', type=int, nargs='+', default=[0, 1, 2])
    ap.add_argument('--seconds', type=float, default=300.0)
    args = ap.parse_args()
    print(f'{args.seconds:g} s at {1 / DT:g} Hz behind a {DEFAULT_DEAD_TIME_S:g} s interlock; '
          'base model NRMSE train / validation [%] (commands held)')
    cases = [('no gap, logged as sent', 0.0, 'sent'),
             (f'{SWITCH_GAP_S:g} s gap, logged as sent', SWITCH_GAP_S, 'sent'),
             ('no gap, the applied duties', 0.0, 'applied')]
    print("open loop, sma-model excite's design:")
    for seed in args.seeds:
        for name, gap_s, logged in cases:
            duty = rig_excitation(args.seconds, DT, 2.0, 0.5, seed=seed, switch_gap_s=gap_s)
            data, held = record(*duty, seed, logged)
            print_fit(f'seed {seed}  {name}', data, held)
    print('closed loop, mode pi, random staircase:')
    for seed in args.seeds:
        for dead_time_s in (0.0, DEFAULT_DEAD_TIME_S):
            data, held = closed_loop_record(args.seconds, seed, dead_time_s)
            print_fit(f'seed {seed}  controller dead time {dead_time_s:g} s', data, held)


def print_fit(name, data, held):
    """Fit the base model on `data`; print its training / validation NRMSE [%]."""
    fit = fit_model(data, ())
    print(f'{name:44s} {100 * fit.train["nrmse"]:6.3f} / {100 * fit.validation["nrmse"]:6.3f}'
          f'  ({held})')


if __name__ == '__main__':
    main()

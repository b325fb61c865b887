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
The fit of an identification record played through the bridge's interlock, logged as sent.

    python benchmarks/bench_excite_interlock.py [--seeds 0 1 2] [--seconds 300]

`sma-model excite`'s design (`core.excitation.rig_excitation`, τ 2 s, full-stroke duty 0.5,
40 Hz) drives plant_sim's model (`control.closed_loop.CorePlant`) behind the bridge's 0.05 s
dead-time interlock; the record logs the duties sent, as `recorder` logs `/sma/duty`. The
base model is fitted on it (`workbench.engine.fit_model`, what `sma-model fit` runs), for the
design without the switch gap, with it (`SWITCH_GAP_S`), and for the duties the plant
applied. Prints the commands the interlock held and the training / validation NRMSE [%].
"""
import argparse

import numpy as np
from sma_actuator.control.closed_loop import CorePlant
from sma_actuator.core.actuator import ActuatorParams
from sma_actuator.core.datakinds import DynamicData
from sma_actuator.core.excitation import rig_excitation, SWITCH_GAP_S
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


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    ap.add_argument('--seeds', type=int, nargs='+', default=[0, 1, 2])
    ap.add_argument('--seconds', type=float, default=300.0)
    args = ap.parse_args()
    print(f'{args.seconds:g} s at {1 / DT:g} Hz behind a 0.05 s interlock; base model '
          'NRMSE train / validation [%] (commands held)')
    cases = [('no gap, logged as sent', 0.0, 'sent'),
             (f'{SWITCH_GAP_S:g} s gap, logged as sent', SWITCH_GAP_S, 'sent'),
             ('no gap, the applied duties', 0.0, 'applied')]
    for seed in args.seeds:
        for name, gap_s, logged in cases:
            duty = rig_excitation(args.seconds, DT, 2.0, 0.5, seed=seed, switch_gap_s=gap_s)
            data, held = record(*duty, seed, logged)
            fit = fit_model(data, ())
            print(f'seed {seed}  {name:28s} {100 * fit.train["nrmse"]:6.3f} / '
                  f'{100 * fit.validation["nrmse"]:6.3f}  ({held})')


if __name__ == '__main__':
    main()

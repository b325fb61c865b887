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
pi_inverse behind a bridge whose interlock sees each command at a jittered arrival time.

    python benchmarks/bench_interlock_jitter.py [--jitter-ms 5] [--seeds 1 2 3 4]

plant_sim's model (`control.closed_loop.CorePlant`) behind a 0.05 s dead-time interlock
(`control.interlock`, as the hardware bridge applies it) that sees each command at its
sample's time + u, u uniform in ±jitter. pi_inverse with the committed model tracks a
0.05 Hz and a 0.2 Hz ±0.5 rad sine and a ±0.4 rad square of 20 s, with its own dead time
`dead_time_s` equal to the bridge's and one period (25 ms) longer, and with the bridge's
dead time and its estimate advanced on the duty the bridge applied (`applied fed`: what a
controller reading /sma/applied_duty could know at best, each period's applied duty with no
transport delay). Prints the RMS error after the first second [rad] and how often the
bridge held a duty the controller sent, without jitter and for each jitter seed.
"""
import argparse

import numpy as np
from sma_actuator.control import ControllerCore, ControllerSettings, load_model
from sma_actuator.control.closed_loop import CorePlant, run_tracking
from sma_actuator.control.interlock import DEFAULT_DEAD_TIME_S
from sma_actuator.core.actuator import ActuatorParams
from sma_actuator.nodes.common import config_path
from sma_actuator.profiles import Profile

BRIDGE_DEAD_TIME_S = DEFAULT_DEAD_TIME_S   # the bridge's default
REFERENCES = {
    'sine 0.05 Hz': (Profile('sine', 0.5, period_s=20.0, delay_s=0.0), 60.0),
    'sine 0.2 Hz': (Profile('sine', 0.5, period_s=5.0, delay_s=0.0), 30.0),
    'square ±0.4 rad, 20 s': (Profile('square', 0.4, period_s=20.0, delay_s=0.0), 60.0),
}


class BridgedPlant(CorePlant):
    """`CorePlant` whose interlock, as the bridge's, sees each command at a jittered time."""

    def __init__(self, jitter_s: float, seed: int):
        super().__init__(ActuatorParams(), seed=0, dead_time_s=BRIDGE_DEAD_TIME_S)
        self.rng_jitter = np.random.default_rng(seed)
        self.jitter_s = jitter_s

    def command_time_s(self) -> float:
        """Return the command's arrival time [s]: its sample's time ± the jitter."""
        return self.time_s + self.rng_jitter.uniform(-self.jitter_s, self.jitter_s)


class AppliedFedController(ControllerCore):
    """pi_inverse whose estimate advances on the duties the plant applied, not its commands."""

    plant = None

    def _advance(self, dt, ambient_c):
        """Advance the estimate by dt [s] on the duties the plant applied over it."""
        if self.plant is not None:
            self.last_duty = tuple(self.plant.applied)
        super()._advance(dt, ambient_c)


def run(model, reference, seconds, jitter_s, seed, dead_time_s, fed=False):
    """Return (RMS error after 1 s [rad], duties held) of one pi_inverse run."""
    plant = BridgedPlant(jitter_s, seed)
    settings = ControllerSettings('pi_inverse', dead_time_s=dead_time_s)
    if fed:
        ctrl = AppliedFedController(model, settings)
        ctrl.plant = plant
    else:
        ctrl = ControllerCore(model, settings)
    trace = run_tracking(ctrl, plant, reference, seconds)
    keep = trace.time_s >= 1.0
    rms = float(np.sqrt(np.mean((trace.setpoint[keep] - trace.position[keep]) ** 2)))
    return rms, plant.interlock.held


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    ap.add_argument('--jitter-ms', type=float, default=5.0, help='arrival jitter, ± [ms]')
    ap.add_argument('--seeds', type=int, nargs='+', default=[1, 2, 3, 4])
    args = ap.parse_args()
    model = load_model(config_path('controller_model.yaml'))
    print(f'bridge dead time {BRIDGE_DEAD_TIME_S} s; RMS error [rad] (duties held), '
          f'no jitter | ±{args.jitter_ms:g} ms, seeds {args.seeds}')
    variants = ((BRIDGE_DEAD_TIME_S, False), (BRIDGE_DEAD_TIME_S + 0.025, False),
                (BRIDGE_DEAD_TIME_S, True))
    for name, (reference, seconds) in REFERENCES.items():
        for dead_time_s, fed in variants:
            still = run(model, reference, seconds, 0.0, 0, dead_time_s, fed)
            jittered = [run(model, reference, seconds, args.jitter_ms * 1e-3, seed,
                            dead_time_s, fed) for seed in args.seeds]
            cells = ' '.join(f'{rms:.4f} ({held})' for rms, held in jittered)
            label = f'dead_time_s {dead_time_s:.3f} s{", applied fed" if fed else ""}'
            print(f'{name:22s} {label:32s}: {still[0]:.4f} ({still[1]}) | {cells}')


if __name__ == '__main__':
    main()

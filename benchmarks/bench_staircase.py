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
Setpoint staircases: pi vs pi_inverse on held targets between random levels.

    python benchmarks/bench_staircase.py [--seeds 3 4 5] [--hold-s 6 10 10]
        [--models runs/bench_tracking_models]

Each seed draws 14 levels uniform in ±0.6 rad after a start at 0, each held --hold-s [s]
(one per seed); the plants and models are bench_tracking.py's (plant_sim's model and the
rich simulator, each plain and with its effect, the model with the effect added; fitted
on 300 s of excitation, cached in --models). RMS error after the first hold [rad].
"""
import argparse
from pathlib import Path
import sys

import bench_tracking as bt
import numpy as np
from sma_actuator.control import ControllerCore, ControllerSettings
from sma_actuator.control.closed_loop import run_tracking

CASES = (('plant', 'plain'), ('plant', 'asymmetric_wires'), ('plant', 'sensor_nonlinearity'),
         ('plant', 'delay'), ('richsim', 'plain'), ('richsim', 'asymmetric_wires'),
         ('richsim', 'sensor_nonlinearity'), ('richsim', 'delay'))


def staircase(seed, hold_s):
    """Return reference(t) [rad]: 0, then 14 levels uniform in ±0.6 rad, each hold_s [s]."""
    levels = np.concatenate([[0.0], np.random.default_rng(seed).uniform(-0.6, 0.6, 14)])
    return lambda t: float(levels[min(int(t // hold_s), len(levels) - 1)]), hold_s * 15


def main():
    """Print the RMS error of pi and pi_inverse per plant and staircase."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    ap.add_argument('--seeds', nargs='*', type=int, default=[3, 4, 5])
    ap.add_argument('--hold-s', nargs='*', type=float, default=[6.0, 10.0, 10.0])
    ap.add_argument('--models', default='runs/bench_tracking_models')
    args = ap.parse_args()
    if len(args.hold_s) != len(args.seeds):
        ap.error('give one --hold-s per seed')
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'test'))
    Path(args.models).mkdir(parents=True, exist_ok=True)
    print('staircases of 14 random levels in ±0.6 rad: RMS error after the first hold [rad]')
    print(f'{"plant":8s} {"case":20s} {"seed":>4s} {"hold":>6s} {"pi":>7s} {"pi_inverse":>10s} '
          f'{"inv/pi":>7s}')
    total = np.zeros(2)
    for source, case in CASES:
        effect = (bt.PLANT_CASES if source == 'plant' else bt.RICH_CASES)[case][1]
        model, _, _ = bt.fitted_model(Path(args.models), source, case,
                                      [effect] if effect else [], 300.0, 1)
        for seed, hold_s in zip(args.seeds, args.hold_s):
            reference, seconds = staircase(seed, hold_s)
            rms = []
            for mode in ('pi', 'pi_inverse'):
                run = run_tracking(ControllerCore(model, ControllerSettings(mode=mode)),
                                   bt.make_plant(source, case, 7), reference, seconds, bt.DT)
                error = (run.setpoint - run.position)[run.time_s >= hold_s]
                rms.append(float(np.sqrt(np.mean(error ** 2))))
            total += rms
            print(f'{source:8s} {case:20s} {seed:4d} {hold_s:4g} s {rms[0]:7.4f} {rms[1]:10.4f} '
                  f'{rms[1] / rms[0]:7.3f}', flush=True)
    print(f'sum of the RMS errors: pi {total[0]:.4f}, pi_inverse {total[1]:.4f} rad')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())

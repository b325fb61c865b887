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
Closed-loop tracking: pi vs pi_inverse on the paper's 0.05 Hz, ±0.5 rad sine.

1. Identification run: plant_sim (accelerated) driven open loop by a multilevel duty
   excitation (`control.excitation.multilevel`, its own seed and its own noise seed);
   `core.identification.fit_dynamic` fits the thermal time constant and the modified-PI
   hysteresis from what came over /sma/joint_states. The controller's model is this fit
   (written to a YAML), never the plant's parameters.
2. Tracking runs: plant_sim + controller (model = the fit) + setpoint through the real
   topics, once per mode, same plant noise seed.
Printed side by side: RMS over the whole run (from the start of the sine) and over the
periods after the first (steady state), max error, and the pi_inverse / pi ratio
(target <= 0.5).

Run: python benchmarks/bench_tracking.py [--periods 3] [--plant gain_ratio_b=1.15 ...]
     [--free gain_ratio_b=0.5:2:1 ...] [--save-model config/controller_model.yaml]
"""
import argparse
import os
from pathlib import Path
import random
import tempfile
import time

import rclpy
from sma_actuator.control.excitation import multilevel
from sma_actuator.control.metrics import summarize
from sma_actuator.control.model_file import save_model
from sma_actuator.core.identification import DynamicData, fit_dynamic
from sma_actuator.nodes.harness import run_closed_loop, run_excitation

SINE = {'profile': 'sine', 'amplitude': 0.5, 'offset': 0.0, 'period_s': 20.0, 'delay_s': 1.0}


def identify(context, seconds, seed, plant, free=None):
    """Excitation run through plant_sim, then fit_dynamic; returns the DynamicFit."""
    duty_a, duty_b = multilevel(seconds, 0.025, seed=seed)
    t, a, b, pos = run_excitation(context, duty_a, duty_b, plant={**plant, 'seed': seed + 1000})
    return fit_dynamic(DynamicData(t, a, b, pos), free=free)


def parse_free(items):
    """NAME=lo:hi:init -> {NAME: (lo, hi, init)}; tau_s is always free."""
    if not items:
        return None
    out = {'tau_s': (0.3, 10.0, 2.0)}
    for item in items:
        name, _, spec = item.partition('=')
        out[name] = tuple(float(v) for v in spec.split(':'))
    return out


def parse_overrides(items):
    out = {}
    for item in items:
        key, _, value = item.partition('=')
        out[key] = float(value)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    ap.add_argument('--periods', type=int, default=3, help='sine periods per tracking run')
    ap.add_argument('--excitation-s', type=float, default=150.0)
    ap.add_argument('--seed', type=int, default=1, help='excitation seed')
    ap.add_argument('--plant', nargs='*', default=[], metavar='PARAM=VALUE',
                    help='plant_sim effect overrides (hidden from the model structure)')
    ap.add_argument('--controller', nargs='*', default=[], metavar='PARAM=VALUE',
                    help='controller parameter overrides for both modes, e.g. kp=1.5 ki=2')
    ap.add_argument('--free', nargs='*', default=[], metavar='NAME=LO:HI:INIT',
                    help='extra model parameters to identify (fit_dynamic free), e.g. '
                         'gain_ratio_b=0.5:2:1')
    ap.add_argument('--save-model', default='', help='also write the identified model here')
    ns = ap.parse_args()
    plant = parse_overrides(ns.plant)
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    context = rclpy.context.Context()
    rclpy.init(context=context, domain_id=random.SystemRandom().randint(101, 200))
    try:
        t0 = time.monotonic()
        fit = identify(context, ns.excitation_s, ns.seed, plant, parse_free(ns.free))
        t_id = time.monotonic() - t0
        header = (f'Identified by benchmarks/bench_tracking.py from a {ns.excitation_s:g} s '
                  f'multilevel excitation (seed {ns.seed}) of plant_sim {plant or "(defaults)"}\n'
                  f'validation NRMSE {fit.validation["nrmse"]:.4f}, tau_s {fit.params.tau_s:.4f}')
        model_path = Path(ns.save_model) if ns.save_model else Path(
            tempfile.mkdtemp()) / 'controller_model.yaml'
        save_model(fit.params, model_path, header)
        duration = SINE['delay_s'] + ns.periods * SINE['period_s']
        results = {}
        for mode in ('pi', 'pi_inverse'):
            t1 = time.monotonic()
            trace = run_closed_loop(context, SINE, duration, mode=mode, real_time_factor=100.0,
                                    plant={**plant, 'seed': 7},
                                    controller={**parse_overrides(ns.controller),
                                                'model_file': str(model_path)})
            a = trace.arrays()
            t = a['time_s'] - a['time_s'][0]
            whole = summarize(t, a['setpoint'], a['position'], 0.025, SINE['delay_s'])
            steady = summarize(t, a['setpoint'], a['position'], 0.025,
                               SINE['delay_s'] + SINE['period_s'])
            results[mode] = (whole, steady, time.monotonic() - t1)
    finally:
        rclpy.try_shutdown(context=context)
    print(f'identification: {ns.excitation_s:g} s excitation, {t_id:.1f} s wall; train NRMSE '
          f'{fit.train["nrmse"]:.4f}, validation NRMSE {fit.validation["nrmse"]:.4f}, '
          f'tau_s {fit.params.tau_s:.3f} s, {fit.params.hysteresis.n_operators} play operators'
          f', free {fit.free}; model {model_path}')
    print(f'plant overrides: {plant or "none"}; controller overrides: '
          f'{parse_overrides(ns.controller) or "none"}; '
          f'sine 0.05 Hz ±0.5 rad, {ns.periods} periods')
    print(f'{"mode":12s} {"rms whole":>10s} {"rms steady":>11s} {"max steady":>11s} '
          f'{"wall s":>7s}')
    for mode, (whole, steady, wall) in results.items():
        print(f'{mode:12s} {whole["rms_error"]:10.4f} {steady["rms_error"]:11.4f} '
              f'{steady["max_error"]:11.4f} {wall:7.1f}')
    for key, i in (('whole', 0), ('steady', 1)):
        ratio = results['pi_inverse'][i]['rms_error'] / results['pi'][i]['rms_error']
        print(f'ratio pi_inverse / pi ({key}): {ratio:.3f}   (target <= 0.5: '
              f'{"met" if ratio <= 0.5 else "NOT met"})')


if __name__ == '__main__':
    main()

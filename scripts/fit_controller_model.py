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
Make config/controller_model.yaml: record plant_sim's excitation run, then sma-model fit it.

1. plant_sim (the ROS node, accelerated, lockstep, noise seed SEED + 1000) is driven open
   loop by `core.excitation.multilevel` (150 s, seed SEED) through the real topics
   (`in_process.run_excitation`); the record is written as a CSV
   (time,duty_a,duty_b,position) next to the model, `<out>.record.csv`.
2. ``sma-model fit <record> --out <out>`` fits the paper's model (plus --add EFFECT ...)
   exactly as a user would; the provenance (this command, the record, the fit's scores)
   is written as a comment header on top of the model file.

Run: python scripts/fit_controller_model.py [--out config/controller_model.yaml]
     [--seconds 150] [--seed 1] [--plant delay_s=0.2 ...] [--add delay ...]
"""
import argparse
import os
from pathlib import Path
import random
import sys

import numpy as np
import rclpy
from sma_actuator.core.excitation import multilevel
from sma_actuator.in_process import run_excitation
from sma_actuator.workbench.cli import main as sma_model
import yaml

DT = 0.025


def record(path, seconds, seed, plant):
    """Run the excitation through plant_sim and write the record CSV; return its length."""
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    context = rclpy.context.Context()
    domain = int(os.environ.get('ROS_DOMAIN_ID', random.SystemRandom().randint(101, 200)))
    rclpy.init(context=context, domain_id=domain)
    try:
        duty_a, duty_b = multilevel(seconds, DT, seed=seed)
        t, a, b, pos = run_excitation(context, duty_a, duty_b,
                                      plant={**plant, 'seed': seed + 1000})
    finally:
        rclpy.try_shutdown(context=context)
    np.savetxt(path, np.column_stack([t - t[0], a, b, pos]), delimiter=',',
               header='time,duty_a,duty_b,position', comments='',
               fmt=['%.4f', '%.5f', '%.5f', '%.6f'])
    return len(t)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[1])
    ap.add_argument('--out', default='config/controller_model.yaml')
    ap.add_argument('--seconds', type=float, default=150.0, help='excitation length [s]')
    ap.add_argument('--seed', type=int, default=1, help='excitation seed')
    ap.add_argument('--plant', nargs='*', default=[], metavar='PARAM=VALUE',
                    help='plant_sim parameter overrides (effects the model must learn)')
    ap.add_argument('--add', nargs='*', default=[], metavar='EFFECT',
                    help='effects to fit besides the paper model (sma-model fit --add)')
    ns = ap.parse_args(argv)
    try:
        plant = {k: float(v) for k, _, v in (p.partition('=') for p in ns.plant)}
    except ValueError:
        print(f'error: --plant takes PARAM=NUMBER, got {ns.plant}', file=sys.stderr)
        return 2
    out = Path(ns.out)
    rec = out.with_name(out.stem + '.record.csv')
    n = record(rec, ns.seconds, ns.seed, plant)
    cmd = ['fit', str(rec), '--out', str(out), '--force'] + (['--add', *ns.add] if ns.add else [])
    status = sma_model(cmd)
    if status:
        return status
    spec = yaml.safe_load(out.read_text(encoding='utf-8'))
    val = spec['scores']['validation']['nrmse']
    m = spec['model']
    tau = m['heat_capacity_j_per_k'] / m['conductance_w_per_k']
    header = (f'Produced by scripts/fit_controller_model.py --seconds {ns.seconds:g} '
              f'--seed {ns.seed}' + (f' --plant {" ".join(ns.plant)}' if ns.plant else '')
              + (f' --add {" ".join(ns.add)}' if ns.add else '') + '\n'
              f'record: {rec.name}, {n} samples at 40 Hz: plant_sim '
              f'{plant or "(defaults)"} driven open loop by core.excitation.multilevel '
              f'(seed {ns.seed}, noise seed {ns.seed + 1000})\n'
              f'model: sma-model {" ".join(cmd[:-1])}; validation NRMSE {100 * val:.2f} %, '
              f'tau_s {tau:.3f} s')
    out.write_text(''.join(f'# {line}\n' for line in header.splitlines())
                   + out.read_text(encoding='utf-8'), encoding='utf-8')
    out.chmod(0o644)     # a package config file, readable by every user
    print(f'wrote {out} (validation NRMSE {100 * val:.2f} %) from {rec}')
    return 0


if __name__ == '__main__':
    sys.exit(main())

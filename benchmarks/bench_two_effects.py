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
Two hidden effects at once: whether `diagnose --rounds` finds both.

Records of the package's own plant (test/support/plant_records.py, 480 s at 40 Hz, open
loop, noise 0.001 rad) with two catalog effects switched on at a weak or middle level.
For each pair: the effects added round by round (up to 3 rounds), the held-out NRMSE
after each (in brackets: a base refitted before a round's effect was named, see
`engine.better_base`), the seconds, and `ok` when exactly the two hidden effects were
added.

    python benchmarks/bench_two_effects.py [--jobs 2] [--rounds 3]
"""
import argparse
from pathlib import Path
import sys
import time

from sma_actuator.workbench.parallel import keep_freed_memory, one_blas_thread

one_blas_thread()   # before numpy loads, as `sma-model` and the record workers run
keep_freed_memory()   # fits reuse their freed arrays (see workbench.parallel)
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'test'))

from sma_actuator.core.identification import DynamicData  # noqa: E402, I100
from sma_actuator.workbench.engine import diagnose_rounds, fit_model  # noqa: E402
from support import plant_records  # noqa: E402
from support.parallel import imap_on_cores  # noqa: E402

# (effect, level, effect, level): each pair of kinds once, weak (0) and middle (1) levels
PAIRS = [('delay', 0, 'convection', 0), ('fast_dynamics', 0, 'phase_resistance', 0),
         ('convection', 1, 'stress_coupling', 0), ('phase_resistance', 0, 'latent_heat', 0),
         ('asymmetric_wires', 0, 'current_limit', 0),
         ('sensor_nonlinearity', 0, 'fatigue_drift', 0), ('delay', 1, 'stress_coupling', 1),
         ('convection', 0, 'current_limit', 1), ('latent_heat', 2, 'sensor_nonlinearity', 1),
         ('fast_dynamics', 1, 'asymmetric_wires', 1)]


def run_case(case):
    """Run the rounds on one two-effect record; return (both found, its result line)."""
    (e1, l1, e2, l2, seed), rounds = case
    started = time.perf_counter()
    changes = dict(plant_records.EFFECTS[e1][l1], **plant_records.EFFECTS[e2][l2])
    d = plant_records.simulate_with(changes, seed=seed)
    data = DynamicData(d['time'], d['duty_a'], d['duty_b'], d['position'])
    base = fit_model(data)
    _, added, _ = diagnose_rounds(data, base, rounds)
    names = [a['added'] for a in added]
    # a round that refitted its base first shows that refit's error in brackets
    errors = [f'{100 * base.validation["nrmse"]:.2f}']
    for a in added:
        if 'refitted_base_nrmse' in a:
            errors.append(f'({100 * a["refitted_base_nrmse"]:.2f})')
        errors.append(f'{100 * a["validation_nrmse"]:.2f}')
    ok = sorted(names) == sorted([e1, e2])
    return ok, (f'{e1 + " L" + str(l1):22s} {e2 + " L" + str(l2):24s} '
                f'{" + ".join(names) or "-":52s} '
                f'{" > ".join(errors) + " %":30s} '
                f'{time.perf_counter() - started:5.0f}  {"ok" if ok else "MISSED"}')


def main():
    ap = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    ap.add_argument('--jobs', type=int, default=2, help='records in parallel')
    ap.add_argument('--rounds', type=int, default=3)
    args = ap.parse_args()
    print('plant: 480 s at 40 Hz, open loop, noise 0.001 rad; two effects per record')
    print(f'{"effect 1":22s} {"effect 2":24s} {"added, round by round":52s} '
          f'{"held-out NRMSE":30s}     s')
    cases = [(pair + (700 + i,), args.rounds) for i, pair in enumerate(PAIRS)]
    found = []
    for _, (ok, line) in imap_on_cores(run_case, cases, args.jobs):
        found.append(ok)
        print(line, flush=True)
    print(f'both found: {sum(found)} of {len(found)}')


if __name__ == '__main__':
    main()

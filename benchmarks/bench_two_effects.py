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
loop, noise 0.001 rad) with two catalog effects switched on at a weak or middle level; or,
with `--source richsim`, of the independent rich simulator (test/support/richsim.py, 480 s
at 40 Hz, open loop, noise 0.002 rad) with two of its effects, level 0/1/2 the low end,
middle and high end of each effect's magnitude range. For the rich simulator, `--rate`,
`--duration`, `--excitation closed` and `--param KEY=VALUE` (another rig, as in
`bench_hidden_effects.py`) change the records; the seeds stay those of the 40 Hz table.
For each pair: the effects added round by round (up to 3 rounds) and then removed as
redundant next to the others (`- name`, `diagnosis.prune_effects`), the held-out NRMSE
after each (in brackets: a base refitted before a round's effect was named, see
`diagnosis.better_base`), the seconds, and `ok` when the final model holds exactly the two
hidden effects.

    python benchmarks/bench_two_effects.py [--jobs 2] [--rounds 3] [--source richsim]
        [--rate 40] [--duration 480] [--excitation open|closed] [--param KEY=VALUE ...]
        [--only K ...]
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
from sma_actuator.workbench.diagnosis import diagnose_rounds  # noqa: E402
from sma_actuator.workbench.engine import fit_model  # noqa: E402
from support import plant_records  # noqa: E402
from support.parallel import imap_on_cores  # noqa: E402
from support.richsim import (  # noqa: E402
    EFFECTS as RICH_EFFECTS, rig_from_command_line, simulate)

# (effect, level, effect, level): each pair of kinds once, weak (0) and middle (1) levels
PAIRS = [('delay', 0, 'convection', 0), ('fast_dynamics', 0, 'phase_resistance', 0),
         ('convection', 1, 'stress_coupling', 0), ('phase_resistance', 0, 'latent_heat', 0),
         ('asymmetric_wires', 0, 'current_limit', 0),
         ('sensor_nonlinearity', 0, 'fatigue_drift', 0), ('delay', 1, 'stress_coupling', 1),
         ('convection', 0, 'current_limit', 1), ('latent_heat', 2, 'sensor_nonlinearity', 1),
         ('fast_dynamics', 1, 'asymmetric_wires', 1)]
# the same for the rich simulator, which has no latent heat but a drifting ambient
RICH_PAIRS = [('delay', 1, 'convection', 1), ('fast_dynamics', 1, 'phase_resistance', 1),
              ('convection', 1, 'stress_coupling', 1), ('phase_resistance', 1, 'ambient_drift', 0),
              ('asymmetric_wires', 1, 'current_limit', 1),
              ('sensor_nonlinearity', 1, 'fatigue_drift', 1), ('delay', 1, 'stress_coupling', 1),
              ('convection', 0, 'current_limit', 1),
              ('ambient_drift', 1, 'sensor_nonlinearity', 1),
              ('fast_dynamics', 1, 'asymmetric_wires', 1)]


def rich_magnitude(effect, level):
    """Magnitude of a rich-simulator effect at level 0/1/2: low end, middle, high end."""
    lo, hi = RICH_EFFECTS[effect]['magnitude_range']
    return lo + 0.5 * level * (hi - lo)


def record(args, e1, l1, e2, l2, seed):
    """Return the DynamicData of a two-effect record of `args.source`."""
    if args.source == 'richsim':
        d = simulate(e1, rich_magnitude(e1, l1), args.excitation, duration_s=args.duration,
                     rate_hz=args.rate, noise_rad=0.002, seed=seed, params=args.params,
                     also=[(e2, rich_magnitude(e2, l2))])
        return DynamicData(d['time'], d['duty_a'], d['duty_b'], d['position'],
                           d['ambient_temperature'])
    changes = dict(plant_records.EFFECTS[e1][l1], **plant_records.EFFECTS[e2][l2])
    d = plant_records.simulate_with(changes, seed=seed)
    return DynamicData(d['time'], d['duty_a'], d['duty_b'], d['position'])


def run_case(case):
    """Run the rounds on one two-effect record; return (both found, its result line)."""
    (e1, l1, e2, l2, seed), args = case
    started = time.perf_counter()
    data = record(args, e1, l1, e2, l2, seed)
    base = fit_model(data)
    _, added, _ = diagnose_rounds(data, base, args.rounds)
    names = [a['added'] for a in added]
    # a round that refitted its base first shows that refit's error in brackets
    errors = [f'{100 * base.validation["nrmse"]:.2f}']
    for a in added:
        if 'refitted_base_nrmse' in a:
            errors.append(f'({100 * a["refitted_base_nrmse"]:.2f})')
        errors.append(f'{100 * a["validation_nrmse"]:.2f}')
    # an effect judged redundant next to the others after the rounds: "- name", its error
    removed = [a for a in added if a.get('removed')]
    names += [f'- {a["added"]}' for a in removed]
    errors += [f'{100 * a["validation_nrmse_without"]:.2f}' for a in removed]
    kept = [a['added'] for a in added if not a.get('removed')]
    ok = sorted(kept) == sorted([e1, e2])
    return ok, (f'{e1 + " L" + str(l1):22s} {e2 + " L" + str(l2):24s} '
                f'{" + ".join(names) or "-":52s} '
                f'{" > ".join(errors) + " %":30s} '
                f'{time.perf_counter() - started:5.0f}  {"ok" if ok else "MISSED"}')


def main():
    ap = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    ap.add_argument('--jobs', type=int, default=2, help='records in parallel')
    ap.add_argument('--rounds', type=int, default=3)
    ap.add_argument('--source', choices=('plant', 'richsim'), default='plant')
    ap.add_argument('--only', type=int, nargs='+', metavar='K',
                    help='run only these pairs (0-based, in the order of PAIRS / RICH_PAIRS)')
    ap.add_argument('--rate', type=float, default=40.0, help='sample rate [Hz] (richsim)')
    ap.add_argument('--duration', type=float, default=480.0, help='record length [s] (richsim)')
    ap.add_argument('--excitation', choices=('open', 'closed'), default='open',
                    help="open-loop duty steps or the simulator's own PI (richsim)")
    ap.add_argument('--param', action='append', default=[], metavar='KEY=VALUE',
                    help='a rich-simulator rig parameter (test/support/richsim.py DEFAULTS)')
    args = ap.parse_args()
    rich = args.source == 'richsim'
    if not rich and (args.rate != 40.0 or args.duration != 480.0 or args.excitation != 'open'):
        ap.error('--rate, --duration and --excitation need --source richsim')
    args.params = rig_from_command_line(ap, args.param, rich)
    noise = 0.002 if rich else 0.001
    print(f'{args.source}: {args.duration:.0f} s at {args.rate:g} Hz, {args.excitation} loop, '
          f'noise {noise} rad; two effects per record'
          + ''.join(f', {k} = {v:g}' for k, v in args.params.items()))
    print(f'{"effect 1":22s} {"effect 2":24s} {"added, round by round":52s} '
          f'{"held-out NRMSE":30s}     s')
    pairs = RICH_PAIRS if args.source == 'richsim' else PAIRS
    cases = [(pair + (700 + i,), args) for i, pair in enumerate(pairs)
             if args.only is None or i in args.only]
    found = []
    for _, (ok, line) in imap_on_cores(run_case, cases, args.jobs):
        found.append(ok)
        print(line, flush=True)
    print(f'both found: {sum(found)} of {len(found)}')


if __name__ == '__main__':
    main()

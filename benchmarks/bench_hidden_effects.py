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
Detection limits of `sma-model diagnose` on data with one hidden effect.

For every catalog effect and a few magnitudes, generate a record with that one hidden
effect, run diagnose, and print: the base model's held-out NRMSE, whether the hidden effect
is named first and significant, its held-out improvement, and what was named instead;
then the named candidate's typical gain (`judging.typical_gain`, the median over 5 blocks of
held-out time) and its RMSE against the base's in each block (base/named [rad]), which say
whether the name rests on one block. Also the null case. With `--rounds N` (N > 1) each
record then goes through `diagnose --rounds N` from the same base: the effects added round
by round (`- name`: then removed as redundant next to the others), the held-out NRMSE
after each, and `exact` when the final model holds the hidden effect and nothing else
(nothing, for the null record). Two sources of records:
  --source richsim (default): the independent rich simulator over its magnitude range
      (test/support/richsim.py EFFECTS); the figure the hidden-effect tests sample from;
  --source plant: the package's own plant model with the effect switched on, as
      `plant_sim` makes it (test/support/plant_records.py; weak, middle, strong setting).
--layout single (rich simulator, open loop): wire b is never heated, so the record is one
wire against a bias spring; effects that need two wires are left out.
--excitation rig (rich simulator): the package's `core.excitation.rig_excitation` in the
rig's own time (τ = its cooling_tau_s, full duty = its duty_max) instead of the simulator's
own duty sequences; no saturation case (the simulator's saturation is an excitation).

    python benchmarks/bench_hidden_effects.py [--source richsim|plant] [--duration 480]
        [--rate 40] [--excitation open|closed|rig] [--layout antagonistic|single]
        [--param KEY=VALUE ...] (another rig: richsim DEFAULTS keys, e.g.
                                 wire_diameter_m=200e-6 cooling_tau_s=2.5)
        [--effects NAME ...]   (a subset: same records as in the full run, no null case)
        [--jobs N]             (records diagnosed in parallel, one BLAS thread each; the
                                seconds column then includes the contention)
        [--rounds N]           (also run the rounds to the end, up to N)
"""
import argparse
from pathlib import Path
import sys
import time

from sma_actuator.workbench.parallel import keep_freed_memory, one_blas_thread

one_blas_thread()   # before numpy loads, as `sma-model` and the record workers run
keep_freed_memory()   # fits reuse their freed arrays (see workbench.parallel)
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'test'))

from sma_actuator.core.excitation import rig_excitation  # noqa: E402, I100
from sma_actuator.core.identification import DynamicData  # noqa: E402
from sma_actuator.workbench.diagnosis import diagnose_rounds  # noqa: E402
from sma_actuator.workbench.effects import get_effect  # noqa: E402
from sma_actuator.workbench.engine import fit_model  # noqa: E402
from sma_actuator.workbench.judging import held_out_block_rmse, typical_gain  # noqa: E402
from support import plant_records  # noqa: E402
from support.parallel import imap_on_cores  # noqa: E402
from support.richsim import (  # noqa: E402
    DEFAULTS, EFFECTS, rig_from_command_line, simulate, simulate_profile)


def run_case(case):
    """Diagnose one simulated record (effect, magnitude, args, seed); returns a result row."""
    effect, magnitude, args, seed = case
    if args.source == 'plant':
        d = plant_records.simulate(effect, int(magnitude), duration_s=args.duration,
                                   rate_hz=args.rate, noise_rad=args.noise, seed=seed)
    elif args.excitation == 'rig':
        rig = dict(DEFAULTS, **args.params)
        duty = rig_excitation(args.duration, rig['cmd_dt_s'], rig['cooling_tau_s'],
                              rig['duty_max'], args.layout, seed)
        d = simulate_profile(*duty, effect=effect, magnitude=magnitude, rate_hz=args.rate,
                             noise_rad=args.noise, seed=seed, params=args.params)
    else:
        d = simulate(effect, magnitude=magnitude, excitation=args.excitation,
                     duration_s=args.duration, rate_hz=args.rate, noise_rad=args.noise,
                     seed=seed, params=args.params, layout=args.layout)
    ambient = None if args.no_ambient else d.get('ambient_temperature')
    data = DynamicData(d['time'], d['duty_a'], d['duty_b'], d['position'], ambient,
                       layout=args.layout)
    t0 = time.perf_counter()
    kind = 'classical' if effect == 'saturation' else None
    # round 1 is `diagnose(data)`: the same base fit, the same diagnosis
    diags, added, _ = diagnose_rounds(data, fit_model(data, (), kind=kind), args.rounds,
                                      kind=kind)
    diag = diags[0]
    mine = next((c for c in diag.candidates if c['effect'] == effect), None)
    named = next((c for c in diag.candidates if c['effect'] == diag.missing_effect), None)
    return {'effect': effect, 'magnitude': magnitude,
            'base_nrmse': diag.baseline.validation['nrmse'],
            'named': diag.missing_effect,
            'first': diag.candidates[0]['effect'],
            'improvement': None if mine is None else mine['improvement'],
            'typical': None if named is None or 'fit' not in named
            else typical_gain(data, diag.baseline, named['fit']),
            'blocks': [] if named is None or 'fit' not in named
            else held_out_block_rmse(data, diag.baseline, named['fit']).T.tolist(),
            'rounds': [a['added'] for a in added]
            + [f'- {a["added"]}' for a in added if a.get('removed')],
            'round_nrmse': [a['validation_nrmse'] for a in added]
            + [a['validation_nrmse_without'] for a in added if a.get('removed')],
            'exact': sorted(a['added'] for a in added if not a.get('removed'))
            == ([] if effect == 'none' else [effect]),
            'seconds': time.perf_counter() - t0}


def main():
    ap = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    ap.add_argument('--duration', type=float, default=480.0)
    ap.add_argument('--rate', type=float, default=40.0)
    ap.add_argument('--source', choices=('richsim', 'plant'), default='richsim')
    ap.add_argument('--noise', type=float, default=None,
                    help='position noise [rad] (default 0.002 richsim, 0.001 plant)')
    ap.add_argument('--excitation', choices=('open', 'closed', 'rig'), default='open')
    ap.add_argument('--layout', choices=('antagonistic', 'single'), default='antagonistic')
    ap.add_argument('--param', action='append', default=[], metavar='KEY=VALUE',
                    help='a rich-simulator rig parameter (test/support/richsim.py DEFAULTS)')
    ap.add_argument('--effects', nargs='*', default=None)
    ap.add_argument('--jobs', type=int, default=1)
    ap.add_argument('--rounds', type=int, default=1,
                    help='run diagnose --rounds up to this many rounds (1: the first only)')
    ap.add_argument('--no-ambient', action='store_true',
                    help='hand diagnose no ambient column, as from a rig that logs none')
    args = ap.parse_args()
    plant = args.source == 'plant'
    if args.noise is None:
        args.noise = 0.001 if plant else 0.002
    if args.layout == 'single' and (plant or args.excitation == 'closed'):
        ap.error('--layout single needs --source richsim and --excitation open or rig')
    if args.excitation == 'rig' and (plant or 'saturation' in (args.effects or ())):
        ap.error('--excitation rig needs --source richsim and has no saturation case (the '
                 "simulator's saturation is an excitation)")
    args.params = rig_from_command_line(ap, args.param, not plant)
    catalog = plant_records.EFFECTS if plant else EFFECTS
    effects = args.effects or [e for e in catalog if e != 'none' and not (
        args.layout == 'single' and get_effect(e).needs_two_wires) and not (
        args.excitation == 'rig' and e == 'saturation')]
    loop = 'open loop' if plant else {'open': 'open loop', 'closed': 'closed loop',
                                      'rig': 'open loop (rig_excitation)'}[args.excitation]
    print(f'{args.source}: {args.duration:.0f} s at {args.rate:.0f} Hz, '
          f'{loop}, {args.layout}, noise {args.noise} rad'
          + (', no ambient column' if args.no_ambient else '')
          + ('; M = level 0/1/2 of test/support/plant_records.py' if plant else '')
          + ''.join(f', {k} = {v:g}' for k, v in args.params.items()))
    print(f'{"effect":20s} {"M":>5s} {"base NRMSE":>10s} {"named":>20s} '
          f'{"improvement":>11s} {"typical":>8s} {"s":>5s}')
    rows = []

    def report(row):
        rows.append(row)
        imp = '-' if row['improvement'] is None else f'{100 * row["improvement"]:+.0f} %'
        typ = '-' if row['typical'] is None else f'{100 * row["typical"]:+.0f} %'
        ok = row['named'] == (None if row['effect'] == 'none' else row['effect'])
        rounds = ''
        if args.rounds > 1:
            errors = ' > '.join(f'{100 * e:.2f}' for e in [row['base_nrmse']]
                                + row['round_nrmse'])
            rounds = (f'  rounds: {" + ".join(row["rounds"]) or "-"} ({errors} %) '
                      f'{"exact" if row["exact"] else "NOT EXACT"}')
        print(f'{row["effect"]:20s} {row["magnitude"]:5.2f} {100 * row["base_nrmse"]:9.2f}% '
              f'{str(row["named"]):>20s} {imp:>11s} {typ:>8s} {row["seconds"]:5.0f}  '
              f'{"ok" if ok else "MISSED"}  '
              + ' '.join(f'{e0:.4f}/{e1:.4f}' for e0, e1 in row['blocks']) + rounds, flush=True)

    unknown = sorted(set(effects) - set(catalog) - {'none'})
    if unknown:
        known = ', '.join(['none'] + [e for e in catalog if e != 'none'])
        ap.error(f'unknown effect(s) {", ".join(unknown)}; known: {known}')
    cases = [('none', 0.0, args, 100)] if not args.effects or 'none' in effects else []
    order = [e for e in catalog if e != 'none']
    for effect in (e for e in effects if e != 'none'):
        k = order.index(effect)          # same seeds whether run alone or with the others
        if plant:
            levels = range(len(catalog[effect]))
        else:
            lo, hi = catalog[effect]['magnitude_range']
            levels = sorted({lo, 0.5 * (lo + hi), hi})
        for j, m in enumerate(levels):
            cases.append((effect, m, args, 200 + 10 * k + j))
    for _, row in imap_on_cores(run_case, cases, args.jobs):
        report(row)
    hits = sum(r['named'] == (None if r['effect'] == 'none' else r['effect']) for r in rows)
    print(f'named correctly: {hits} of {len(rows)}')
    if args.rounds > 1:
        print(f'after up to {args.rounds} rounds, exactly the hidden effect: '
              f'{sum(r["exact"] for r in rows)} of {len(rows)}')


if __name__ == '__main__':
    main()

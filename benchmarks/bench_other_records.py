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
How well a model fitted on a rig's few records predicts the rig's other records.

A stand-in for the measured spring-biased wire: the independent rich simulator
(test/support/richsim.py, one wire against the loop tension, 100 Hz, noise 0.001 rad),
driven with the duty profiles of the three shared records (`square_a`: full duty D from
10 s to 30 s, then off, 70 s; `step_a`: D from 10 s, 50 s; `ramp_a`: 0 -> D from 5 s to
25 s, then held, 50 s), D = --duty. The model fitted on them (`fit_model` on the joined
records, as `sma-model fit A B C` writes it) predicts six other records of the same rig,
each from its own rest: steps to 0.6 D and 0.7 D, a staircase up and down in fifths of D,
a triangle, a ramp down, a 0.05 Hz sine and a pulse train. Per rig effect (--effects
NAME:MAGNITUDE, `none` for the plain rig): the RMSE of each other record as a share of the
measured range over all records [%], for the base model and the base + that effect, fitted
on the three records and on the three plus the staircase (a record at five duty levels).
With --diagnose, the base rows also give what `diagnose` names on their training records,
the ramp held out (given last, as `sma-model diagnose` holds out the last record).

    python benchmarks/bench_other_records.py [--jobs 2] [--duty 0.45] [--diagnose]
        [--effects none convection:2 current_limit:1 ...] [--param cooling_tau_s=6 ...]
"""
import argparse
from pathlib import Path
import sys
import time

from sma_actuator.workbench.parallel import keep_freed_memory, one_blas_thread

one_blas_thread()   # before numpy loads, as `sma-model` and the workers run
keep_freed_memory()   # fits reuse their freed arrays (see workbench.parallel)
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'test'))

import numpy as np  # noqa: E402, I100
from sma_actuator.workbench.diagnosis import diagnose  # noqa: E402
from sma_actuator.workbench.engine import fit_model, record_scores  # noqa: E402
from sma_actuator.workbench.records import join  # noqa: E402
from support.parallel import imap_on_cores  # noqa: E402
from support.richsim import EFFECTS, rig_from_command_line  # noqa: E402
from support.rig_profiles import EXTRA, profiles, records, SHARED  # noqa: E402


# the simulator's effects a wire against a spring has (saturation changes the excitation)
ONE_WIRE = [e for e in EFFECTS if e not in ('saturation', 'stress_coupling', 'asymmetric_wires')]


def run_case(case):
    """Fit one model on the training records; return ({record: RMSE share}, name, seconds)."""
    (effect, magnitude, added, train), args = case
    started = time.perf_counter()
    recs = records(effect, magnitude, args.duty, args.params)
    held_out = tuple(name for name, _ in recs if name not in train)
    data = join(recs, held_out=held_out)
    fit = fit_model(data, effects=added)
    share = {r['data']: r['scores']['all']['rmse'] / data.span()
             for r in record_scores(data, fit.prediction, fit.split) if r['data'] in held_out}
    named = named_effect(recs, train) if args.diagnose and not added else ''
    return share, named, time.perf_counter() - started


def named_effect(recs, train):
    """Return what `diagnose` names on the `train` records, the ramp given last (held out)."""
    order = [n for n in train if n != 'ramp'] + ['ramp']
    by_name = dict(recs)
    data = join([(n, by_name[n]) for n in order], held_out=('ramp',))
    return diagnose(data, base=fit_model(data), jobs=1).missing_effect or 'nothing'


def main():
    """Print the other records' errors for each rig effect, model and training set."""
    ap = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    ap.add_argument('--jobs', type=int, default=2, help='fits in parallel')
    ap.add_argument('--duty', type=float, default=0.45, help='full duty D of the profiles')
    ap.add_argument('--effects', nargs='+', metavar='NAME:MAGNITUDE',
                    default=['none:0', 'convection:2', 'current_limit:1',
                             'phase_resistance:1.4'])
    ap.add_argument('--diagnose', action='store_true',
                    help='also give what diagnose names on the base rows')
    ap.add_argument('--param', action='append', default=[], metavar='KEY=VALUE',
                    help='a rich-simulator rig parameter (test/support/richsim.py DEFAULTS)')
    args = ap.parse_args()
    if not 0 < args.duty <= 1:
        ap.error(f'--duty {args.duty}: give a duty in (0, 1]')
    args.params = rig_from_command_line(ap, args.param)
    rigs = []
    for item in args.effects:
        name, _, magnitude = item.partition(':')
        try:
            rigs.append((name, float(magnitude or 1)))
        except ValueError:
            ap.error(f'--effects {item}: give NAME:MAGNITUDE, e.g. convection:2')
        if name not in ONE_WIRE:
            ap.error(f'--effects {item}: {name!r} is not a rich-simulator effect of one wire '
                     f'({", ".join(ONE_WIRE)})')
    trains = (SHARED, SHARED + (EXTRA,))
    cases = [((e, m, added, train), args) for e, m in rigs
             for added in ((), (e,))[:1 + (e != 'none')] for train in trains]
    print(f'richsim, one wire, 100 Hz, noise 0.001 rad, full duty {args.duty:g}'
          + ''.join(f', {k} = {v:g}' for k, v in args.params.items()))
    others = [n for n in profiles(args.duty) if n not in SHARED + (EXTRA,)]
    print(f'{"rig effect":22s} {"model":25s} {"fitted on":11s} '
          + ' '.join(f'{n:>9s}' for n in others) + '    median  diagnose names       s')
    for ((effect, magnitude, added, train), _), (share, named, took) in imap_on_cores(
            run_case, cases, args.jobs):
        figures = [100 * share[n] for n in others]
        print(f'{f"{effect} {magnitude:g}":22s} {" + ".join(("base",) + added):25s} '
              f'{"3 + stairs" if EXTRA in train else "3 shared":11s} '
              + ' '.join(f'{x:7.2f} %' for x in figures)
              + f' {np.median(figures):7.2f} %  {named:18s} {took:4.0f}', flush=True)
    return 0


if __name__ == '__main__':
    np.seterr(all='ignore')
    raise SystemExit(main())

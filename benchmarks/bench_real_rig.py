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
Benchmark the workbench on the measured spring-biased wire records, with timings.

    .venv/bin/python benchmarks/bench_real_rig.py [--effects sensor_zero] [--diagnose]
        [--only-diagnose] [--held-out ramp_a] [--jobs 0]
        [--dir ../shared/data/real/spring_biased_wire]

1. leave one record out: fit on the other records, the whole-record NRMSE of the left-out
   one, normalised by the range of the measured position over all records [%];
2. fit on all records (the last one held out, the workbench default; --held-out to
   choose), wall time;
3. with --diagnose: `diagnose` over every catalog effect on all records, wall time, what
   it names and the held-out error before and after (--only-diagnose: this part alone).
"""
import argparse
from pathlib import Path
import time

from sma_actuator.workbench.parallel import one_blas_thread

one_blas_thread()   # before numpy loads, as `sma-model` runs: the same fits, the same figures

import numpy as np  # noqa: E402, I100
from sma_actuator.workbench.data import load_data  # noqa: E402
from sma_actuator.workbench.engine import diagnose, fit_model, record_scores  # noqa: E402
from sma_actuator.workbench.records import join  # noqa: E402

NAMES = ('square_a', 'step_a', 'ramp_a')


def main():
    """Print leave-one-record-out NRMSE, fit and diagnose timings."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    ap.add_argument('--dir', default='../shared/data/real/spring_biased_wire')
    ap.add_argument('--effects', nargs='*', default=['sensor_zero'])
    ap.add_argument('--diagnose', action='store_true')
    ap.add_argument('--only-diagnose', action='store_true')
    ap.add_argument('--held-out', default=NAMES[-1], choices=NAMES)
    ap.add_argument('--jobs', type=int, default=0)
    args = ap.parse_args()
    recs = [(n, load_data(Path(args.dir) / f'{n}.csv')) for n in NAMES]
    effects = tuple(args.effects)
    data = join(recs, held_out=(args.held_out,))
    if not args.only_diagnose:
        leave_one_out(recs, effects, data)
    if args.diagnose or args.only_diagnose:
        started = time.perf_counter()
        base = fit_model(data)
        diag = diagnose(data, base=base, jobs=args.jobs)
        took = time.perf_counter() - started
        best = next((c for c in diag.candidates if c['effect'] == diag.missing_effect), None)
        print(f'diagnose (base fit + {len(diag.candidates)} candidates): {took:.1f} s; '
              f'names {diag.missing_effect}')
        for c in diag.candidates:
            v = c['validation_nrmse']
            print(f'  {c["effect"]:<20} {"n/a" if v is None else f"{100 * v:.2f} %":>8} '
                  f'{"yes" if c["significant"] else "no"}')
        if best:
            print(f'held-out NRMSE {100 * base.validation["nrmse"]:.2f} % -> '
                  f'{100 * best["fit"].validation["nrmse"]:.2f} %')
    return 0


def leave_one_out(recs, effects, data):
    """Print the whole-record NRMSE of each record fitted on the others, then a fit on all."""
    print(f'model: base + {", ".join(effects) or "nothing"}')
    print(f'{"left out":<10} {"NRMSE":>7} {"RMSE":>9} {"fit time":>9}')
    for held in NAMES:
        started = time.perf_counter()
        loo = join(recs, held_out=(held,))
        fit = fit_model(loo, effects=effects)
        per = record_scores(loo, fit.prediction, fit.split)
        sc = {r['data']: r['scores']['all'] for r in per}[held]
        print(f'{held:<10} {100 * sc["nrmse"]:6.2f} % {sc["rmse"]:6.3f} mm '
              f'{time.perf_counter() - started:7.1f} s', flush=True)
    started = time.perf_counter()
    fit = fit_model(data, effects=effects)
    print(f'fit on all three ({data.segments[-1][0]} held out): '
          f'{time.perf_counter() - started:.1f} s, '
          f'validation NRMSE {100 * fit.validation["nrmse"]:.2f} %')


if __name__ == '__main__':
    np.seterr(all='ignore')
    raise SystemExit(main())

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

1. leave one record out, as `sma-model fit` of several records does
   (`workbench.crossval`): the whole-record NRMSE of each record predicted by the model
   fitted on the others, normalised by the range of the measured position over all
   records [%], and of the model fitted on all records; wall time of the fits;
2. with --diagnose: `diagnose` over every catalog effect on all records (the --held-out
   record held out, default the last), wall time, what it names and the held-out error
   before and after (--only-diagnose: this part alone).
"""
import argparse
from pathlib import Path
import time

from sma_actuator.workbench.parallel import keep_freed_memory, one_blas_thread

one_blas_thread()   # before numpy loads, as `sma-model` runs: the same fits, the same figures
keep_freed_memory()   # fits reuse their freed arrays (see workbench.parallel)

import numpy as np  # noqa: E402, I100
from sma_actuator.workbench.crossval import cross_validate  # noqa: E402
from sma_actuator.workbench.data import load_data  # noqa: E402
from sma_actuator.workbench.diagnosis import diagnose  # noqa: E402
from sma_actuator.workbench.engine import fit_model  # noqa: E402
from sma_actuator.workbench.records import join  # noqa: E402

NAMES = ('square_a', 'step_a', 'ramp_a')


def main():
    """Print leave-one-record-out NRMSE, fit and diagnose timings."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    ap.add_argument('--dir', default='../shared/data/real/spring_biased_wire')
    ap.add_argument('--effects', nargs='*', default=[])
    ap.add_argument('--diagnose', action='store_true')
    ap.add_argument('--only-diagnose', action='store_true')
    ap.add_argument('--held-out', default=NAMES[-1], choices=NAMES)
    ap.add_argument('--jobs', type=int, default=0)
    args = ap.parse_args()
    recs = [(n, load_data(Path(args.dir) / f'{n}.csv')) for n in NAMES]
    effects = tuple(args.effects)
    if not args.only_diagnose:
        leave_one_out(recs, effects, args.jobs)
    if args.diagnose or args.only_diagnose:
        data = join(recs, held_out=(args.held_out,))
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


def leave_one_out(recs, effects, jobs):
    """Print the whole-record NRMSE of each record left out, and of the model fitted on all."""
    print(f'model: base + {", ".join(effects) or "nothing"}')
    started = time.perf_counter()
    _, fit, rows = cross_validate(recs, effects, jobs=jobs)
    took = time.perf_counter() - started
    print(f'{"record":<10} {"left out: NRMSE":>16} {"RMSE":>9}   {"fitted on all: NRMSE":>20}')
    for r in rows:
        out, on_all = r['scores']['all'], r['scores']['train']
        print(f'{r["data"]:<10} {100 * out["nrmse"]:14.2f} % {out["rmse"]:6.3f} mm '
              f'{100 * on_all["nrmse"]:20.2f} %')
    print(f'pooled     {100 * fit.validation["nrmse"]:14.2f} % {fit.validation["rmse"]:6.3f} mm '
          f'{100 * fit.train["nrmse"]:20.2f} %')
    cores = f'{jobs} processes' if jobs else 'every core'
    print(f'{len(rows) + 1} fits ({len(rows)} left out, 1 on all) on {cores}: {took:.1f} s')


if __name__ == '__main__':
    np.seterr(all='ignore')
    raise SystemExit(main())

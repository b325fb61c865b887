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
Benchmark: `diagnose` over every catalog effect on 10 minutes of 40 Hz data.

Target (issue 6): under 60 s wall time on the 2-core CI machine. The record is simulated
with `sma_actuator.core.actuator.simulate` (paper model, Flexinol defaults) under random
antagonistic duty segments, with a measured ambient that drifts by 2 K (so that
`ambient_drift` is applicable too) and 3 mrad Gaussian position noise. The timed part is
what `sma-model diagnose DATA` does after loading: the base fit plus one refit per
candidate effect. Data generation and one small warm-up fit (numba kernels) are not timed.

    .venv/bin/python benchmarks/bench_diagnose.py [--minutes 10] [--rate 40] [--jobs 1 0] [--check]

Times the run in one process (--jobs 1) and on every core (0, what `sma-model diagnose`
does by default) side by side.

--check: exit status 1 if the timed part exceeds the target.
"""
import argparse
import sys
import time

from sma_actuator.workbench.parallel import available_cores, keep_freed_memory, one_blas_thread

one_blas_thread()   # before numpy loads, as `sma-model` runs
keep_freed_memory()   # fits reuse their freed arrays (see workbench.parallel)

import numpy as np  # noqa: E402, I100
from sma_actuator.core.actuator import ActuatorParams, simulate  # noqa: E402
from sma_actuator.core.identification import DynamicData  # noqa: E402
from sma_actuator.workbench.diagnosis import diagnose  # noqa: E402
from sma_actuator.workbench.effects import CATALOG  # noqa: E402
from sma_actuator.workbench.engine import fit_model  # noqa: E402

TARGET_S = 60.0


def antagonistic_duties(n, dt, rng):
    """Segments of 1-4 s: one wire at 0.3-0.7 duty and the other off, or both off."""
    da, db = np.zeros(n), np.zeros(n)
    k = 0
    while k < n:
        length = int(rng.uniform(1.0, 4.0) / dt)
        level, wire = rng.uniform(0.3, 0.7), rng.integers(3)
        (da if wire == 0 else db)[k:k + length] = level if wire < 2 else 0.0
        k += length
    return da, db


def make_record(minutes=10.0, rate_hz=40.0, seed=0):
    """Return a simulated run as DynamicData (time [s], duties, position [rad], ambient [°C])."""
    rng = np.random.default_rng(seed)
    dt = 1.0 / rate_hz
    n = int(round(minutes * 60.0 * rate_hz))
    t = np.arange(n) * dt
    da, db = antagonistic_duties(n, dt, rng)
    ambient = 22.0 + 2.0 * t / t[-1]
    pos = simulate(ActuatorParams(), da, db, dt, ambient_c=ambient).position_rad
    return DynamicData(t, da, db, pos + rng.normal(0.0, 0.003, n), ambient=ambient)


def main(argv=None):
    """Run the benchmark; print the wall time and the diagnosis."""
    ap = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    ap.add_argument('--minutes', type=float, default=10.0)
    ap.add_argument('--rate', type=float, default=40.0, help='sample rate [Hz]')
    ap.add_argument('--seed', type=int, default=0)
    ap.add_argument('--jobs', type=int, nargs='+', default=[1, 0],
                    help='process counts to time side by side (0 = every core, what '
                         'sma-model diagnose uses); the last one is checked')
    ap.add_argument('--check', action='store_true', help='exit 1 if over the target')
    args = ap.parse_args(argv)
    data = make_record(args.minutes, args.rate, args.seed)
    fit_model(make_record(0.5, args.rate, args.seed + 1))          # warm-up (JIT caches)
    print(f'record: {len(data)} samples ({args.minutes:g} min at {args.rate:g} Hz), '
          f'{len(CATALOG)} catalog effects, {available_cores()} cores')
    runs = {}
    for jobs in args.jobs:
        start = time.perf_counter()
        base = fit_model(data)
        t_base = time.perf_counter() - start
        diag = diagnose(data, base=base, jobs=jobs)
        runs[jobs] = (time.perf_counter() - start, t_base, diag)
    print(f'{"jobs":>4}  {"base fit":>8}  {"total":>7}  (target < {TARGET_S:g} s)')
    for jobs, (total, t_base, _) in runs.items():
        print(f'{jobs:>4}  {t_base:7.1f}s  {total:6.1f}s')
    if len(runs) > 1:
        first, last = list(runs.values())[0][0], list(runs.values())[-1][0]
        print(f'speed-up jobs={args.jobs[-1]} over jobs={args.jobs[0]}: {first / last:.2f}x')
    total, _, diag = runs[args.jobs[-1]]
    print(f"candidates (jobs={args.jobs[-1]}; seconds are each refit's own wall time):")
    for c in diag.candidates:
        imp = 'n/a' if c['improvement'] is None else f'{100 * c["improvement"]:+.1f} %'
        print(f'  {c["effect"]:<20} {imp:>9}  {c.get("seconds", 0.0):6.1f} s  '
              f'{"significant" if c["significant"] else ""}')
    print(f'missing effect: {diag.missing_effect}')
    ok = total < TARGET_S
    print('PASS' if ok else 'FAIL')
    return 0 if ok or not args.check else 1


if __name__ == '__main__':
    sys.exit(main())

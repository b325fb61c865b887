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
Benchmark: two diagnoses side by side, with glibc's malloc defaults and with freed arrays kept.

    .venv/bin/python benchmarks/bench_freed_memory.py [--seconds 480] [--side-by-side 2]

Each diagnosis runs in its own process on the rich simulator's hidden-effect delay record
(closed loop, 40 Hz, the CI test's case); `--side-by-side` of them start at once, first
with glibc's defaults, then with `workbench.parallel.keep_freed_memory()`. Prints, per
setting, the mean wall time of one diagnosis and, of its whole process, the user and system
CPU seconds, page faults and peak memory; then the ratio of the wall times
(docs/workbench.md, "Speed").
"""
import argparse
import json
import os
from pathlib import Path
import resource
import subprocess
import sys
import time

ROOT = Path(__file__).resolve().parents[1]
CHILD = """
import json, resource, sys, time
sys.path.insert(0, {test!r})
from sma_actuator.workbench.parallel import keep_freed_memory, one_blas_thread
one_blas_thread()
if sys.argv[1] == 'keep':
    keep_freed_memory()
from sma_actuator.core.identification import DynamicData
from sma_actuator.workbench.diagnosis import diagnose
from sma_actuator.workbench.engine import fit_model
from support.richsim import simulate
d = simulate('delay', magnitude=1.5, excitation='closed', duration_s=float(sys.argv[2]),
             rate_hz=40, noise_rad=0.002, seed=15)
data = DynamicData(d['time'], d['duty_a'], d['duty_b'], d['position'])
fit_model(data)   # numba kernels compiled or loaded
t = time.perf_counter()
named = diagnose(data).missing_effect
u = resource.getrusage(resource.RUSAGE_SELF)
print(json.dumps({{'wall_s': time.perf_counter() - t, 'named': named, 'user_s': u.ru_utime,
                  'sys_s': u.ru_stime, 'faults': u.ru_minflt, 'peak_mb': u.ru_maxrss / 1024}}))
"""


def run(mode: str, seconds: float, count: int) -> dict:
    """Return the mean figures of `count` diagnoses started at once in `mode`."""
    env = {k: v for k, v in os.environ.items() if not k.startswith('MALLOC_')}
    code = CHILD.format(test=str(ROOT / 'test'))
    procs = [subprocess.Popen([sys.executable, '-c', code, mode, str(seconds)], env=env,
                              stdout=subprocess.PIPE, text=True) for _ in range(count)]
    runs = [json.loads(p.communicate()[0].strip().splitlines()[-1]) for p in procs]
    keys = ('wall_s', 'user_s', 'sys_s', 'faults', 'peak_mb')
    mean = {k: sum(r[k] for r in runs) / count for k in keys}
    mean['named'] = ', '.join(sorted({str(r['named']) for r in runs}))
    return mean


def main() -> None:
    """Run both settings and print them side by side."""
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0].strip())
    ap.add_argument('--seconds', type=float, default=480.0, help='record length [s]')
    ap.add_argument('--side-by-side', type=int, default=2, help='diagnoses at once')
    args = ap.parse_args()
    started = time.perf_counter()
    rows = {mode: run(mode, args.seconds, args.side_by_side) for mode in ('defaults', 'keep')}
    print(f'{args.side_by_side} diagnoses side by side, delay record {args.seconds:.0f} s '
          f'at 40 Hz ({resource.getpagesize()} B pages)')
    print(f"{'malloc':10s} {'wall [s]':>9s} {'user [s]':>9s} {'sys [s]':>8s} "
          f"{'page faults':>12s} {'peak [MB]':>10s}  named")
    for mode, r in rows.items():
        print(f"{mode:10s} {r['wall_s']:9.1f} {r['user_s']:9.1f} {r['sys_s']:8.1f} "
              f"{r['faults']:12.0f} {r['peak_mb']:10.0f}  {r['named']}")
    ratio = rows['defaults']['wall_s'] / rows['keep']['wall_s']
    print(f'wall time, defaults / keep: {ratio:.2f} '
          f'(benchmark {time.perf_counter() - started:.0f} s)')


if __name__ == '__main__':
    main()

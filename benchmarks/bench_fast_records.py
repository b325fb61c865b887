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
Benchmark `sma-model diagnose` on a fast record: kept whole and decimated to 100 Hz.

    .venv/bin/python benchmarks/bench_fast_records.py [--rate 1000] [--duration 300]
        [--effect delay] [--magnitude 1.0] [--jobs 2]

A rich-simulator record (test/support/richsim.py: one hidden effect, open loop, 2 mrad
noise) is written as CSV at --rate, and the same record simulated at 100 Hz. Each is
diagnosed by `sma-model diagnose --json`, one run at a time: the fast record kept at its
rate (`--max-rate` = its rate), the fast record decimated (the default `--max-rate`), and
the 100 Hz record. Printed side by side: wall time [s], the largest process's peak
resident memory [MB], the held-out NRMSE of the base and of the named effect [%], and the
name.
"""
import argparse
import json
from pathlib import Path
import subprocess
import sys
import tempfile
import time

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'test'))
from support.richsim import simulate  # noqa: E402, I100

# runs the command and prints the peak resident set [kB] of its largest process
PEAK_RSS = ('import resource, subprocess, sys; '
            'subprocess.run(sys.argv[1:], stdout=sys.stderr, check=True); '
            'print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)')


def write_record(path, args, rate_hz):
    """Write the rich-simulator record at `rate_hz` [Hz] as a dynamic CSV."""
    d = simulate(args.effect, magnitude=args.magnitude, excitation='open',
                 duration_s=args.duration, rate_hz=rate_hz, noise_rad=0.002, seed=5)
    np.savetxt(path, np.column_stack([d['time'], d['duty_a'], d['duty_b'], d['position']]),
               delimiter=',', header='time,duty_a,duty_b,position', comments='', fmt='%.6g')


def diagnose(path, max_rate_hz, jobs):
    """Return (wall [s], peak memory [MB], diagnose JSON) of one `sma-model diagnose`."""
    with tempfile.TemporaryFile('w+') as out:
        cmd = [sys.executable, '-m', 'sma_actuator.workbench.cli', 'diagnose', str(path),
               '--json', '--jobs', str(jobs), '--max-rate', f'{max_rate_hz:g}']
        t0 = time.perf_counter()
        peak_kb = subprocess.run([sys.executable, '-c', PEAK_RSS, *cmd], stdout=subprocess.PIPE,
                                 stderr=out, text=True, check=True).stdout
        wall = time.perf_counter() - t0
        out.seek(0)
        text = out.read()
    return wall, int(peak_kb) / 1024.0, json.loads(text[text.index('{'):])


def main():
    """Print the three diagnoses side by side."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    ap.add_argument('--rate', type=float, default=1000.0)
    ap.add_argument('--duration', type=float, default=300.0)
    ap.add_argument('--effect', default='delay')
    ap.add_argument('--magnitude', type=float, default=1.0)
    ap.add_argument('--jobs', type=int, default=2)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        fast, slow = Path(tmp) / 'fast.csv', Path(tmp) / 'slow.csv'
        write_record(fast, args, args.rate)
        write_record(slow, args, 100.0)
        runs = [(f'{args.rate:g} Hz kept', fast, args.rate),
                (f'{args.rate:g} Hz decimated', fast, 100.0),
                ('simulated at 100 Hz', slow, 100.0)]
        print(f'richsim {args.effect} M {args.magnitude:g}, {args.duration:g} s, open loop, '
              f'--jobs {args.jobs}')
        print(f'{"record":24s} {"wall s":>7s} {"peak MB":>8s} {"base %":>7s} '
              f'{"named %":>8s}  named')
        walls = {}
        for label, path, max_rate in runs:
            wall, peak_mb, doc = diagnose(path, max_rate, args.jobs)
            walls[label] = wall
            named = doc['missing_effect']
            best = next((c['validation_nrmse'] for c in doc['candidates']
                         if c['effect'] == named), None)
            after = f'{100 * best:8.2f}' if best is not None else f'{"-":>8s}'
            print(f'{label:24s} {wall:7.1f} {peak_mb:8.0f} '
                  f'{100 * doc["baseline"]["validation_nrmse"]:7.2f} {after}  {named}',
                  flush=True)
        kept, decimated = walls[runs[0][0]], walls[runs[1][0]]
        print(f'wall time, kept / decimated: {kept / decimated:.1f}')


if __name__ == '__main__':
    main()

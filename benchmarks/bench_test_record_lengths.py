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
The hidden-effect test's cases on records of another length: what diagnose names, and how.

Each case of `test/test_workbench_hidden_effects.py` (STRONG) is simulated again with only
its record length changed, diagnosed, and printed with the three best candidates (held-out
improvement, * significant) and the seconds it took. The test runs each case on the
shortest record it passes by a margin; this shows the margins.

    python benchmarks/bench_test_record_lengths.py [--duration 240] [--effects NAME ...]
        [--jobs N]
"""
import argparse
from pathlib import Path
import sys
import time

from sma_actuator.workbench.parallel import keep_freed_memory, one_blas_thread

one_blas_thread()   # before numpy loads, as `sma-model` and the record workers run
keep_freed_memory()   # fits reuse their freed arrays (see workbench.parallel)
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'test'))

from support.parallel import imap_on_cores  # noqa: E402, I100
from test_workbench_hidden_effects import ARGS, diagnose_case, STRONG  # noqa: E402


def timed_case(case: tuple) -> tuple:
    """Return (seconds, missing effect, ranking) of one test case."""
    t0 = time.perf_counter()
    missing, ranking = diagnose_case(case)
    return time.perf_counter() - t0, missing, ranking


def _percent(improvement) -> str:
    """Return a held-out improvement as a signed percentage, or 'failed' for no fit."""
    return 'failed' if improvement is None else f'{100 * improvement:+.0f} %'


def main() -> None:
    """Diagnose the selected test cases at one record length and print a row each."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    ap.add_argument('--duration', type=float, default=240.0, help='record length [s]')
    ap.add_argument('--effects', nargs='*', help='only these cases (effect names, none)')
    ap.add_argument('--jobs', type=int, default=1)
    args = ap.parse_args()
    at = ARGS.split(',').index('duration')
    cases = [c[:at] + (args.duration,) + c[at + 1:] for c in STRONG
             if not args.effects or c[0] in args.effects]
    print(f'hidden-effect test cases on {args.duration:.0f} s records')
    print(f'{"effect":20s} {"M":>5s} {"loop":6s} {"rate":>6s} {"named":>20s} {"s":>5s}  '
          'best three (held-out improvement, * significant)')
    for case, (seconds, missing, ranking) in imap_on_cores(timed_case, cases, args.jobs):
        best = '  '.join(f'{e} {_percent(i)}{"*" if s else ""}' for e, i, s in ranking[:3])
        print(f'{case[0]:20s} {case[1]:5.2f} {case[2]:6s} {case[4]:4d}Hz '
              f'{str(missing):>20s} {seconds:5.0f}  {best}', flush=True)


if __name__ == '__main__':
    main()

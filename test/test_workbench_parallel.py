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

"""A fitting process keeps its freed arrays (`workbench.parallel.keep_freed_memory`)."""
import ctypes
import subprocess
import sys

import pytest

# three 16 MB temporaries alive at once and freed together, 50 times, as a fit's regressor
# matrices are; prints the page faults that took
ROUNDS = """
import resource, sys
import numpy as np
if sys.argv[1] == 'keep':
    from sma_actuator.workbench.parallel import keep_freed_memory
    keep_freed_memory()
a = np.ones((2000, 1000))
def temporaries():
    b, c, d = a * 2.0, a + 1.0, a - 1.0
    return float(b[0, 0] + c[0, 0] + d[0, 0])
temporaries()
f0 = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
for _ in range(50):
    temporaries()
print(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - f0)
"""


def _faults(mode):
    out = subprocess.run([sys.executable, '-c', ROUNDS, mode], capture_output=True, text=True,
                         check=True, env={'PATH': '/usr/bin:/bin'})
    return int(out.stdout)


@pytest.mark.skipif(getattr(ctypes.CDLL(None), 'mallopt', None) is None,
                    reason='no glibc mallopt')
def test_freed_arrays_are_reused_not_faulted_in_again():
    plain, kept = _faults('plain'), _faults('keep')
    # 3 x 16 MB a round is about 12,000 pages; without it glibc unmaps or trims a good part
    # of them at each free and faults them in again the next round
    assert plain > 50 * 1000, plain
    assert kept < plain / 100, (kept, plain)


def test_processes_started_later_inherit_the_setting():
    code = ('import os, subprocess, sys\n'
            'from sma_actuator.workbench.parallel import keep_freed_memory\n'
            'keep_freed_memory()\n'
            'print(subprocess.run([sys.executable, "-c", "import os; '
            'print(os.environ[\'MALLOC_TRIM_THRESHOLD_\'])"], capture_output=True, '
            'text=True).stdout.strip())')
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                         check=True, env={'PATH': '/usr/bin:/bin'})
    assert int(out.stdout) >= 1 << 30


def _pid_and_blas(item):
    """Return (item, this process's id, its BLAS thread setting); raise for item 'fail'."""
    import os
    if item == 'fail':
        raise ValueError('a job failed')
    return item, os.getpid(), os.environ.get('OPENBLAS_NUM_THREADS')


def test_worker_processes_are_kept_for_the_next_call_and_shut_down_by_an_error(monkeypatch):
    from sma_actuator.workbench import parallel
    monkeypatch.setenv('OPENBLAS_NUM_THREADS', '4')
    parallel.shutdown_pool()
    try:
        first = [r for _, r in parallel.imap_on_cores(_pid_and_blas, range(6), 2)]
        second = [r for _, r in parallel.imap_on_cores(_pid_and_blas, range(4), 2)]
        assert sorted(r[0] for r in first) == list(range(6))
        pids = {r[1] for r in first}
        assert len(pids) == 2 and {r[1] for r in second} <= pids   # the same two processes
        assert {r[2] for r in first + second} == {'1'}              # one BLAS thread each
        assert parallel.os.environ['OPENBLAS_NUM_THREADS'] == '4'   # the caller's, restored
        with pytest.raises(ValueError, match='a job failed'):
            list(parallel.imap_on_cores(_pid_and_blas, ['fail', 1, 2, 3], 2))
        third = {r[1] for _, r in parallel.imap_on_cores(_pid_and_blas, range(4), 2)}
        assert not third & pids                                      # started anew
    finally:
        parallel.shutdown_pool()

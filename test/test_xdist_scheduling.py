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
The test command's `--dist loadfile` finishes the session after a crashed or hung worker.

A worker process that dies (a segfault in middleware teardown, the OOM killer) or hangs past
setup.cfg's faulthandler_timeout (which then ends it) fails the test it was running, once; the
rest of that test's file and every other file still run, and the session ends instead of
waiting forever for the replacement worker.
"""
import os
from pathlib import Path
import subprocess
import sys

from conftest import NOTICE_S
import pytest

CRASHING_FILE = """
import os
import signal


def test_before():
    pass


def test_stop():
    os.kill(os.getpid(), signal.SIGKILL)


def test_after():
    pass
"""
HANGING_FILE = CRASHING_FILE.replace('os.kill(os.getpid(), signal.SIGKILL)', 'signal.pause()')
ONE_TEST_FILE = 'def test_only():\n    pass\n'


@pytest.mark.slow
@pytest.mark.parametrize('workers', [1, 2])
def test_a_crashed_worker_fails_one_test_and_the_session_runs_the_rest(tmp_path, workers):
    out = _run_session(tmp_path, CRASHING_FILE, '-n', str(workers))
    assert "crashed while running 'test_a_stops.py::test_stop'" in out, out


@pytest.mark.slow
def test_a_hung_test_ends_its_worker_after_the_faulthandler_timeout(tmp_path):
    out = _run_session(tmp_path, HANGING_FILE, '-n', '1', '-o', 'faulthandler_timeout=2',
                       '-o', 'faulthandler_exit_on_timeout=true')
    assert 'Timeout (0:00:02)!' in out and 'in test_stop' in out, out
    assert "crashed while running 'test_a_stops.py::test_stop'" in out, out


def _run_session(tmp_path, stopping_file, *args):
    """Run pytest on a file whose second test stops its worker and two one-test files."""
    (tmp_path / 'test_a_stops.py').write_text(stopping_file)
    for name in ('test_b_one.py', 'test_c_one.py'):
        (tmp_path / name).write_text(ONE_TEST_FILE)
    support = str(Path(__file__).resolve().parent)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        p for p in (support, os.environ.get('PYTHONPATH')) if p))
    result = subprocess.run(
        [sys.executable, '-m', 'pytest', '-rA', '-p', 'no:cacheprovider',
         '-p', 'support.xdist_scheduling', '--dist', 'loadfile', *args, '.'],
        capture_output=True, text=True, cwd=tmp_path, env=env, timeout=4 * NOTICE_S)
    out = result.stdout + result.stderr
    assert result.returncode == 1, out
    for test in ('test_a_stops.py::test_before', 'test_a_stops.py::test_after',
                 'test_b_one.py::test_only', 'test_c_one.py::test_only'):
        assert f'PASSED {test}' in out, out
    assert out.count('FAILED test_a_stops.py::test_stop') == 1, out    # reported once, run once
    assert '1 failed, 4 passed' in out, out
    return out

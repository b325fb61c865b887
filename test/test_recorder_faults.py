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
The recorder console script on a full disk, an unwritable directory and `topics:=[]`.

A full disk is simulated with RLIMIT_FSIZE (SIGXFSZ ignored, so a write past the limit
fails with EFBIG like one on a full file system fails with ENOSPC). Each case must end
with exit status 1, one `recorder: ...` line and no traceback (issue 13 item 8).
"""
import os
import resource
import signal
import subprocess
import time

from conftest import spin_until
import pytest

rclpy = pytest.importorskip('rclpy')
# after the importorskip guard, hence out of the alphabetical order
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus  # noqa: E402, I100
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from sma_actuator.bag.reader import BagReader  # noqa: E402
from std_msgs.msg import Float64MultiArray  # noqa: E402
from test_recorder_signals import _recorder_command  # noqa: E402

FILE_LIMIT_BYTES = 256 * 1024


def _limit_file_size():
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (FILE_LIMIT_BYTES, FILE_LIMIT_BYTES))


def _one_line_failure(proc, output):
    assert proc.returncode == 1, output
    assert 'Traceback' not in output, output
    lines = [line for line in output.splitlines() if line.startswith('recorder: ')]
    assert len(lines) == 1, output
    return lines[0]


def test_full_disk_reports_error_closes_and_exits_with_one_line(ros_context, tmp_path):
    bag = tmp_path / 'bag'
    proc = subprocess.Popen(
        _recorder_command() + ['--ros-args', '-p', f'bag_path:={bag}', '-p', 'topics:=[/sma/*]',
                               '-p', 'discovery_period_s:=0.05', '-p', 'chunk_max_age_s:=0.2',
                               '-p', 'chunk_size_bytes:=16384', '-p', 'compression:=none'],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=dict(os.environ),
        preexec_fn=_limit_file_size)
    node = rclpy.create_node('talker', context=ros_context)
    diags = []
    node.create_subscription(
        DiagnosticArray, '/diagnostics',
        lambda m: diags.extend(s for s in m.status if s.name.startswith('recorder')), 10)
    pub = node.create_publisher(Float64MultiArray, '/sma/blob', 10)
    ex = SingleThreadedExecutor(context=ros_context)
    ex.add_node(node)
    try:
        assert spin_until(ex, lambda: pub.get_subscription_count() > 0, 30), \
            'recorder never subscribed'
        end = time.monotonic() + 60.0
        sent = 0
        while proc.poll() is None and time.monotonic() < end:
            pub.publish(Float64MultiArray(data=[float(sent)] * 1000))   # 8 kB each
            sent += 1
            ex.spin_once(timeout_sec=0.005)
        spin_until(ex, lambda: any(s.level == DiagnosticStatus.ERROR for s in diags), 2.0)
        output = proc.communicate(timeout=30)[0]
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(10)
        ex.shutdown()
        node.destroy_node()
    line = _one_line_failure(proc, output)
    assert 'cannot write' in line and 'File too large' in line, line
    errors = [s for s in diags if s.level == DiagnosticStatus.ERROR]
    assert errors and 'recording stopped' in errors[0].message
    # what reached the disk before the failure is still a readable recording
    recovered = list(BagReader(bag).messages())
    assert 0 < len(recovered) < sent


def test_unwritable_directory_is_one_line_and_exit_status_1(tmp_path):
    blocker = tmp_path / 'a_file'
    blocker.write_text('not a directory')
    proc = subprocess.run(
        _recorder_command() + ['--ros-args', '-p', f'bag_path:={blocker / "bag"}'],
        capture_output=True, text=True, timeout=60)
    line = _one_line_failure(proc, proc.stdout + proc.stderr)
    assert 'cannot create the bag' in line and 'Not a directory' in line, line


def test_empty_topic_list_is_one_line_and_exit_status_1(tmp_path):
    proc = subprocess.run(
        _recorder_command() + ['--ros-args', '-p', f'bag_path:={tmp_path / "bag"}',
                               '-p', 'topics:=[]'],
        capture_output=True, text=True, timeout=60)
    line = _one_line_failure(proc, proc.stdout + proc.stderr)
    assert 'topics must be a list' in line and "['*', '/diagnostics']" in line, line
    assert not (tmp_path / 'bag').exists()

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
The recorder console script under signals.

SIGINT/SIGTERM finish the bag, SIGKILL leaves a file that BagReader recovers up to the last chunk
and whose loss it reports.
"""
import os
from pathlib import Path
import shutil
import signal
import subprocess
import sys
import time

from conftest import NOTICE_S
import pytest

rclpy = pytest.importorskip('rclpy')
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.node import Node  # noqa: E402
from rclpy.serialization import deserialize_message  # noqa: E402
from rosbags.highlevel import AnyReader, AnyReaderError  # noqa: E402
from sma_actuator.bag.errors import BagError  # noqa: E402
from sma_actuator.bag.reader import BagReader  # noqa: E402
from std_msgs.msg import Float64  # noqa: E402
from support.stopping import stopped_cleanly  # noqa: E402


def _recorder_command():
    script = Path(sys.prefix) / 'lib' / 'sma_actuator' / 'recorder'
    found = shutil.which('recorder')
    if script.exists():
        return [str(script)]
    if found:
        return [found]
    return [sys.executable, '-m', 'sma_actuator.nodes.recorder']


@pytest.fixture
def recording(ros_context, tmp_path):
    """Start the recorder on /sma/* in a subprocess; yield (process, bag path, node, executor)."""
    bag = tmp_path / 'bag'
    proc = subprocess.Popen(
        _recorder_command() + ['--ros-args', '-p', f'bag_path:={bag}', '-p', 'topics:=[/sma/*]',
                               '-p', 'discovery_period_s:=0.05', '-p', 'chunk_max_age_s:=0.2',
                               '-p', 'chunk_size_bytes:=4096'],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, env=dict(os.environ))
    node = Node('talker', context=ros_context)
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(node)
    try:
        yield proc, bag, node, executor
    finally:
        if proc.poll() is None:
            proc.kill()
        proc.wait(timeout=10)
        executor.shutdown()
        node.destroy_node()


def _publish(node, executor, count, period_s=0.005):
    """Publish 0..count-1 on /sma/setpoint (reliable) once the recorder is subscribed."""
    pub = node.create_publisher(Float64, '/sma/setpoint', 10)
    end = time.monotonic() + NOTICE_S
    while pub.get_subscription_count() == 0 and time.monotonic() < end:
        executor.spin_once(timeout_sec=0.05)
    assert pub.get_subscription_count() == 1, 'recorder never subscribed'
    time.sleep(0.3)  # let the reliable connection settle
    for i in range(count):
        pub.publish(Float64(data=float(i)))
        executor.spin_once(timeout_sec=period_s)
    return pub


def _on_disk(bag, count):
    """Wait until `count` messages of the unfinished bag have reached the file; return whether."""
    end = time.monotonic() + NOTICE_S
    while time.monotonic() < end:
        try:
            if sum(1 for _ in BagReader(bag).messages()) >= count:
                return True
        except BagError:
            pass              # nothing (readable) written yet
        time.sleep(0.1)
    return False


@pytest.mark.slow
@pytest.mark.parametrize('sig', [signal.SIGINT, signal.SIGTERM])
def test_sigint_and_sigterm_finish_the_bag(recording, sig):
    proc, bag, node, executor = recording
    _publish(node, executor, 200)
    assert _on_disk(bag, 200), 'the recorder did not write the messages'
    proc.send_signal(sig)
    output = proc.communicate(timeout=NOTICE_S)[0].decode()
    assert stopped_cleanly(proc.returncode, output), output
    assert (bag / 'metadata.yaml').is_file(), output
    with AnyReader([bag]) as reader:
        values = [reader.deserialize(raw, c.msgtype).data for c, _, raw in reader.messages()]
    assert values == [float(i) for i in range(200)]
    assert BagReader(bag).recoveries == []


@pytest.mark.slow
def test_sigkill_leaves_a_recoverable_file(recording):
    proc, bag, node, executor = recording
    pub = _publish(node, executor, 300)
    # chunks older than chunk_max_age_s reach the file: wait for all of the above to be there
    assert _on_disk(bag, 300), 'the recorder did not write the messages'
    for i in range(300, 320):  # these may still be in the recorder's memory at the kill
        pub.publish(Float64(data=float(i)))
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=NOTICE_S)
    assert not (bag / 'metadata.yaml').exists()
    with pytest.raises(AnyReaderError, match='magic'):
        with AnyReader([bag / 'bag_0.mcap']) as reader:
            list(reader.messages())  # an ordinary reader cannot use it
    reader = BagReader(bag)
    (report,) = reader.recoveries
    values = [m.data for m in reader.messages()]
    assert len(values) >= 300
    assert [deserialize_message(v, Float64).data for v in values] == [
        float(i) for i in range(len(values))]
    assert report.recovered_messages == len(values)
    assert 'no summary' in str(report) and str(bag / 'bag_0.mcap') in str(report)

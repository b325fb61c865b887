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

"""ReplayNode: stored bytes on (remapped) topics, filter, /clock, QoS, zero duty on stop."""
import os
from pathlib import Path
import shutil
import signal
import subprocess
import sys

from conftest import NOTICE_S, spin_until
import pytest

rclpy = pytest.importorskip('rclpy')
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.node import Node  # noqa: E402
from rclpy.qos import qos_profile_sensor_data, QoSProfile  # noqa: E402
from rclpy.serialization import deserialize_message  # noqa: E402
from rosgraph_msgs.msg import Clock  # noqa: E402
from sensor_msgs.msg import JointState  # noqa: E402
from sma_actuator.bag.errors import BagError, BagNotFoundError  # noqa: E402
from sma_actuator.bag.synthetic import offered_profile, stamp, to_cdr  # noqa: E402
from sma_actuator.bag.writer import BagWriter  # noqa: E402
from sma_actuator.nodes.replay import ReplayNode  # noqa: E402
from std_msgs.msg import Float64, Float64MultiArray  # noqa: E402
from support.stopping import stopped_cleanly  # noqa: E402

T0 = 1_650_000_000_000_000_000
MS = 1_000_000
ZERO_DUTY = [0.0, 0.0]


def _write_bag(path, count=30, period_ms=10):
    """Duty (reliable), joint states (best effort) and setpoint; returns stored bytes by topic."""
    stored = {'/sma/duty': [], '/sma/joint_states': [], '/sma/setpoint': []}
    with BagWriter(path) as bag:
        bag.add_topic('/sma/duty', 'std_msgs/msg/Float64MultiArray', [offered_profile('reliable')])
        bag.add_topic('/sma/joint_states', 'sensor_msgs/msg/JointState',
                      [offered_profile('best_effort')])
        bag.add_topic('/sma/setpoint', 'std_msgs/msg/Float64', [offered_profile('reliable')])
        for i in range(count):
            t = T0 + i * period_ms * MS
            items = [('/sma/duty', {'data': [0.5 + i * 1e-3, 0.0]}),
                     ('/sma/joint_states', {'header': {'stamp': stamp(t)}, 'name': ['shaft'],
                                            'position': [0.01 * i], 'velocity': [0.0]}),
                     ('/sma/setpoint', {'data': 0.1})]
            payloads = to_cdr([(bag.topics[topic].type, msg) for topic, msg in items])
            for k, ((topic, _), data) in enumerate(zip(items, payloads)):
                bag.write(topic, data, t + k * 1000)
                stored[topic].append(data)
    return stored


def _spin_until(executor, condition, timeout_s=NOTICE_S):
    return spin_until(executor, condition, timeout_s, step_s=0.02)


@pytest.fixture
def probe(ros_context):
    """Return a node recording what arrives (raw) on the topics a replay may publish."""
    node = Node('probe', context=ros_context)
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(node)
    got = {}
    reliable = QoSProfile(depth=100)
    # best effort as the sensor streams are offered, but deep enough that a starved
    # executor does not overwrite samples before it takes them
    sensor = QoSProfile(depth=100, reliability=qos_profile_sensor_data.reliability)
    for topic, ty, qos in [('/sma/duty', Float64MultiArray, reliable),
                           ('/measured/joint_states', JointState, sensor),
                           ('/sma/joint_states', JointState, sensor),
                           ('/sma/setpoint', Float64, reliable),
                           ('/clock', Clock, sensor)]:
        got[topic] = []
        node.create_subscription(ty, topic, lambda d, t=topic: got[t].append(d), qos, raw=True)
    extra = []
    yield node, executor, got, extra
    for other in extra:
        other.destroy_node()
    executor.shutdown()
    node.destroy_node()


def test_replays_stored_bytes_remapped_filtered_with_clock(probe, tmp_path):
    node, executor, got, extra = probe
    stored = _write_bag(tmp_path / 'bag')
    replay = ReplayNode(context=executor.context, bag_path=str(tmp_path / 'bag'), rate=2.0,
                        topics=['/sma/duty', '/sma/joint_states'], clock=True,
                        clock_frequency_hz=50.0, wait_for_subscribers_s=NOTICE_S,
                        remap=['/sma/joint_states:=/measured/joint_states'])
    extra.append(replay)
    executor.add_node(replay)
    assert replay.played_topics == {'/sma/duty': '/sma/duty',
                                    '/sma/joint_states': '/measured/joint_states'}
    offers = {t: replay.get_publishers_info_by_topic(t)[0].qos_profile.reliability.name
              for t in ('/sma/duty', '/measured/joint_states')}
    assert offers == {'/sma/duty': 'RELIABLE', '/measured/joint_states': 'BEST_EFFORT'}
    replay.start()
    assert _spin_until(executor, replay.finished.is_set)
    _spin_until(executor, lambda: len(got['/sma/duty']) > len(stored['/sma/duty']) and len(
        got['/measured/joint_states']) >= len(stored['/sma/joint_states']))

    assert replay.stats.published == 60
    assert got['/sma/duty'][:-1] == stored['/sma/duty']
    assert deserialize_message(got['/sma/duty'][-1], Float64MultiArray).data.tolist() == ZERO_DUTY
    assert got['/measured/joint_states'] == stored['/sma/joint_states']
    assert got['/sma/joint_states'] == [] and got['/sma/setpoint'] == []
    clock = [deserialize_message(c, Clock).clock for c in got['/clock']]
    times = [c.sec * 1_000_000_000 + c.nanosec for c in clock]
    assert len(times) >= 3 and times == sorted(times)
    assert T0 <= times[0] and times[-1] <= T0 + 290 * MS


def test_a_hardware_runs_applied_duty_drives_the_duty_topic_and_ends_at_zero(probe, tmp_path):
    # the bridge held wire b's commands: the applied duty, not the commands, is played
    node, executor, got, extra = probe
    duty_type, applied = 'std_msgs/msg/Float64MultiArray', []
    with BagWriter(tmp_path / 'bag') as bag:
        for topic in ('/sma/duty', '/sma/applied_duty'):
            bag.add_topic(topic, duty_type, [offered_profile('reliable')])
        for i in range(20):
            t = T0 + i * 10 * MS
            command, sent = to_cdr([(duty_type, {'data': [0.0, 0.4]}),
                                    (duty_type, {'data': [0.0, 0.4 if i > 4 else 0.0]})])
            bag.write('/sma/duty', command, t)
            bag.write('/sma/applied_duty', sent, t + 1000)
            applied.append(sent)
    replay = ReplayNode(context=executor.context, bag_path=str(tmp_path / 'bag'),
                        topics=['/sma/applied_duty'], remap=['/sma/applied_duty:=/sma/duty'],
                        duty_topic='/sma/applied_duty', wait_for_subscribers_s=NOTICE_S)
    extra.append(replay)
    executor.add_node(replay)
    assert replay.played_topics == {'/sma/applied_duty': '/sma/duty'}
    replay.start()
    assert _spin_until(executor, replay.finished.is_set)
    _spin_until(executor, lambda: len(got['/sma/duty']) > len(applied))
    assert got['/sma/duty'][:-1] == applied
    assert _last_duty(got) == ZERO_DUTY


def test_stop_mid_playback_zeroes_the_duty(probe, tmp_path):
    node, executor, got, extra = probe
    stored = _write_bag(tmp_path / 'bag', count=200, period_ms=20)
    replay = ReplayNode(context=executor.context, bag_path=str(tmp_path / 'bag'),
                        wait_for_subscribers_s=NOTICE_S, loop=True)
    extra.append(replay)
    executor.add_node(replay)
    replay.start()
    assert _spin_until(executor, lambda: len(got['/sma/duty']) >= 5)
    replay.stop()
    _spin_until(executor, lambda: _last_duty(got) == ZERO_DUTY)
    duty = [deserialize_message(d, Float64MultiArray).data.tolist() for d in got['/sma/duty']]
    assert duty[-1] == ZERO_DUTY
    assert got['/sma/duty'][:-1] == stored['/sma/duty'][:len(duty) - 1]
    assert replay.stats.stopped


def test_bad_requests_are_named(ros_context, tmp_path):
    _write_bag(tmp_path / 'bag', count=2)
    with pytest.raises(BagNotFoundError, match='no such file'):
        ReplayNode(context=ros_context, bag_path=str(tmp_path / 'missing'))
    with pytest.raises(ValueError, match='bag_path is required'):
        ReplayNode(context=ros_context)
    with pytest.raises(BagError, match=r"\['/sma/other'\] are not in the bag"):
        ReplayNode(context=ros_context, bag_path=str(tmp_path / 'bag'), topics=['/sma/other'])
    with pytest.raises(ValueError, match="bad remapping 'joint_states'"):
        ReplayNode(context=ros_context, bag_path=str(tmp_path / 'bag'), remap=['joint_states'])
    empty = tmp_path / 'empty'
    with BagWriter(empty) as bag:
        bag.add_topic('/sma/duty', 'std_msgs/msg/Float64MultiArray')
    with pytest.raises(BagError, match='nothing to play'):
        ReplayNode(context=ros_context, bag_path=str(empty))
    with pytest.raises(ValueError, match='parameter rate: .* outside the allowed range'):
        ReplayNode(context=ros_context, bag_path=str(tmp_path / 'bag'), rate=0.0)


def _replay_command():
    script = Path(sys.prefix) / 'lib' / 'sma_actuator' / 'replay'
    if script.exists():
        return [str(script)]
    found = shutil.which('replay')
    return [found] if found else [sys.executable, '-m', 'sma_actuator.nodes.replay']


@pytest.mark.slow
def test_console_script_interrupted_zeroes_duty_before_exit(probe, tmp_path):
    node, executor, got, _ = probe
    _write_bag(tmp_path / 'bag', count=300, period_ms=20)
    config = Path(__file__).resolve().parents[1] / 'config' / 'replay.yaml'
    proc = subprocess.Popen(
        _replay_command() + ['--ros-args', '--params-file', str(config),
                             '-p', f'bag_path:={tmp_path / "bag"}', '-p', 'loop:=true',
                             '-p', "remap:=['/sma/joint_states:=/measured/joint_states']"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, env=dict(os.environ))
    try:
        assert _spin_until(executor, lambda: len(got['/sma/duty']) >= 10)
        assert len(got['/measured/joint_states']) > 0 and got['/sma/joint_states'] == []
        proc.send_signal(signal.SIGINT)
        output = proc.communicate(timeout=NOTICE_S)[0].decode()
        _spin_until(executor, lambda: _last_duty(got) == ZERO_DUTY)   # its last word
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(timeout=NOTICE_S)
    assert stopped_cleanly(proc.returncode, output), output
    assert _last_duty(got) == ZERO_DUTY, output


def _last_duty(got):
    return deserialize_message(got['/sma/duty'][-1], Float64MultiArray).data.tolist()

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

"""RecorderNode in-process: records what was published, byte for byte, read back by rosbags."""

from conftest import NOTICE_S, spin_until
from mcap.reader import make_reader
import numpy as np
import pytest

rclpy = pytest.importorskip('rclpy')
# after the importorskip guard, hence out of the alphabetical order
from builtin_interfaces.msg import Time  # noqa: E402, I100
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.node import Node  # noqa: E402
from rclpy.qos import qos_profile_sensor_data, QoSProfile  # noqa: E402
from rclpy.serialization import deserialize_message  # noqa: E402
from rosbags.highlevel import AnyReader  # noqa: E402
from rosgraph_msgs.msg import Clock  # noqa: E402
from sensor_msgs.msg import JointState, Temperature  # noqa: E402
from sma_actuator.bag.arrays import load_run  # noqa: E402
from sma_actuator.bag.errors import BagExistsError  # noqa: E402
from sma_actuator.bag.qos import load_offered_qos_profiles  # noqa: E402
from sma_actuator.nodes.recorder import RecorderNode  # noqa: E402
from std_msgs.msg import Float64, Float64MultiArray  # noqa: E402

N = 40
RELIABLE = QoSProfile(depth=10)
CONTRACT = {  # topic: (type, qos, message for index i)
    '/sma/setpoint': (Float64, RELIABLE, lambda i: Float64(data=0.01 * i)),
    '/sma/duty': (Float64MultiArray, RELIABLE,
                  lambda i: Float64MultiArray(data=[i / N, 1 - i / N])),
    '/sma/joint_states': (JointState, qos_profile_sensor_data,
                          lambda i: JointState(name=['shaft'], position=[0.1 * i],
                                               velocity=[-0.1 * i])),
    '/sma/wire_a/temperature': (Temperature, qos_profile_sensor_data,
                                lambda i: Temperature(temperature=30.0 + i, variance=0.1)),
    '/sma/ambient_temperature': (Temperature, qos_profile_sensor_data,
                                 lambda i: Temperature(temperature=21.0 + 0.01 * i)),
}


def _spin_until(executor, condition, timeout_s=NOTICE_S):
    return spin_until(executor, condition, timeout_s, step_s=0.02)


@pytest.fixture
def graph(ros_context):
    """Talker, probe (independent raw subscriber) and an executor; cleaned up after."""
    talker = Node('talker', context=ros_context)
    probe = Node('probe', context=ros_context)
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(talker)
    executor.add_node(probe)
    nodes = [talker, probe]
    yield talker, probe, executor, nodes
    executor.shutdown()
    for node in nodes:
        node.destroy_node()


@pytest.mark.slow
def test_records_every_contract_topic_byte_for_byte(graph, tmp_path):
    talker, probe, executor, nodes = graph
    pubs = {t: talker.create_publisher(ty, t, qos) for t, (ty, qos, _) in CONTRACT.items()}
    other = talker.create_publisher(Float64, '/other/topic', 10)
    diag = talker.create_publisher(DiagnosticArray, '/diagnostics', 10)
    seen = {t: [] for t in CONTRACT}
    for topic, (ty, qos, _) in CONTRACT.items():
        probe.create_subscription(ty, topic, lambda d, i, t=topic: seen[t].append((d, i)), qos,
                                  raw=True)
    recorder = RecorderNode(context=executor.context, bag_path=str(tmp_path / 'bag'),
                            discovery_period_s=0.1, chunk_size_bytes=2048)
    nodes.append(recorder)
    executor.add_node(recorder)
    expected_topics = sorted(list(CONTRACT) + ['/diagnostics'])
    assert _spin_until(executor, lambda: recorder.recorded_topics == expected_topics), \
        recorder.recorded_topics
    _spin_until(executor, lambda: all(p.get_subscription_count() >= 2 for p in pubs.values()))
    _spin_until(executor, lambda: False, 0.3)  # let the new subscriptions match
    for i in range(N):
        for topic, pub in pubs.items():
            pub.publish(CONTRACT[topic][2](i))
        other.publish(Float64(data=float(i)))
        diag.publish(DiagnosticArray(status=[DiagnosticStatus(
            name='talker', values=[KeyValue(key='i', value=str(i))])]))
        _spin_until(executor, lambda: False, 0.004)
    _spin_until(executor, lambda: all(len(v) == N for v in seen.values()))
    _spin_until(executor, lambda: False, 0.3)
    offered = {t: talker.get_publishers_info_by_topic(t)[0] for t in CONTRACT}
    recorder.close()

    path = tmp_path / 'bag'
    with AnyReader([path]) as reader:
        assert sorted(c.topic for c in reader.connections) == expected_topics
        stored = {}
        for conn, _, raw in reader.messages():
            stored.setdefault(conn.topic, []).append(bytes(raw))
        talker_diag = [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages()
                       if c.topic == '/diagnostics']
    for topic, (ty, _, make) in CONTRACT.items():
        assert stored[topic] == [d for d, _ in seen[topic]], f'{topic}: bytes differ from wire'
        if CONTRACT[topic][1] is RELIABLE:
            assert len(stored[topic]) == N
        values = [deserialize_message(raw, ty) for raw in stored[topic]]
        assert values == [make(i) for i in range(N)][:len(values)]
    talker_values = [s.values[0].value for m in talker_diag for s in m.status
                     if s.name == 'talker']
    assert talker_values == [str(i) for i in range(N)]

    with open(path / 'bag_0.mcap', 'rb') as f:
        mcap = make_reader(f)
        summary = mcap.get_summary()
        channels = {c.topic: c for c in summary.channels.values()}
        publish_times = {}
        for _, channel, msg in mcap.iter_messages():
            publish_times.setdefault(channel.topic, []).append((msg.publish_time, msg.log_time))
    # the workbench's view of the same recording
    arrays = load_run(path)
    assert list(arrays) == ['time', 'duty_a', 'duty_b', 'position', 'ambient_temperature',
                            'setpoint']
    published_js = [deserialize_message(raw, JointState).position[0]
                    for raw in stored['/sma/joint_states']]
    assert arrays['position'][0] == published_js[0]
    assert min(published_js) <= arrays['position'].min() <= arrays['position'].max() <= max(
        published_js)
    assert set(arrays['duty_a']) <= {i / N for i in range(N)} | {0.0}
    setpoint = arrays['setpoint']
    known = ~np.isnan(setpoint)
    assert known[1:].all(), 'NaN only before the first setpoint (at most the first sample)'
    assert set(setpoint[known]) <= {0.01 * i for i in range(N)}
    for topic in CONTRACT:
        meta = channels[topic].metadata
        assert meta['topic_type_hash'] == str(offered[topic].topic_type_hash)
        (qos,) = load_offered_qos_profiles(meta['offered_qos_profiles'])
        assert qos['reliability'] == offered[topic].qos_profile.reliability.name.lower()
        sources = [info['source_timestamp'] for _, info in seen[topic]]
        assert [p for p, _ in publish_times[topic]] == sources
        # log time = reception on the same clock: after the publish, within a hang bound
        assert all(0 <= log - pub < NOTICE_S * 1e9 for pub, log in publish_times[topic])


def test_late_topics_are_picked_up(graph, tmp_path):
    talker, _, executor, nodes = graph
    recorder = RecorderNode(context=executor.context, bag_path=str(tmp_path / 'late'),
                            topics=['/sma/*'], discovery_period_s=0.05)
    nodes.append(recorder)
    executor.add_node(recorder)
    _spin_until(executor, lambda: False, 0.2)
    assert recorder.recorded_topics == []
    pub = talker.create_publisher(Float64, '/sma/setpoint', 10)
    assert _spin_until(executor, lambda: recorder.recorded_topics == ['/sma/setpoint'])
    _spin_until(executor, lambda: pub.get_subscription_count() == 1)
    _spin_until(executor, lambda: False, 0.3)
    for i in range(5):
        pub.publish(Float64(data=float(i)))
    assert _spin_until(executor, lambda: recorder.bag.message_count == 5)
    recorder.destroy_node()
    nodes.remove(recorder)
    with AnyReader([tmp_path / 'late']) as reader:
        assert [reader.deserialize(raw, c.msgtype).data for c, _, raw in reader.messages()] == [
            0.0, 1.0, 2.0, 3.0, 4.0]


def test_on_sim_time_topics_are_found_before_the_clock_starts(graph, tmp_path):
    # the walkthrough's plant holds sim time at 0 until the recorder reads its joint states
    talker, _, executor, nodes = graph
    recorder = RecorderNode(context=executor.context, bag_path=str(tmp_path / 'paused'),
                            topics=['/sma/*'], discovery_period_s=0.05, use_sim_time=True)
    nodes.append(recorder)
    executor.add_node(recorder)
    talker.create_publisher(JointState, '/sma/joint_states', qos_profile_sensor_data)
    assert _spin_until(executor, lambda: recorder.recorded_topics == ['/sma/joint_states'])


def test_refuses_to_overwrite_and_rejects_unknown_parameters(ros_context, tmp_path):
    existing = tmp_path / 'bag'
    existing.mkdir()
    (existing / 'bag_0.mcap').write_bytes(b'precious')
    with pytest.raises(BagExistsError, match='already holds a bag'):
        RecorderNode(context=ros_context, bag_path=str(existing))
    assert (existing / 'bag_0.mcap').read_bytes() == b'precious'
    with pytest.raises(ValueError, match="unknown parameters \\['topic'\\]"):
        RecorderNode(context=ros_context, topic=['/x'])


@pytest.mark.slow
def test_sim_time_recording_logs_the_clock_time(graph, tmp_path):
    """
    Like rosbag2 under use_sim_time.

    Log time = /clock time at reception (the demo runs the plant on accelerated sim time, so wall
    time would compress the run).
    """
    talker, _, executor, nodes = graph
    clock_pub = talker.create_publisher(Clock, '/clock', 10)
    pub = talker.create_publisher(Float64, '/sma/setpoint', 10)
    recorder = RecorderNode(context=executor.context, bag_path=str(tmp_path / 'sim'),
                            topics=['/sma/setpoint'], discovery_period_s=0.05,
                            use_sim_time=True)
    nodes.append(recorder)
    executor.add_node(recorder)
    assert _spin_until(executor, lambda: recorder.recorded_topics == ['/sma/setpoint'])
    _spin_until(executor, lambda: clock_pub.get_subscription_count() >= 1)
    _spin_until(executor, lambda: False, 0.3)
    sim_s = [1000 + 0.5 * i for i in range(5)]
    for i, t in enumerate(sim_s):
        clock_pub.publish(Clock(clock=Time(sec=int(t), nanosec=int((t % 1) * 1e9))))
        _spin_until(executor, lambda: False, 0.1)
        pub.publish(Float64(data=float(i)))
        _spin_until(executor, lambda: False, 0.1)
    _spin_until(executor, lambda: recorder.bag.message_count == 5)
    recorder.close()
    with AnyReader([tmp_path / 'sim']) as reader:
        log_times = [t for _, t, _ in reader.messages()]
    assert log_times == [int(t * 1e9) for t in sim_s]

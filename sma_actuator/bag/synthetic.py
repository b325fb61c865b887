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
ROS-free CDR encoding and made-up runs, for tests, examples and benchmarks.

:func:`to_cdr` serialises plain dicts to CDR with mcap-ros2-support's public MCAP writer (into
memory, read back with mcap's reader), from the installed message definitions; the bytes equal
what rclpy puts on the wire for the same values.
"""
import io
import math
from pathlib import Path
from typing import Any, Callable, Dict, List, Sequence, Tuple, Union

from mcap.reader import make_reader
from mcap.writer import CompressionType
from mcap_ros2.writer import Writer as Ros2McapWriter

from .msgdefs import message_definition, normalize_type_name
from .writer import BagWriter

#: The package's topic contract: topic -> (type, reliability of its publishers).
SMA_TOPICS = {
    '/sma/setpoint': ('std_msgs/msg/Float64', 'reliable'),
    '/sma/duty': ('std_msgs/msg/Float64MultiArray', 'reliable'),
    '/sma/joint_states': ('sensor_msgs/msg/JointState', 'best_effort'),
    '/sma/wire_a/temperature': ('sensor_msgs/msg/Temperature', 'best_effort'),
    '/sma/wire_b/temperature': ('sensor_msgs/msg/Temperature', 'best_effort'),
    '/sma/ambient_temperature': ('sensor_msgs/msg/Temperature', 'best_effort'),
    '/diagnostics': ('diagnostic_msgs/msg/DiagnosticArray', 'reliable'),
}


def to_cdr(messages: Sequence[Tuple[str, Dict[str, Any]]]) -> List[bytes]:
    """
    Return the CDR bytes of each (type name, message dict) pair, in order.

    Missing fields take their default (0, '', empty). The messages go through one in-memory
    MCAP (about 30 us a message), so encode many at once.
    """
    stream = io.BytesIO()
    writer = Ros2McapWriter(stream, compression=CompressionType.NONE, enable_crcs=False)
    schemas = {}
    for index, (type_name, message) in enumerate(messages):
        full = normalize_type_name(type_name)
        if full not in schemas:
            schemas[full] = writer.register_msgdef(full, message_definition(full))
        writer.write_message(full, schemas[full], message, log_time=index)
    writer.finish()
    stream.seek(0)
    return [message.data for _, _, message in make_reader(stream).iter_messages()]


def cdr_encoder(type_name: str) -> Callable[[Dict[str, Any]], bytes]:
    """
    Return a function serialising one dict (field name -> value) of ``type_name`` to CDR.

    About 0.7 ms a call: for more than a few messages use :func:`to_cdr`.
    """
    message_definition(normalize_type_name(type_name))   # an unknown type fails here
    return lambda message: to_cdr([(type_name, message)])[0]


def offered_profile(reliability: str, depth: int = 10) -> Dict[str, Any]:
    """
    Return a rosbag2 QoS dict as a publisher with this reliability offers it.

    Deadline, lifespan and lease are infinite, as Fast DDS reports them for default profiles.
    """
    infinite = {'sec': 9223372036, 'nsec': 854775807}
    return {'history': 'keep_last', 'depth': depth, 'reliability': reliability,
            'durability': 'volatile', 'deadline': infinite, 'lifespan': infinite,
            'liveliness': 'automatic', 'liveliness_lease_duration': infinite,
            'avoid_ros_namespace_conventions': False}


def stamp(time_ns: int) -> Dict[str, int]:
    """Return a builtin_interfaces/Time dict for a time [ns]."""
    return {'sec': time_ns // 1_000_000_000, 'nanosec': time_ns % 1_000_000_000}


def _demo_messages(duration_s: float, joint_state_rate_hz: float, duty_rate_hz: float,
                   start_ns: int) -> List[Tuple[str, Dict[str, Any], int]]:
    """Return the demo run's (topic, message dict, time [ns]) in writing order."""
    written = []
    events = []
    for k in range(int(duration_s * joint_state_rate_hz) + 1):
        events.append((int(k * 1e9 / joint_state_rate_hz), 'js'))
    for k in range(int(duration_s * duty_rate_hz) + 1):
        events.append((int(k * 1e9 / duty_rate_hz) + 137_000, 'duty'))
    events.sort()
    position, duty_a, last_ns = 0.0, 0.0, 0
    step_ns = int(0.1 * duration_s * 1e9)
    written.append(('/sma/setpoint', {'data': 0.0}, start_ns))
    written.append(('/sma/ambient_temperature', {'temperature': 22.0}, start_ns))
    setpoint_sent = False
    for t_ns, kind in events:
        position += (2.0 * duty_a - position) * (1 - math.exp(-(t_ns - last_ns) * 1e-9 / 0.2))
        last_ns = t_ns
        if t_ns >= step_ns and not setpoint_sent:
            written.append(('/sma/setpoint', {'data': 0.2}, start_ns + t_ns))
            setpoint_sent = True
        target = 0.2 if setpoint_sent else 0.0
        if kind == 'duty':
            duty_a = min(1.0, max(0.0, 4.0 * (target - position) + 0.5 * target))
            written.append(('/sma/duty', {'data': [duty_a, 0.0]}, start_ns + t_ns))
        else:
            msg = {'header': {'stamp': stamp(start_ns + t_ns)}, 'name': ['shaft'],
                   'position': [position], 'velocity': [0.0]}
            written.append(('/sma/joint_states', msg, start_ns + t_ns))
    return written


def write_demo_run(path: Union[str, Path], *, duration_s: float = 2.0,
                   joint_state_rate_hz: float = 100.0, duty_rate_hz: float = 50.0,
                   start_ns: int = 1_700_000_000_000_000_000, overwrite: bool = False,
                   **writer_options) -> Path:
    """
    Write a bag of a made-up step response on the contract topics.

    Setpoint steps to 0.2 rad at 10 % of the run; duty_a follows a proportional law, duty_b is 0;
    the shaft angle is a first-order lag (tau 0.2 s) of 2 rad x duty_a; ambient is 22 degC.

    :param writer_options: Passed to :class:`BagWriter` (compression, chunk size, splits).
    :return: The bag directory.
    """
    written = _demo_messages(duration_s, joint_state_rate_hz, duty_rate_hz, start_ns)
    payloads = to_cdr([(SMA_TOPICS[topic][0], msg) for topic, msg, _ in written])
    with BagWriter(path, overwrite=overwrite, **writer_options) as bag:
        for topic, (type_name, reliability) in SMA_TOPICS.items():
            if topic != '/diagnostics':
                bag.add_topic(topic, type_name, [offered_profile(reliability)])
        for (topic, _, t_ns), data in zip(written, payloads):
            bag.write(topic, data, t_ns)
    return Path(path)

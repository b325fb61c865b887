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

"""The one diagnostics builder of every node (nodes.ros_diagnostics) on a real /diagnostics."""
from conftest import spin_until
import pytest

rclpy = pytest.importorskip('rclpy')
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus  # noqa: E402, I100
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from sma_actuator.nodes import common as c  # noqa: E402
from sma_actuator.nodes.ros_diagnostics import (Diagnostics, ERROR, LEVELS, OK,  # noqa: E402
                                                WARN)


def _listen(context, publisher_node):
    listener = rclpy.create_node('diag_listener', context=context)
    arrays = []
    listener.create_subscription(DiagnosticArray, c.DIAGNOSTICS, arrays.append,
                                 c.DIAGNOSTICS_QOS)
    ex = SingleThreadedExecutor(context=context)
    for n in (publisher_node, listener):
        ex.add_node(n)
    return listener, arrays, ex


def test_a_status_carries_node_part_full_name_and_values_as_text(ros_context):
    node = rclpy.create_node('plant_sim', namespace='/left', context=ros_context)
    diag = Diagnostics(node, 'plant')
    listener, arrays, ex = _listen(ros_context, node)
    try:
        assert spin_until(ex, lambda: diag.pub.get_subscription_count() > 0)
        # a mapping and (key, value) pairs give the same status; floats get 6 digits
        diag.publish(WARN, 'duty stale', {'theta_a_c': 41.123456789, 'rejected': 3,
                                          'bag': 'runs/x'})
        diag.publish(WARN, 'duty stale', [('theta_a_c', 41.123456789), ('rejected', 3),
                                          ('bag', 'runs/x')])
        assert spin_until(ex, lambda: len(arrays) >= 2)
        for array in arrays:
            (status,) = array.status
            assert status.name == 'plant_sim: plant'
            assert status.hardware_id == '/left/plant_sim'   # two actuators stay apart
            assert status.level == DiagnosticStatus.WARN and status.message == 'duty stale'
            assert [(v.key, v.value) for v in status.values] == [
                ('theta_a_c', '41.1235'), ('rejected', '3'), ('bag', 'runs/x')]
            assert array.header.stamp.sec > 0
    finally:
        ex.shutdown()
        listener.destroy_node()
        node.destroy_node()


def test_several_parts_go_out_in_one_array_with_the_named_hardware(ros_context):
    # the hardware bridge: link, mcu and duty statuses of one serial port
    node = rclpy.create_node('hardware_bridge', namespace='/sma', context=ros_context)
    diag = Diagnostics(node, hardware_id='/dev/ttyACM0')
    listener, arrays, ex = _listen(ros_context, node)
    try:
        assert spin_until(ex, lambda: diag.pub.get_subscription_count() > 0)
        diag.publish_statuses([diag.status(LEVELS[level], text, part=part)
                               for part, level, text in (('link', 'ok', 'connected'),
                                                         ('mcu', 'error', 'fault'),
                                                         ('duty', 'stale', 'no duty'))])
        assert spin_until(ex, lambda: arrays)
        got = [(s.name, s.level, s.message, s.hardware_id) for s in arrays[0].status]
        assert got == [('hardware_bridge: link', OK, 'connected', '/dev/ttyACM0'),
                       ('hardware_bridge: mcu', ERROR, 'fault', '/dev/ttyACM0'),
                       ('hardware_bridge: duty', DiagnosticStatus.STALE, 'no duty',
                        '/dev/ttyACM0')]
    finally:
        ex.shutdown()
        listener.destroy_node()
        node.destroy_node()

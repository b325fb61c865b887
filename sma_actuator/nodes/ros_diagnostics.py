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
Diagnostics of every node: DiagnosticStatus entries on /diagnostics, built in one place.

Each status is named ``<node name>: <part>`` and carries key values as text (a float with
6 significant digits, anything else as ``str``). Its hardware_id is the node's fully
qualified name, which tells two actuators (namespaces) apart on the one /diagnostics,
unless the node names its hardware (the bridge: its serial port).
"""
from typing import Any, Iterable, Mapping, Optional, Tuple, Union

from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.node import Node

from .common import DIAGNOSTICS, DIAGNOSTICS_QOS

OK, WARN, ERROR, STALE = (DiagnosticStatus.OK, DiagnosticStatus.WARN, DiagnosticStatus.ERROR,
                          DiagnosticStatus.STALE)
# level by the name the ROS-free cores use (hardware.bridge_core)
LEVELS = {'ok': OK, 'warn': WARN, 'error': ERROR, 'stale': STALE}

Values = Optional[Union[Mapping[str, Any], Iterable[Tuple[str, Any]]]]


class Diagnostics:
    """
    Publish the DiagnosticStatus entries of one node on /diagnostics.

    :param node: The node that publishes (its name prefixes every status name).
    :param name: Default part name: the status is ``<node name>: <name>``.
    :param hardware_id: The status hardware_id; default: the node's fully qualified name.
    """

    def __init__(self, node: Node, name: str = '',
                 hardware_id: Optional[str] = None) -> None:
        self.node = node
        self.name = f'{node.get_name()}: {name}'
        self.hardware_id = hardware_id or node.get_fully_qualified_name()
        self.pub = node.create_publisher(DiagnosticArray, DIAGNOSTICS, DIAGNOSTICS_QOS)

    def status(self, level: bytes, message: str, values: Values = None,
               part: Optional[str] = None) -> DiagnosticStatus:
        """
        Return one DiagnosticStatus of this node.

        :param level: OK, WARN, ERROR or STALE.
        :param values: Key values, as a mapping or (key, value) pairs.
        :param part: Part name instead of the default one (``<node name>: <part>``).
        """
        name = self.name if part is None else f'{self.node.get_name()}: {part}'
        pairs = values.items() if isinstance(values, Mapping) else (values or ())
        return DiagnosticStatus(level=level, name=name, message=message,
                                hardware_id=self.hardware_id,
                                values=[KeyValue(key=k, value=_text(v)) for k, v in pairs])

    def publish_statuses(self, statuses: Iterable[DiagnosticStatus],
                         stamp: Optional[Time] = None) -> None:
        """Publish `statuses` in one DiagnosticArray stamped `stamp` (default: node clock)."""
        msg = DiagnosticArray(status=list(statuses))
        msg.header.stamp = stamp or self.node.get_clock().now().to_msg()
        self.pub.publish(msg)

    def publish(self, level: bytes, message: str, values: Values = None,
                stamp: Optional[Time] = None) -> None:
        """Publish one status: level (OK/WARN/ERROR), message and key values."""
        self.publish_statuses([self.status(level, message, values)], stamp)


def _text(value: Any) -> str:
    return f'{value:.6g}' if isinstance(value, float) else str(value)

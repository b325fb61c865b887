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
The rclpy side of recording and replay (the only module of sma_actuator.bag importing ROS).

Small helpers shared by the recorder and replay nodes: message classes by type name, QoS
profiles from rosbag2 policy names, parameter declaration with descriptors, diagnostics.
"""
import importlib
from typing import Any, Dict, Iterable, Iterator, Tuple

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor
from rclpy.exceptions import InvalidParameterTypeException, InvalidParameterValueException
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

from .errors import UnknownTypeError
from .msgdefs import split_type_name
from .qos import profile_to_dict

_RELIABILITY = {'reliable': ReliabilityPolicy.RELIABLE,
                'best_effort': ReliabilityPolicy.BEST_EFFORT}
_DURABILITY = {'volatile': DurabilityPolicy.VOLATILE,
               'transient_local': DurabilityPolicy.TRANSIENT_LOCAL}

#: A parameter spec: (default, description, (min, max) or None). A default of
#: Parameter.Type.STRING_ARRAY declares a string list with no default (unset = None).
ParamSpec = Tuple[Any, str, Any]


def message_class(type_name: str):
    """
    Import and return the Python class of ``pkg/msg/Type``.

    :raises UnknownTypeError: The message package or type is not installed.
    """
    package, namespace, name = split_type_name(type_name)
    try:
        return getattr(importlib.import_module(f'{package}.{namespace}'), name)
    except (ImportError, AttributeError) as err:
        raise UnknownTypeError(None, f"message type '{type_name}' is not installed "
                                     f'(cannot import {package}.{namespace}.{name})') from err


def qos_profile(reliability: str, durability: str, depth: int) -> QoSProfile:
    """Return a keep-last QoS profile from rosbag2 policy names."""
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=depth,
                      reliability=_RELIABILITY[reliability], durability=_DURABILITY[durability])


def publisher_offers(node: Node, topic: str):
    """Return ``(offered QoS dicts, type hash or '')`` of the publishers of a topic."""
    infos = node.get_publishers_info_by_topic(topic)
    hashes = {str(i.topic_type_hash) for i in infos}
    type_hash = hashes.pop() if len(hashes) == 1 else ''
    return [profile_to_dict(i.qos_profile) for i in infos], (
        type_hash if type_hash.startswith('RIHS01_') else '')


def take_pending(subscription) -> Iterator[Tuple[Any, Dict[str, Any]]]:
    """
    Yield ``(message, info)`` for every message already queued on a subscription.

    rclpy's executors take one message per subscription per wait cycle, which caps a node at
    roughly ten thousand messages per second and lets bursts overflow the queue. Called from
    the subscription's own callback, this takes the rest of the queue at once, through the
    same ``handle.take_message`` call the executor uses. If that call is not available it
    yields nothing and the executor takes the messages one by one as usual.
    """
    handle = getattr(subscription, 'handle', None)
    if handle is None or not hasattr(handle, 'take_message'):
        return
    while True:
        with handle:
            taken = handle.take_message(subscription.msg_type, subscription.raw)
        if taken is None:
            return
        yield taken


def declare_parameters(node: Node, specs: Dict[str, ParamSpec]) -> Dict[str, Any]:
    """Declare parameters with descriptors (description, numeric range); return their values."""
    values = {}
    for name, (default, description, limits) in specs.items():
        descriptor = ParameterDescriptor(description=description)
        if limits is not None and isinstance(default, float):
            descriptor.floating_point_range = [
                FloatingPointRange(from_value=float(limits[0]), to_value=float(limits[1]))]
        elif limits is not None and isinstance(default, int) and not isinstance(default, bool):
            descriptor.integer_range = [
                IntegerRange(from_value=int(limits[0]), to_value=int(limits[1]))]
        try:
            values[name] = node.declare_parameter(name, default, descriptor).value
        except (InvalidParameterValueException, InvalidParameterTypeException) as err:
            raise ValueError(f"parameter '{name}': {err}") from err
    return values


#: Parameters every rclpy node declares itself; accepted as keyword arguments too.
NODE_PARAMETERS = ('use_sim_time',)


def parameter_overrides(specs: Dict[str, ParamSpec], params: Dict[str, Any]):
    """
    Turn ``name=value`` keyword arguments into rclpy parameter overrides.

    :raises ValueError: A name that is not one of the node's parameters.
    """
    unknown = sorted(set(params) - set(specs) - set(NODE_PARAMETERS))
    if unknown:
        raise ValueError(f'unknown parameters {unknown}; known: {sorted(specs)}')
    overrides = []
    for name, value in params.items():
        default = specs[name][0] if name in specs else value
        if isinstance(default, float) and isinstance(value, int) and not isinstance(value, bool):
            value = float(value)  # 2 for a double parameter means 2.0
        if isinstance(value, (list, tuple)) and not value:
            # rclpy types an empty list as a byte array; these lists are string lists
            overrides.append(Parameter(name, Parameter.Type.STRING_ARRAY, []))
            continue
        overrides.append(Parameter(name, value=list(value) if isinstance(value, tuple) else value))
    return overrides


def diagnostics(node: Node, name: str, level: bytes, message: str,
                values: Iterable[Tuple[str, Any]]) -> DiagnosticArray:
    """Return a DiagnosticArray with one status stamped with the node clock."""
    status = DiagnosticStatus(level=level, name=name, message=message,
                              hardware_id=node.get_fully_qualified_name(),
                              values=[KeyValue(key=k, value=str(v)) for k, v in values])
    array = DiagnosticArray(status=[status])
    array.header.stamp = node.get_clock().now().to_msg()
    return array


OK, WARN, ERROR = DiagnosticStatus.OK, DiagnosticStatus.WARN, DiagnosticStatus.ERROR

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
The rclpy side of recording and replay; sma_actuator.bag itself imports no ROS.

Small helpers shared by the recorder and replay nodes: message classes by type name, QoS
profiles from rosbag2 policy names, the QoS publishers offer, taking a queue at once.
"""
import importlib
from typing import Any, Dict, Iterator, List, Tuple

from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.subscription import Subscription

from ..bag.errors import UnknownTypeError
from ..bag.msgdefs import split_type_name
from ..bag.qos import profile_to_dict

_RELIABILITY = {'reliable': ReliabilityPolicy.RELIABLE,
                'best_effort': ReliabilityPolicy.BEST_EFFORT}
_DURABILITY = {'volatile': DurabilityPolicy.VOLATILE,
               'transient_local': DurabilityPolicy.TRANSIENT_LOCAL}


def message_class(type_name: str) -> type:
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


def publisher_offers(node: Node, topic: str) -> Tuple[List[Dict[str, Any]], str]:
    """Return ``(offered QoS dicts, type hash or '')`` of the publishers of a topic."""
    infos = node.get_publishers_info_by_topic(topic)
    hashes = {str(i.topic_type_hash) for i in infos}
    type_hash = hashes.pop() if len(hashes) == 1 else ''
    return [profile_to_dict(i.qos_profile) for i in infos], (
        type_hash if type_hash.startswith('RIHS01_') else '')


def take_pending(subscription: Subscription) -> Iterator[Tuple[Any, Dict[str, Any]]]:
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

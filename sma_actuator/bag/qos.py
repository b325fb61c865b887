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
QoS profiles in rosbag2's Jazzy (metadata version 9) YAML form, without importing ROS.

rosbag2 Jazzy stores the QoS profiles offered by a topic's publishers in the MCAP channel
metadata key ``offered_qos_profiles`` as a YAML sequence (``YAML::Dump`` of
``rosbag2_storage::Rosbag2QoS``), policies as lower-case names::

    - history: keep_last
      depth: 10
      reliability: reliable
      durability: volatile
      deadline:
        sec: 9223372036
        nsec: 854775807
      lifespan: ...
      liveliness: automatic
      liveliness_lease_duration: ...
      avoid_ros_namespace_conventions: false

Durations are rmw_time_t ``{sec, nsec}``; "infinite" is RMW_DURATION_INFINITE, i.e. INT64_MAX
nanoseconds = ``{sec: 9223372036, nsec: 854775807}``. Older bags (metadata version <= 8) use the
integer enum values; :func:`load_offered_qos_profiles` reads both.
"""
from typing import Any, Dict, List, Optional

import yaml

#: rmw enum value -> rosbag2 v9 name (values as in rmw/types.h and rclpy.qos).
HISTORY = {0: 'system_default', 1: 'keep_last', 2: 'keep_all', 3: 'unknown'}
RELIABILITY = {0: 'system_default', 1: 'reliable', 2: 'best_effort', 3: 'unknown',
               4: 'best_available'}
DURABILITY = {0: 'system_default', 1: 'transient_local', 2: 'volatile', 3: 'unknown',
              4: 'best_available'}
LIVELINESS = {0: 'system_default', 1: 'automatic', 3: 'manual_by_topic', 4: 'unknown',
              5: 'best_available'}
#: RMW_DURATION_INFINITE in nanoseconds.
INFINITE_NS = 2**63 - 1
_NS_PER_S = 1_000_000_000
_POLICIES = {'history': HISTORY, 'reliability': RELIABILITY, 'durability': DURABILITY,
             'liveliness': LIVELINESS}
_DURATIONS = ('deadline', 'lifespan', 'liveliness_lease_duration')

QosDict = Dict[str, Any]


def duration_to_dict(nanoseconds: int) -> Dict[str, int]:
    """Convert a duration [ns] to rmw_time_t form ``{'sec': s, 'nsec': ns}``."""
    sec, nsec = divmod(int(nanoseconds), _NS_PER_S)
    return {'sec': sec, 'nsec': nsec}


def _policy_name(table: Dict[int, str], value: Any) -> str:
    """Return the v9 name of a policy given as enum member, int or name."""
    if isinstance(value, str):
        name = value.lower()
        if name not in table.values():
            raise ValueError(f"unknown QoS policy value '{value}' (expected one of "
                             f'{sorted(table.values())})')
        return name
    return table.get(int(getattr(value, 'value', value)), 'unknown')


def _nanoseconds(value: Any) -> int:
    """Return a duration [ns] from an rclpy Duration, a {sec, nsec} dict or an int [ns]."""
    if isinstance(value, dict):
        return int(value['sec']) * _NS_PER_S + int(value['nsec'])
    return int(getattr(value, 'nanoseconds', value))


def profile_to_dict(profile: Any) -> QosDict:
    """
    Convert a QoS profile to the rosbag2 v9 mapping (keys in rosbag2's order).

    :param profile: An ``rclpy.qos.QoSProfile`` (or any object/dict with the same fields).
    """
    def get(name):
        return profile[name] if isinstance(profile, dict) else getattr(profile, name)

    out: QosDict = {}
    for key in ('history', 'depth', 'reliability', 'durability', 'deadline', 'lifespan',
                'liveliness', 'liveliness_lease_duration', 'avoid_ros_namespace_conventions'):
        value = get(key)
        if key in _POLICIES:
            out[key] = _policy_name(_POLICIES[key], value)
        elif key in _DURATIONS:
            out[key] = duration_to_dict(_nanoseconds(value))
        elif key == 'depth':
            out[key] = int(value)
        else:
            out[key] = bool(value)
    return out


def dump_offered_qos_profiles(profiles: List[Any]) -> str:
    """
    Serialise profiles to the exact YAML text rosbag2 Jazzy puts in channel metadata.

    :param profiles: QoS profiles (see :func:`profile_to_dict`); empty gives ``[]``.
    """
    dicts = [profile_to_dict(p) for p in profiles]
    if not dicts:
        return '[]'
    return yaml.safe_dump(dicts, sort_keys=False, default_flow_style=False).rstrip('\n')


def load_offered_qos_profiles(text: Optional[str]) -> List[QosDict]:
    """
    Parse ``offered_qos_profiles`` YAML (rosbag2 v9 names or <= v8 integers) to v9 dicts.

    :raises ValueError: The text is not a YAML sequence of QoS mappings.
    """
    if not text or not text.strip():
        return []
    data = yaml.safe_load(text)
    if data is None:
        return []
    if not isinstance(data, list) or not all(isinstance(p, dict) for p in data):
        raise ValueError(f'offered_qos_profiles is not a YAML list of mappings: {text[:80]!r}')
    try:
        return [profile_to_dict(p) for p in data]
    except KeyError as err:
        raise ValueError(f'offered_qos_profiles entry lacks the {err} field') from err


def adapt_request_to_offers(offers: List[QosDict]) -> Dict[str, str]:
    """
    Choose subscription reliability/durability that connects to every publisher (as rosbag2).

    Reliable only if every offer is reliable, transient_local only if every offer is; with no
    offers known: reliable/volatile (rosbag2's default).

    :return: ``{'reliability': ..., 'durability': ...}`` in v9 names.
    """
    if not offers:
        return {'reliability': 'reliable', 'durability': 'volatile'}
    reliable = all(o['reliability'] == 'reliable' for o in offers)
    latched = all(o['durability'] == 'transient_local' for o in offers)
    return {'reliability': 'reliable' if reliable else 'best_effort',
            'durability': 'transient_local' if latched else 'volatile'}


def adapt_offer_to_recorded_offers(offers: List[QosDict]) -> Dict[str, str]:
    """
    Choose publisher reliability/durability for replay from the recorded offers (as rosbag2).

    If all recorded publishers offered the same reliability and durability, offer those;
    otherwise (or with none recorded) offer reliable/volatile, which every subscriber accepts
    except one asking for transient_local.

    :return: ``{'reliability': ..., 'durability': ...}`` in v9 names.
    """
    pairs = {(o['reliability'], o['durability']) for o in offers}
    if len(pairs) == 1:
        reliability, durability = pairs.pop()
        if reliability in ('reliable', 'best_effort') and durability in (
                'volatile', 'transient_local'):
            return {'reliability': reliability, 'durability': durability}
    return {'reliability': 'reliable', 'durability': 'volatile'}

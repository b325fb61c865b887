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

"""QoS profiles are written in rosbag2 Jazzy's YAML form and read back from v8/v9 bags."""
import pytest
from rosbags.rosbag2.metadata import parse_qos
from sma_actuator.bag.qos import (
    adapt_offer_to_recorded_offers,
    adapt_request_to_offers,
    dump_offered_qos_profiles,
    INFINITE_NS,
    load_offered_qos_profiles,
    profile_to_dict,
)
from sma_actuator.bag.synthetic import offered_profile

# What rosbag2 Jazzy (qos.cpp, YAML::Dump) writes for a Fast DDS publisher discovered with
# reliable/volatile, history unknown, depth 0 and infinite durations.
JAZZY_TEXT = """\
- history: unknown
  depth: 0
  reliability: reliable
  durability: volatile
  deadline:
    sec: 9223372036
    nsec: 854775807
  lifespan:
    sec: 9223372036
    nsec: 854775807
  liveliness: automatic
  liveliness_lease_duration:
    sec: 9223372036
    nsec: 854775807
  avoid_ros_namespace_conventions: false"""


class _Duration:
    def __init__(self, ns):
        self.nanoseconds = ns


class _Profile:
    """Duck-typed stand-in for an rclpy QoSProfile as get_publishers_info_by_topic returns."""

    history, depth, reliability, durability, liveliness = 3, 0, 1, 2, 1
    deadline = lifespan = liveliness_lease_duration = _Duration(INFINITE_NS)
    avoid_ros_namespace_conventions = False


def test_discovered_profile_dumps_exactly_like_rosbag2_jazzy():
    assert dump_offered_qos_profiles([_Profile()]) == JAZZY_TEXT


def test_dump_is_read_by_rosbags_with_the_same_policies():
    (qos,) = parse_qos(dump_offered_qos_profiles([offered_profile('best_effort', depth=5)]))
    assert qos.reliability.name == 'BEST_EFFORT'
    assert qos.durability.name == 'VOLATILE'
    assert qos.depth == 5
    assert (qos.deadline.sec, qos.deadline.nsec) == (9223372036, 854775807)


def test_no_profiles_dump_as_empty_sequence():
    assert dump_offered_qos_profiles([]) == '[]'
    assert load_offered_qos_profiles('[]') == []
    assert load_offered_qos_profiles('') == []


def test_version_8_integer_profiles_are_read_as_names():
    v8 = JAZZY_TEXT.replace('history: unknown', 'history: 3').replace(
        'reliability: reliable', 'reliability: 2').replace(
        'durability: volatile', 'durability: 1').replace('liveliness: automatic', 'liveliness: 1')
    (profile,) = load_offered_qos_profiles(v8)
    assert (profile['history'], profile['reliability'], profile['durability'],
            profile['liveliness']) == ('unknown', 'best_effort', 'transient_local', 'automatic')


def test_round_trip_keeps_every_field():
    original = offered_profile('reliable', depth=7)
    assert load_offered_qos_profiles(dump_offered_qos_profiles([original])) == [original]
    assert profile_to_dict(original) == original


@pytest.mark.parametrize('text, problem', [
    ('history: keep_last', 'not a YAML list'),
    ('- 3', 'not a YAML list'),
    (JAZZY_TEXT.replace('reliable', 'sometimes'), "unknown QoS policy value 'sometimes'"),
    (JAZZY_TEXT.replace('  depth: 0\n', ''), "lacks the 'depth' field"),
])
def test_malformed_profiles_are_rejected_with_the_reason(text, problem):
    with pytest.raises(ValueError, match=problem):
        load_offered_qos_profiles(text)


def test_request_adapts_to_the_weakest_publisher():
    reliable, best = offered_profile('reliable'), offered_profile('best_effort')
    latched = dict(reliable, durability='transient_local')
    assert adapt_request_to_offers([reliable, reliable]) == {
        'reliability': 'reliable', 'durability': 'volatile'}
    assert adapt_request_to_offers([reliable, best])['reliability'] == 'best_effort'
    assert adapt_request_to_offers([latched])['durability'] == 'transient_local'
    assert adapt_request_to_offers([latched, reliable])['durability'] == 'volatile'
    assert adapt_request_to_offers([]) == {'reliability': 'reliable', 'durability': 'volatile'}


def test_replay_offer_keeps_a_consistent_recorded_offer_else_falls_back():
    best = offered_profile('best_effort')
    assert adapt_offer_to_recorded_offers([best, best]) == {
        'reliability': 'best_effort', 'durability': 'volatile'}
    mixed = [best, offered_profile('reliable')]
    assert adapt_offer_to_recorded_offers(mixed) == {
        'reliability': 'reliable', 'durability': 'volatile'}
    assert adapt_offer_to_recorded_offers([]) == {
        'reliability': 'reliable', 'durability': 'volatile'}

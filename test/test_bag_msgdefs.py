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

"""Message definitions and type hashes match rosbag2's layout and the installed interfaces."""
import pytest
from rosbags.typesys import get_types_from_msg, get_typestore, Stores
from sma_actuator.bag.errors import UnknownTypeError
from sma_actuator.bag.msgdefs import (DELIMITER, interface_file, message_definition,
                                      normalize_type_name, type_description_hash)
from sma_actuator.bag.synthetic import SMA_TOPICS

CONTRACT_TYPES = sorted({t for t, _ in SMA_TOPICS.values()} | {'rosgraph_msgs/msg/Clock'})


def _sections(text):
    """Split a full definition into [(type or None for the root, text)]."""
    parts = text.split('\n' + DELIMITER)
    out = [(None, parts[0])]
    for part in parts[1:]:
        head, _, body = part.partition('\n')
        assert head.startswith('MSG: ')
        out.append((head[len('MSG: '):], body))
    return out


def test_joint_state_definition_is_root_then_dependencies_depth_first():
    text = message_definition('sensor_msgs/msg/JointState')
    sections = _sections(text)
    assert sections[0][1] == interface_file('sensor_msgs/msg/JointState', '.msg').read_text()
    assert [name for name, _ in sections[1:]] == ['std_msgs/Header', 'builtin_interfaces/Time']
    assert sections[1][1] == interface_file('std_msgs/msg/Header', '.msg').read_text()
    assert DELIMITER == '=' * 80 + '\n'


def test_dependencies_are_sorted_and_listed_once():
    sections = _sections(message_definition('diagnostic_msgs/msg/DiagnosticArray'))
    names = [name for name, _ in sections[1:]]
    # root deps sorted; Header's own dep (Time) follows Header (depth first); no repeats
    assert names == ['diagnostic_msgs/DiagnosticStatus', 'diagnostic_msgs/KeyValue',
                     'std_msgs/Header', 'builtin_interfaces/Time']


@pytest.mark.parametrize('type_name', CONTRACT_TYPES)
def test_definition_parses_and_hashes_to_the_installed_type_hash(type_name):
    """
    Check the text is complete and correct with an independent parser (rosbags).

    It rebuilds the type from our text alone, and its RIHS01 hash of that type equals the
    hash rosidl installed.
    """
    store = get_typestore(Stores.EMPTY)
    text = message_definition(type_name)
    types = {}
    for name, body in _sections(text):
        types.update(get_types_from_msg(body, name or type_name))
    store.register(types)
    assert store.hash_rihs01(type_name) == type_description_hash(type_name)
    assert type_description_hash(type_name).startswith('RIHS01_')


def test_short_type_names_are_normalised():
    assert normalize_type_name('std_msgs/Float64') == 'std_msgs/msg/Float64'
    assert message_definition('std_msgs/Float64') == message_definition('std_msgs/msg/Float64')


@pytest.mark.parametrize('bad', ['', 'Float64', 'std_msgs/msg/Float64/x', '1pkg/msg/T'])
def test_malformed_type_names_are_rejected(bad):
    with pytest.raises(UnknownTypeError, match='not a ROS message type name'):
        message_definition(bad)


def test_unknown_type_names_the_type_and_where_it_looked():
    with pytest.raises(UnknownTypeError, match=r"'no_such_msgs/msg/Thing'.*no_such_msgs"):
        message_definition('no_such_msgs/msg/Thing')
    with pytest.raises(UnknownTypeError, match='NoSuchType'):
        type_description_hash('std_msgs/msg/NoSuchType')


def test_ament_prefix_path_is_searched_first(tmp_path, monkeypatch):
    msg_dir = tmp_path / 'share' / 'fake_msgs' / 'msg'
    msg_dir.mkdir(parents=True)
    (msg_dir / 'Thing.msg').write_text('float64 x\nstd_msgs/Header header\n')
    monkeypatch.setenv('AMENT_PREFIX_PATH', str(tmp_path))
    message_definition.cache_clear()
    try:
        sections = _sections(message_definition('fake_msgs/msg/Thing'))
    finally:
        message_definition.cache_clear()
    assert sections[0][1] == 'float64 x\nstd_msgs/Header header\n'
    assert [n for n, _ in sections[1:]] == ['std_msgs/Header', 'builtin_interfaces/Time']

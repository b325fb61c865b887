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
Message definitions and type hashes of installed ROS 2 message types, as rosbag2 stores them.

rosbag2 (``rosbag2_cpp::LocalMessageDefinitionSource``, Jazzy) stores one schema per type with
encoding ``ros2msg``: the text of the type's .msg file, then for every dependency not yet
written (in sorted order, depth first) a newline, a line of 80 ``=``, a line ``MSG: pkg/Type``
and that dependency's .msg text. The functions here rebuild exactly that text from the .msg
files of the installed packages, so a reader (rosbags, Foxglove, mcap-ros2-support) can decode a
bag without the packages installed.

The type hash (``RIHS01_...``) comes from the type-description JSON that rosidl installs next
to each .msg file; it is what rclpy reports as ``TopicEndpointInfo.topic_type_hash``.

Packages are looked up through the ament index (``AMENT_PREFIX_PATH``, as on a full Jazzy
install) and then in ``<sys.prefix>/share`` (the pip-installed Jazzy wheels).
"""
import functools
import json
import os
from pathlib import Path
import re
import sys
from typing import List, Set, Tuple

from .errors import UnknownTypeError

#: Line put before each dependency's definition (followed by ``MSG: pkg/Type``).
DELIMITER = '=' * 80 + '\n'

# Same expression as rosbag2's MSG_FIELD_TYPE_REGEX: the first word on a line is a field type.
_FIELD_TYPE = re.compile(r'(?:^|\n)\s*([a-zA-Z0-9_/]+)(?:\[[^\]]*\])?\s+')
_PRIMITIVES = frozenset({
    'bool', 'byte', 'char', 'float32', 'float64', 'int8', 'uint8', 'int16', 'uint16',
    'int32', 'uint32', 'int64', 'uint64', 'string'})
_NAME = r'[a-zA-Z][a-zA-Z0-9_]*'
_TYPE_NAME = re.compile(rf'^({_NAME})/(?:({_NAME})/)?({_NAME})$')
# Guards against a (broken) cyclic definition, like rosbag2's max recursion depth.
_MAX_DEPTH = 50


def split_type_name(type_name: str) -> Tuple[str, str, str]:
    """
    Split ``pkg/msg/Type`` or ``pkg/Type`` into ``(pkg, 'msg', 'Type')``.

    :raises UnknownTypeError: The name is not a ROS interface type name.
    """
    match = _TYPE_NAME.match(type_name or '')
    if not match:
        raise UnknownTypeError(
            None, f"'{type_name}' is not a ROS message type name (expected pkg/msg/Type)")
    package, namespace, name = match.groups()
    return package, namespace or 'msg', name


def normalize_type_name(type_name: str) -> str:
    """Return the full ``pkg/msg/Type`` form of a type name (``std_msgs/Float64`` accepted)."""
    return '/'.join(split_type_name(type_name))


def share_directories() -> List[Path]:
    """Return the ``share`` directories searched for interface files, in search order."""
    prefixes = [p for p in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep) if p]
    prefixes.append(sys.prefix)
    dirs: List[Path] = []
    for prefix in prefixes:
        share = Path(prefix) / 'share'
        if share not in dirs:
            dirs.append(share)
    return dirs


def interface_file(type_name: str, suffix: str) -> Path:
    """
    Return the installed interface file of a type, e.g. suffix ``.msg`` or ``.json``.

    :raises UnknownTypeError: No installed package provides the file; the message lists
        the directories searched.
    """
    package, namespace, name = split_type_name(type_name)
    searched = []
    for share in share_directories():
        candidate = share / package / namespace / (name + suffix)
        if candidate.is_file():
            return candidate
        searched.append(str(candidate))
    raise UnknownTypeError(
        None, f"no installed definition for '{type_name}' (looked for {', '.join(searched)})")


def _dependencies(text: str, package: str) -> Set[str]:
    """Return the non-primitive field types of a .msg text as ``pkg/Type`` names."""
    deps = set()
    for match in _FIELD_TYPE.finditer(text):
        field_type = match.group(1)
        if field_type in _PRIMITIVES:
            continue
        deps.add(field_type if '/' in field_type else f'{package}/{field_type}')
    return deps


@functools.lru_cache(maxsize=None)
def _msg_text(type_name: str) -> str:
    """Return the raw text of a type's .msg file."""
    return interface_file(type_name, '.msg').read_text(encoding='utf-8')


@functools.lru_cache(maxsize=None)
def message_definition(type_name: str) -> str:
    """
    Return the full ``ros2msg`` definition of an installed message type, as rosbag2 writes it.

    :param type_name: ``pkg/msg/Type`` (or ``pkg/Type``).
    :raises UnknownTypeError: The type or one of its dependencies is not installed.
    """
    seen: Set[str] = set()

    def append_recursive(name: str, depth: int) -> str:
        if depth <= 0:
            raise UnknownTypeError(None, f"definition of '{type_name}' nests too deeply")
        text = _msg_text(name)
        result = text
        for dep in sorted(_dependencies(text, split_type_name(name)[0])):
            if dep not in seen:
                seen.add(dep)
                result += '\n' + DELIMITER + f'MSG: {dep}\n' + append_recursive(dep, depth - 1)
        return result

    return append_recursive(normalize_type_name(type_name), _MAX_DEPTH)


@functools.lru_cache(maxsize=None)
def type_description_hash(type_name: str) -> str:
    """
    Return the ``RIHS01_<sha256 hex>`` type hash of an installed message type.

    :raises UnknownTypeError: The type's type-description JSON is not installed or has no hash.
    """
    full_name = normalize_type_name(type_name)
    path = interface_file(full_name, '.json')
    for entry in json.loads(path.read_text(encoding='utf-8')).get('type_hashes', []):
        if entry.get('type_name') == full_name:
            return entry['hash_string']
    raise UnknownTypeError(path, f"no type hash for '{full_name}' in the type description")

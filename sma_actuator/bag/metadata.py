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
rosbag2 bag metadata (``metadata.yaml``, version 9 = Jazzy) from plain Python values.

The same mapping (without the ``rosbag2_bagfile_information`` wrapper) is what rosbag2_storage_mcap
embeds in each MCAP file as a Metadata record named ``rosbag2`` with key ``serialized_metadata``;
its presence tells rosbag2 that the channel QoS YAML uses version-9 names.

Layout follows ``rosbag2_storage/yaml.hpp``; sequences are indented under their key like
yaml-cpp emits them, and null is written ``~``.
"""
from dataclasses import dataclass, field
import os
from pathlib import Path
from typing import Any, Dict, List, Tuple

import yaml

from .errors import BagError
from .qos import load_offered_qos_profiles

#: rosbag2 metadata version written (Jazzy).
METADATA_VERSION = 9
METADATA_FILE = 'metadata.yaml'
#: Largest metadata.yaml read [bytes]; a bag with thousands of files and topics needs < 1 MiB.
MAX_METADATA_BYTES = 4 << 20
#: Deepest YAML nesting read (rosbag2 metadata nests 5 levels).
MAX_METADATA_DEPTH = 32
# libyaml's safe loader when installed (fast); its parser is not recursive, and documents are
# only composed after the nesting depth was checked (deep nesting overflows the C stack).
_LOADER = getattr(yaml, 'CSafeLoader', yaml.SafeLoader)
_ROOT_KEY = 'rosbag2_bagfile_information'


@dataclass
class TopicRecord:
    """One topic as rosbag2 describes it (``TopicMetadata`` plus its message count)."""

    name: str
    type: str  # noqa: A003 (rosbag2's TopicMetadata field name)
    offered_qos_profiles: str = '[]'  # channel-metadata YAML text, see qos.py
    type_description_hash: str = ''
    serialization_format: str = 'cdr'
    message_count: int = 0


@dataclass
class FileRecord:
    """One storage file: path relative to the bag directory, times [ns], message count."""

    path: str
    starting_time_ns: int = 0
    duration_ns: int = 0
    message_count: int = 0


@dataclass
class BagRecord:
    """A whole bag: its files and topics; timings are derived from the files."""

    files: List[FileRecord] = field(default_factory=list)
    topics: List[TopicRecord] = field(default_factory=list)
    ros_distro: str = field(default_factory=lambda: os.environ.get('ROS_DISTRO', 'jazzy'))
    compression_format: str = ''
    compression_mode: str = ''

    def span_ns(self) -> Tuple[int, int]:
        """Return ``(starting_time, duration)`` [ns] over all files that hold messages."""
        spans = [(f.starting_time_ns, f.starting_time_ns + f.duration_ns)
                 for f in self.files if f.message_count]
        if not spans:
            return 0, 0
        start = min(s for s, _ in spans)
        return start, max(e for _, e in spans) - start


class _Dumper(yaml.SafeDumper):
    """SafeDumper that indents block sequences under their key and writes null as ``~``."""

    def increase_indent(self, flow=False, indentless=False):
        return super().increase_indent(flow, False)


_Dumper.add_representer(
    type(None), lambda dumper, _: dumper.represent_scalar('tag:yaml.org,2002:null', '~'))


def to_dict(bag: BagRecord) -> Dict[str, Any]:
    """Return the rosbag2 ``BagMetadata`` mapping (keys in rosbag2's order)."""
    start, duration = bag.span_ns()
    return {
        'version': METADATA_VERSION,
        'storage_identifier': 'mcap',
        'duration': {'nanoseconds': duration},
        'starting_time': {'nanoseconds_since_epoch': start},
        'message_count': sum(f.message_count for f in bag.files),
        'topics_with_message_count': [
            {'topic_metadata': {
                'name': t.name,
                'type': t.type,
                'serialization_format': t.serialization_format,
                'offered_qos_profiles': load_offered_qos_profiles(t.offered_qos_profiles),
                'type_description_hash': t.type_description_hash},
             'message_count': t.message_count}
            for t in bag.topics],
        'compression_format': bag.compression_format,
        'compression_mode': bag.compression_mode,
        'relative_file_paths': [f.path for f in bag.files],
        'files': [
            {'path': f.path,
             'starting_time': {'nanoseconds_since_epoch': f.starting_time_ns},
             'duration': {'nanoseconds': f.duration_ns},
             'message_count': f.message_count}
            for f in bag.files],
        'custom_data': None,
        'ros_distro': bag.ros_distro,
    }


def dump_serialized_metadata(bag: BagRecord) -> str:
    """Return the YAML stored in the MCAP ``rosbag2`` metadata record (no wrapper key)."""
    return yaml.dump(to_dict(bag), Dumper=_Dumper, sort_keys=False, default_flow_style=False)


def dump_metadata_yaml(bag: BagRecord) -> str:
    """Return the text of ``metadata.yaml`` for a bag directory."""
    return yaml.dump({_ROOT_KEY: to_dict(bag)}, Dumper=_Dumper, sort_keys=False,
                     default_flow_style=False)


def write_metadata_yaml(directory: Path, bag: BagRecord) -> Path:
    """Write ``metadata.yaml`` atomically (temp file + rename) and return its path."""
    path = Path(directory) / METADATA_FILE
    tmp = path.with_name(METADATA_FILE + '.tmp')
    tmp.write_text(dump_metadata_yaml(bag), encoding='utf-8')
    os.replace(tmp, path)
    return path


def _nesting_depth_ok(text: str, limit: int) -> bool:
    """Return whether no YAML collection in `text` nests deeper than `limit` (event parse)."""
    depth = 0
    for event in yaml.parse(text, Loader=_LOADER):
        if isinstance(event, (yaml.MappingStartEvent, yaml.SequenceStartEvent)):
            depth += 1
            if depth > limit:
                return False
        elif isinstance(event, (yaml.MappingEndEvent, yaml.SequenceEndEvent)):
            depth -= 1
    return True


def read_metadata_yaml(path: Path) -> Dict[str, Any]:
    """
    Read a rosbag2 ``metadata.yaml`` and return the inner ``BagMetadata`` mapping.

    The file may hold at most :data:`MAX_METADATA_BYTES` and nest at most
    :data:`MAX_METADATA_DEPTH` levels; every field this package uses is type-checked.

    :raises BagError: The file is not valid rosbag2 metadata (the message says which field).
    """
    path = Path(path)
    try:
        size = path.stat().st_size
        if size > MAX_METADATA_BYTES:
            raise BagError(path, f'metadata file of {size} bytes is over the limit of '
                                 f'{MAX_METADATA_BYTES} bytes; not rosbag2 metadata')
        text = path.read_text(encoding='utf-8')
        if not _nesting_depth_ok(text, MAX_METADATA_DEPTH):
            raise BagError(path, f'YAML nested deeper than {MAX_METADATA_DEPTH} levels; not '
                                 'rosbag2 metadata')
        data = yaml.load(text, Loader=_LOADER)  # a safe loader: plain data only
    except (OSError, UnicodeDecodeError, yaml.YAMLError, RecursionError) as err:
        reason = 'nested too deeply' if isinstance(err, RecursionError) else \
            ' '.join(str(err).split())
        raise BagError(path, f'cannot read rosbag2 metadata: {reason}') from None
    if not isinstance(data, dict) or not isinstance(data.get(_ROOT_KEY), dict):
        raise BagError(path, f"not rosbag2 metadata (no '{_ROOT_KEY}' mapping)")
    info = data[_ROOT_KEY]
    if info.get('storage_identifier') not in (None, 'mcap'):
        raise BagError(path, f"storage '{info.get('storage_identifier')!s:.40}' is not "
                             'supported (only mcap bags can be read)')
    _check_schema(path, info)
    return info


def _is_count(value) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and 0 <= value < 1 << 63


def _check_schema(path: Path, info: Dict[str, Any]) -> None:
    """Raise BagError naming the first field this package reads that has the wrong type."""
    def bad(field_name, want) -> None:
        raise BagError(path, f'metadata field {field_name} must be {want}')

    paths = info.get('relative_file_paths')
    if paths is not None and (not isinstance(paths, list) or not all(
            isinstance(p, str) and p for p in paths)):
        bad('relative_file_paths', 'a list of file names')
    if paths is not None and len(set(paths)) != len(paths):
        bad('relative_file_paths', 'a list without repeated files')
    files = info.get('files')
    if files is not None:
        if not isinstance(files, list) or not all(isinstance(f, dict) for f in files):
            bad('files', 'a list of mappings')
        for i, f in enumerate(files):
            if not isinstance(f.get('path'), str):
                bad(f'files[{i}].path', 'a file name')
            if not _is_count(f.get('message_count')):
                bad(f'files[{i}].message_count', 'a non-negative integer')
            for key, inner in (('starting_time', 'nanoseconds_since_epoch'),
                               ('duration', 'nanoseconds')):
                if not isinstance(f.get(key), dict) or not _is_count(f[key].get(inner)):
                    bad(f'files[{i}].{key}.{inner}', 'a non-negative integer')
    topics = info.get('topics_with_message_count')
    if topics is not None:
        if not isinstance(topics, list) or not all(isinstance(t, dict) for t in topics):
            bad('topics_with_message_count', 'a list of mappings')
        for i, t in enumerate(topics):
            meta = t.get('topic_metadata')
            if not isinstance(meta, dict) or not isinstance(meta.get('name'), str):
                bad(f'topics_with_message_count[{i}].topic_metadata.name', 'a topic name')
            if not _is_count(t.get('message_count')):
                bad(f'topics_with_message_count[{i}].message_count', 'a non-negative integer')


def bag_file_paths(bag_dir: Path, info: Dict[str, Any], meta_path: Path) -> List[Path]:
    """
    Return the storage files ``metadata.yaml`` lists, each checked to lie in ``bag_dir``.

    :raises BagError: A path is absolute, leaves the directory (``..`` or a symlink out).
    """
    root = Path(bag_dir).resolve()
    out = []
    for rel in info.get('relative_file_paths') or []:
        candidate = Path(rel)
        if candidate.is_absolute() or '..' in candidate.parts or \
                root not in (root / candidate).resolve().parents:
            raise BagError(meta_path, f"listed file '{rel}' is outside the bag directory "
                                      '(absolute path, .. or a symlink out)')
        out.append(Path(bag_dir) / candidate)
    return out

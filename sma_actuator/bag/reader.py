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
BagReader: messages and topic information of an MCAP bag (ours or rosbag2's), ROS-free.

Accepts a bag directory (with or without ``metadata.yaml``) or a single ``.mcap`` file. Files
with a valid summary are read through mcap's indexed reader; files without one (the recorder was
killed) are recovered up to the last complete chunk, see :mod:`.recovery` and
:attr:`BagReader.recoveries`.
"""
from dataclasses import dataclass
from pathlib import Path
from typing import Dict, Iterable, Iterator, List, Optional, Union

from mcap.exceptions import McapError
from mcap.reader import make_reader

from .errors import (BagError, BagNotFoundError, NotMcapError, TruncatedBagError,
                     UnknownTypeError)
from .metadata import METADATA_FILE, read_metadata_yaml
from .recovery import iter_span_messages, RecoveryReport, scan

MCAP_MAGIC = b'\x89MCAP0\r\n'
_FOOTER_AND_MAGIC = 9 + 20 + 8  # footer record (opcode, length, 20-byte body) + magic


@dataclass
class TopicInfo:
    """A topic of the bag: type, encodings, recorded QoS and type hash, message count."""

    name: str
    type: str  # noqa: A003 (rosbag2's TopicMetadata field name)
    serialization_format: str
    schema_encoding: str
    definition: str
    offered_qos_profiles: str
    type_hash: str
    message_count: int


@dataclass
class BagMessage:
    """One stored message: CDR bytes as recorded plus its times [ns since epoch]."""

    topic: str
    data: bytes
    log_time_ns: int
    publish_time_ns: int


class _McapFile:
    """One storage file: summary-based when complete, scan-based when recovered."""

    def __init__(self, path: Path):
        self.path = path
        self.recovery: Optional[RecoveryReport] = None
        self._spans = None
        size = path.stat().st_size
        if size == 0:
            raise TruncatedBagError(path, 'file is empty (0 bytes)')
        with open(path, 'rb') as f:
            magic = f.read(len(MCAP_MAGIC))
            if magic != MCAP_MAGIC[:len(magic)] or len(magic) < len(MCAP_MAGIC):
                if magic == MCAP_MAGIC[:len(magic)]:
                    raise TruncatedBagError(path, f'file ends after {size} bytes, inside the '
                                                  'MCAP magic')
                raise NotMcapError(path, 'not an MCAP file (wrong magic bytes at start)')
            f.seek(max(0, size - len(MCAP_MAGIC)))
            complete = size >= 2 * len(MCAP_MAGIC) + _FOOTER_AND_MAGIC and \
                f.read() == MCAP_MAGIC
        summary, profile = self._read_summary() if complete else (None, None)
        if summary is not None:
            self.schemas, self.channels = summary.schemas, summary.channels
            stats = summary.statistics
            self.counts = dict(stats.channel_message_counts) if stats else {}
            self.profile = profile
            return
        found = scan(path)
        if found.header is None:
            raise TruncatedBagError(path, f'file is cut off after {size} bytes, before the '
                                          'MCAP header; nothing to recover')
        self.recovery = found.report
        self.schemas, self.channels = found.schemas, found.channels
        self.counts, self._spans = found.message_counts, found.data_spans
        self.profile = found.header.profile

    def _read_summary(self):
        """Return ``(summary, header profile)``, or ``(None, None)`` if there is no summary."""
        try:
            with open(self.path, 'rb') as f:
                reader = make_reader(f)
                return reader.get_summary(), reader.get_header().profile
        except (McapError, ValueError, OSError, EOFError):
            return None, None

    def messages(self, topics: Optional[Iterable[str]],
                 start_time_ns: Optional[int]) -> Iterator[BagMessage]:
        wanted = None if topics is None else set(topics)
        by_id = {cid: ch.topic for cid, ch in self.channels.items()}
        if self._spans is not None:
            source = iter_span_messages(self.path, self._spans)
        else:
            source = self._indexed(wanted, start_time_ns)
        for msg in source:
            topic = by_id.get(msg.channel_id)
            if topic is None or (wanted is not None and topic not in wanted):
                continue
            if start_time_ns is not None and msg.log_time < start_time_ns:
                continue
            yield BagMessage(topic, msg.data, msg.log_time, msg.publish_time)

    def _indexed(self, wanted, start_time_ns):
        with open(self.path, 'rb') as f:
            reader = make_reader(f)
            for _, _, msg in reader.iter_messages(topics=None if wanted is None else list(wanted),
                                                  starting_at=start_time_ns,
                                                  log_time_order=True):
                yield msg


def _bag_files(path: Path) -> List[Path]:
    """Resolve a bag path (directory or .mcap file) to its storage files, in order."""
    if not path.exists():
        raise BagNotFoundError(path, 'no such file or directory')
    if path.is_file():
        return [path]
    meta = path / METADATA_FILE
    if meta.is_file():
        info = read_metadata_yaml(meta)
        files = [path / rel for rel in info.get('relative_file_paths') or []]
        missing = [f.name for f in files if not f.is_file()]
        if missing:
            raise BagNotFoundError(path, f'metadata.yaml lists missing files: {missing}')
        if files:
            return files

    def split_index(p: Path):
        tail = p.stem.rsplit('_', 1)[-1]
        return (int(tail) if tail.isdigit() else -1, p.name)

    files = sorted(path.glob('*.mcap'), key=split_index)
    if not files:
        raise BagNotFoundError(path, 'directory holds no .mcap file')
    return files


class BagReader:
    """
    Read an MCAP bag directory or file.

    :param path: Bag directory (rosbag2 layout) or a single ``.mcap`` file.
    :raises BagNotFoundError: The path does not exist or holds no .mcap file.
    :raises NotMcapError: A file is not MCAP.
    :raises TruncatedBagError: A file is empty or cut before its header.
    :raises UnknownTypeError: One topic is stored with two different types.
    """

    def __init__(self, path: Union[str, Path]):
        self.path = Path(path)
        self._files = [_McapFile(p) for p in _bag_files(self.path)]
        self.topics: Dict[str, TopicInfo] = {}
        for f in self._files:
            self._collect_topics(f)

    def _collect_topics(self, f: _McapFile):
        for cid, ch in f.channels.items():
            schema = f.schemas.get(ch.schema_id)
            type_name = schema.name if schema else ''
            known = self.topics.get(ch.topic)
            if known is not None and known.type != type_name:
                raise UnknownTypeError(f.path, f"topic '{ch.topic}' has type '{type_name}' here "
                                               f"but '{known.type}' in an earlier file")
            count = f.counts.get(cid, 0)
            if known is not None:
                known.message_count += count
                continue
            self.topics[ch.topic] = TopicInfo(
                name=ch.topic, type=type_name, serialization_format=ch.message_encoding,
                schema_encoding=schema.encoding if schema else '',
                definition=schema.data.decode('utf-8', 'replace') if schema else '',
                offered_qos_profiles=ch.metadata.get('offered_qos_profiles', ''),
                type_hash=ch.metadata.get('topic_type_hash', ''), message_count=count)

    @property
    def files(self) -> List[Path]:
        """Storage files of the bag, in playback order."""
        return [f.path for f in self._files]

    @property
    def recoveries(self) -> List[RecoveryReport]:
        """One report per file that had no summary and was recovered (empty if none)."""
        return [f.recovery for f in self._files if f.recovery is not None]

    @property
    def profiles(self) -> List[str]:
        """MCAP header profile of each file (``'ros2'`` for rosbag2 bags)."""
        return [f.profile for f in self._files]

    @property
    def message_count(self) -> int:
        """Messages in the bag (recovered ones for recovered files)."""
        return sum(t.message_count for t in self.topics.values())

    def messages(self, topics: Optional[Iterable[str]] = None,
                 start_time_ns: Optional[int] = None) -> Iterator[BagMessage]:
        """
        Yield messages in log-time order (per file; files in sequence).

        :param topics: Only these topics (default: all).
        :param start_time_ns: Skip messages logged before this time [ns].
        """
        topics = None if topics is None else list(topics)
        for f in self._files:
            yield from f.messages(topics, start_time_ns)

    def time_range_ns(self):
        """Return ``(first, last)`` log time [ns] over the bag, or ``(None, None)`` if empty."""
        first = last = None
        for msg in self.messages():
            first = msg.log_time_ns if first is None else min(first, msg.log_time_ns)
            last = msg.log_time_ns if last is None else max(last, msg.log_time_ns)
        return first, last


__all__ = ['BagError', 'BagMessage', 'BagReader', 'RecoveryReport', 'TopicInfo']

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
import io
from pathlib import Path
import struct
from typing import Dict, Iterable, Iterator, List, Optional, Tuple, Union
import zlib

from mcap.data_stream import ReadDataStream
from mcap.exceptions import McapError
from mcap.reader import make_reader
from mcap.records import Footer

from .errors import (BagError, BagNotFoundError, DamagedBagError, NotMcapError,
                     TruncatedBagError, UnknownTypeError)
from .metadata import bag_file_paths, METADATA_FILE, read_metadata_yaml
from .recovery import check_indexed, iter_span_messages, RecoveryReport, scan

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
    """
    One storage file, every chunk checked when it is opened.

    A complete file with an intact summary whose chunks all pass their checks is read through
    mcap's indexed reader (log-time order across chunks). Otherwise (no usable summary, or a
    damaged chunk) the intact chunks are read one by one and :attr:`recovery` says what was
    lost.
    """

    def __init__(self, path: Path, expected: Optional['_Expected'] = None) -> None:
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
        summary, profile = self._read_summary(size) if complete else (None, None)
        if summary is not None:
            found = check_indexed(path, summary)
            if not found.damage:
                self.schemas, self.channels = summary.schemas, summary.channels
                self.counts = found.message_counts
                self.profile = profile
                return
            self.profile = profile
        else:
            found = scan(path)
            if found.header is None and not found.spans:
                damage = found.damage[0] if found.damage else None
                where = f' (damaged at byte {damage.offset}: {damage.reason})' \
                    if damage and damage.offset > len(MCAP_MAGIC) else ''
                raise TruncatedBagError(path, f'file is cut off after {size} bytes, before the '
                                              f'MCAP header{where}; nothing to recover')
            self.profile = found.header.profile if found.header else ''
        self.schemas, self.channels = found.schemas, found.channels
        self.counts, self._spans = found.message_counts, found.data_spans
        self.recovery = _report(path, size, found, summary, expected)

    def _read_summary(self, size: int):
        """
        Return ``(summary, header profile)``, or ``(None, None)`` without a usable summary.

        A summary counts only if its CRC (when the writer stored one) matches and it lists
        chunk indexes for all its messages.
        """
        try:
            with open(self.path, 'rb') as f:
                reader = make_reader(f, validate_crcs=True)
                f.seek(size - _FOOTER_AND_MAGIC + 9)
                footer = Footer.read(ReadDataStream(io.BytesIO(f.read(20))))
                if not len(MCAP_MAGIC) < footer.summary_start < size - _FOOTER_AND_MAGIC:
                    return None, None
                if footer.summary_crc:
                    f.seek(footer.summary_start)
                    covered = f.read(size - footer.summary_start - len(MCAP_MAGIC) - 4)
                    if zlib.crc32(covered) != footer.summary_crc:
                        return None, None
                summary = reader.get_summary()
                profile = reader.get_header().profile
        except (McapError, ValueError, OSError, EOFError, KeyError, struct.error,
                OverflowError, MemoryError, RecursionError, UnicodeDecodeError):
            return None, None
        if summary is None:
            return None, None
        stats = summary.statistics
        if stats is not None and stats.message_count and not summary.chunk_indexes:
            return None, None  # unchunked messages: find them by scanning
        return summary, profile

    def messages(self, topics: Optional[Iterable[str]],
                 start_time_ns: Optional[int]) -> Iterator[BagMessage]:
        wanted = None if topics is None else set(topics)
        by_id = {cid: ch.topic for cid, ch in self.channels.items()}
        if self._spans is not None:
            source = iter_span_messages(self.path, self._spans)
        else:
            source = self._indexed(wanted, start_time_ns)
        try:
            for msg in source:
                topic = by_id.get(msg.channel_id)
                if topic is None or (wanted is not None and topic not in wanted):
                    continue
                if start_time_ns is not None and msg.log_time < start_time_ns:
                    continue
                yield BagMessage(topic, msg.data, msg.log_time, msg.publish_time)
        except (McapError, ValueError, OSError, EOFError, KeyError, struct.error,
                OverflowError, MemoryError, RecursionError) as err:
            # The chunks were checked when the file was opened: it changed since.
            raise DamagedBagError(self.path, f'cannot read a chunk checked at open ({err}); '
                                             'was the file changed?') from None

    def _indexed(self, wanted, start_time_ns):
        with open(self.path, 'rb') as f:
            reader = make_reader(f, validate_crcs=True)
            for _, _, msg in reader.iter_messages(topics=None if wanted is None else list(wanted),
                                                  starting_at=start_time_ns,
                                                  log_time_order=True):
                yield msg


@dataclass
class _Expected:
    """Message counts ``metadata.yaml`` gives for one file (total, and per topic if known)."""

    total: int
    by_topic: Optional[Dict[str, int]] = None
    end_ns: Optional[int] = None


def _report(path: Path, size: int, found, summary, expected: Optional[_Expected]):
    """Build the loss report of a damaged or unfinished file (see RecoveryReport)."""
    topic_of = {cid: ch.topic for cid, ch in found.channels.items()}
    recovered: Dict[str, int] = {}
    for cid, n in found.message_counts.items():
        recovered[topic_of[cid]] = recovered.get(topic_of[cid], 0) + n
    total = sum(recovered.values())
    exact, by_topic, lost = False, {}, found.partial_messages + found.orphan_messages
    stats = summary.statistics if summary is not None else None
    if stats is not None:
        want: Dict[str, int] = {}
        for cid, n in stats.channel_message_counts.items():
            topic = summary.channels[cid].topic if cid in summary.channels else f'channel {cid}'
            want[topic] = want.get(topic, 0) + n
        expected = _Expected(sum(want.values()), want)
    elif not found.damage and found.data_complete:
        expected = _Expected(total, dict(recovered))
    if expected is not None and expected.by_topic is not None and all(
            expected.by_topic.get(t, 0) >= n for t, n in recovered.items()) and \
            sum(expected.by_topic.values()) == expected.total:
        by_topic = {t: n - recovered.get(t, 0) for t, n in expected.by_topic.items()}
        lost, exact = sum(by_topic.values()), True
    elif expected is not None and expected.total >= total:
        lost, exact = expected.total - total, True
    spans = sorted((s for s in found.spans if s.start_ns is not None),
                   key=lambda s: s.offset)
    first = min((s.start_ns for s in spans), default=None)
    intervals = []
    if lost:
        for d in found.damage:
            before = [s.end_ns for s in spans if s.offset < d.offset]
            after = [s.start_ns for s in spans if s.offset > d.offset]
            a = d.start_ns if d.start_ns is not None else max(before, default=first)
            b = d.end_ns if d.end_ns is not None else min(
                after, default=expected.end_ns if expected is not None else None)
            if a is not None and b is not None and b >= a:
                intervals.append((a, b))
    lost_bytes = sum(d.length for d in found.damage)
    return RecoveryReport(
        path=path, file_size=size, recovered_bytes=size - lost_bytes, recovered_messages=total,
        lost_messages=lost, last_log_time_ns=max((s.end_ns for s in spans), default=None),
        lost_exact=exact, lost_by_topic={t: n for t, n in by_topic.items() if n},
        lost_intervals_ns=intervals, damage=list(found.damage),
        has_summary=summary is not None, first_log_time_ns=first)


def _bag_files(path: Path):
    """
    Resolve a bag path (directory or .mcap file) to its storage files, in order.

    :return: ``[(file, expected counts from metadata.yaml or None), ...]``.
    """
    if not path.exists():
        raise BagNotFoundError(path, 'no such file or directory')
    if path.is_file():
        return [(path, None)]
    meta = path / METADATA_FILE
    if meta.is_file():
        info = read_metadata_yaml(meta)
        files = bag_file_paths(path, info, meta)
        missing = [f.name for f in files if not f.is_file()]
        if missing:
            raise BagNotFoundError(path, f'metadata.yaml lists missing files: {missing}')
        if files:
            return list(zip(files, _expected_counts(info, len(files))))

    def split_index(p: Path) -> Tuple[int, str]:
        tail = p.stem.rsplit('_', 1)[-1]
        return (int(tail) if tail.isdigit() else -1, p.name)

    files = sorted(path.glob('*.mcap'), key=split_index)
    if not files:
        raise BagNotFoundError(path, 'directory holds no .mcap file')
    return [(f, None) for f in files]


def _expected_counts(info, n_files: int) -> List[Optional[_Expected]]:
    """Per-file message counts from (schema-checked) metadata; per topic for one file."""
    files = info.get('files')
    if not files or [f['path'] for f in files] != info.get('relative_file_paths'):
        return [None] * n_files  # counts that cannot be matched to the files are not used
    out = [_Expected(f['message_count'], None, f['starting_time']['nanoseconds_since_epoch']
                     + f['duration']['nanoseconds']) for f in files]
    topics = info.get('topics_with_message_count')
    if n_files == 1 and topics is not None:
        by_topic: Dict[str, int] = {}
        for t in topics:
            name = t['topic_metadata']['name']
            by_topic[name] = by_topic.get(name, 0) + t['message_count']
        out[0].by_topic = by_topic
    return out


class BagReader:
    """
    Read an MCAP bag directory or file.

    :param path: Bag directory (rosbag2 layout) or a single ``.mcap`` file.
    :raises BagNotFoundError: The path does not exist or holds no .mcap file.
    :raises NotMcapError: A file is not MCAP.
    :raises TruncatedBagError: A file is empty or cut before its header.
    :raises BagError: ``metadata.yaml`` is not valid (paths out of the bag, wrong types).

    Every chunk is decompressed and its CRC checked when the bag is opened; damaged chunks are
    skipped and reported in :attr:`recoveries` like the cut-off end of an unfinished file.
    :raises UnknownTypeError: One topic is stored with two different types.
    """

    def __init__(self, path: Union[str, Path]) -> None:
        self.path = Path(path)
        self._files = [_McapFile(p, expected) for p, expected in _bag_files(self.path)]
        self.topics: Dict[str, TopicInfo] = {}
        for f in self._files:
            self._collect_topics(f)

    def _collect_topics(self, f: _McapFile) -> None:
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

    def time_range_ns(self) -> Tuple[Optional[int], Optional[int]]:
        """Return ``(first, last)`` log time [ns] over the bag, or ``(None, None)`` if empty."""
        first = last = None
        for msg in self.messages():
            first = msg.log_time_ns if first is None else min(first, msg.log_time_ns)
            last = msg.log_time_ns if last is None else max(last, msg.log_time_ns)
        return first, last


__all__ = ['BagError', 'BagMessage', 'BagReader', 'RecoveryReport', 'TopicInfo']

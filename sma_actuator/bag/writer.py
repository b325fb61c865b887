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
BagWriter: serialized ROS 2 messages into a rosbag2-compatible MCAP bag directory.

A bag is a directory ``<dir>/`` holding ``<dir name>_0.mcap`` (``_1``, ``_2``... after a split)
and, once closed, ``metadata.yaml`` (rosbag2 Jazzy format), so ``ros2 bag info/play <dir>``,
``ros2 bag play <dir>/<file>.mcap``, Foxglove and PlotJuggler open it. Each MCAP file follows
rosbag2_storage_mcap: profile ``ros2``, one ``ros2msg`` schema per type with the full
definition text, ``cdr`` channels with ``offered_qos_profiles`` and ``topic_type_hash``
metadata, chunked + indexed, a ``rosbag2`` metadata record, summary with statistics.

Crash safety: a chunk is closed and handed to the OS when it reaches ``chunk_size_bytes`` or is
``chunk_max_age_s`` old (checked on every write and on :meth:`BagWriter.flush_if_due`), so after
a SIGKILL the file is readable (``BagReader``) up to the last closed chunk.

The writer is thread-safe (one lock) and ROS-free: callers pass bytes already in CDR.
"""
import contextlib
import copy
from pathlib import Path
import threading
import time
from typing import Dict, List, Optional, Union

from mcap.writer import CompressionType, Writer

from .errors import BagExistsError, BagWriteError
from .metadata import (
    BagRecord,
    dump_serialized_metadata,
    FileRecord,
    METADATA_FILE,
    TopicRecord,
    write_metadata_yaml,
)
from .msgdefs import message_definition, normalize_type_name, type_description_hash
from .qos import dump_offered_qos_profiles
from .. import __version__

COMPRESSIONS = {'zstd': CompressionType.ZSTD, 'lz4': CompressionType.LZ4,
                'none': CompressionType.NONE}
LIBRARY = f'sma_actuator-bag/{__version__}'
# mcap's own size trigger is disabled; this class decides when a chunk ends (see flush()).
_NEVER = 1 << 62
_RECORD_OVERHEAD_BYTES = 31  # opcode + length + Message fields around the payload
#: Smallest max_file_size_bytes (0 = no size split): below it a file's fixed part (header,
#: schemas with full definitions, summary, metadata: a few KiB) dominates and a recorder
#: would split on nearly every message.
MIN_FILE_SIZE_BYTES = 64 * 1024


def storage_file_name(bag_dir: Union[str, Path], index: int) -> str:
    """Return rosbag2's name of the ``index``-th storage file of a bag directory."""
    return f'{Path(bag_dir).name}_{index}.mcap'


def existing_bag_files(bag_dir: Path) -> List[Path]:
    """Return files in ``bag_dir`` that belong to a bag (``metadata.yaml``, ``*.mcap``)."""
    if not bag_dir.is_dir():
        return []
    return sorted(p for p in bag_dir.iterdir()
                  if p.name == METADATA_FILE or p.suffix == '.mcap')


class _TopicSpec:
    """What the bag stores about one topic."""

    def __init__(self, name, type_name, qos_yaml, type_hash, definition, encoding) -> None:
        self.record = TopicRecord(name=name, type=type_name, offered_qos_profiles=qos_yaml,
                                  type_description_hash=type_hash,
                                  serialization_format=encoding)
        self.definition = definition


class _StorageFile:
    """One open MCAP file of the bag, with its schema/channel ids and statistics."""

    def __init__(self, path: Path, compression: CompressionType) -> None:
        # 'xb': never replace a file that appeared since the existence check.
        self.stream = open(path, 'xb')
        self.mcap = Writer(self.stream, chunk_size=_NEVER, compression=compression)
        self.mcap.start(profile='ros2', library=LIBRARY)
        # Magic + header reach the OS at once: a file killed before its first chunk is then
        # still recognisable as an (empty) MCAP recording, not a 0-byte file.
        self.stream.flush()
        self.record = FileRecord(path=path.name)
        self.schema_ids: Dict[str, int] = {}
        self.channel_ids: Dict[str, int] = {}
        self.sequence: Dict[str, int] = {}
        self.end_ns = 0
        self.bytes_written = 8  # magic
        self.pending_bytes = 0
        self.chunk_started = None  # monotonic [s] of the first message in the open chunk

    def add_topic(self, spec: _TopicSpec) -> None:
        rec = spec.record
        if rec.type not in self.schema_ids:
            self.schema_ids[rec.type] = self.mcap.register_schema(
                name=rec.type, encoding='ros2msg', data=spec.definition.encode('utf-8'))
        self.channel_ids[rec.name] = self.mcap.register_channel(
            topic=rec.name, message_encoding=rec.serialization_format,
            schema_id=self.schema_ids[rec.type],
            metadata={'offered_qos_profiles': rec.offered_qos_profiles,
                      'topic_type_hash': rec.type_description_hash})
        self.sequence[rec.name] = 0

    def write(self, topic, data, log_time_ns, publish_time_ns) -> None:
        self.sequence[topic] = (self.sequence[topic] + 1) & 0xFFFFFFFF
        self.mcap.add_message(channel_id=self.channel_ids[topic], log_time=log_time_ns,
                              data=data, publish_time=publish_time_ns,
                              sequence=self.sequence[topic])
        rec = self.record
        if rec.message_count == 0:
            rec.starting_time_ns = self.end_ns = log_time_ns
        rec.starting_time_ns = min(rec.starting_time_ns, log_time_ns)
        self.end_ns = max(self.end_ns, log_time_ns)
        rec.duration_ns = self.end_ns - rec.starting_time_ns
        rec.message_count += 1
        self.pending_bytes += len(data) + len(topic) + _RECORD_OVERHEAD_BYTES
        if self.chunk_started is None:
            self.chunk_started = time.monotonic()

    def flush(self) -> None:
        """Close the open chunk (if any) and pass everything to the OS."""
        self.mcap.flush()
        self.bytes_written = self.stream.tell()
        self.pending_bytes = 0
        self.chunk_started = None

    def close(self, serialized_metadata: str) -> None:
        self.mcap.add_metadata('rosbag2', {'serialized_metadata': serialized_metadata})
        self.mcap.finish()
        self.bytes_written = self.stream.tell()
        self.stream.close()


class BagWriter:
    """
    Write a rosbag2 bag directory of MCAP files from serialized (CDR) messages.

    Usage::

        with BagWriter('runs/step1/bag') as bag:
            bag.add_topic('/sma/duty', 'std_msgs/msg/Float64MultiArray', [offered_qos])
            bag.write('/sma/duty', cdr_bytes, log_time_ns, publish_time_ns)

    :param path: Bag directory to create (may exist if it holds no bag yet).
    :param compression: Chunk compression, ``'zstd'``, ``'lz4'`` or ``'none'``.
    :param chunk_size_bytes: A chunk is closed once it holds about this many bytes.
    :param chunk_max_age_s: ... or once its first message is this old [s] (bounds the data
        lost on SIGKILL); 0 disables the age limit.
    :param max_file_size_bytes: Start a new ``_N.mcap`` file past this size; 0 = never.
    :param max_file_duration_s: Start a new file past this span of log time [s]; 0 = never.
    :param overwrite: Replace an existing bag in ``path``: its ``metadata.yaml`` and ``*.mcap``
        files are deleted, other files are kept (without it: BagExistsError).
    :param ros_distro: Distro recorded in the metadata (default ``$ROS_DISTRO`` or jazzy).
    :raises BagExistsError: ``path`` already holds a bag (or is a file) and not ``overwrite``.
    :raises ValueError: An option is out of range.
    """

    def __init__(self, path: Union[str, Path], *, compression: str = 'zstd',
                 chunk_size_bytes: int = 256 * 1024, chunk_max_age_s: float = 1.0,
                 max_file_size_bytes: int = 0, max_file_duration_s: float = 0.0,
                 overwrite: bool = False, ros_distro: Optional[str] = None) -> None:
        if compression not in COMPRESSIONS:
            raise ValueError(f"compression '{compression}' is not one of {sorted(COMPRESSIONS)}")
        if chunk_size_bytes <= 0 or chunk_max_age_s < 0:
            raise ValueError('chunk_size_bytes must be > 0 and chunk_max_age_s >= 0')
        if max_file_size_bytes < 0 or max_file_duration_s < 0:
            raise ValueError('max_file_size_bytes and max_file_duration_s must be >= 0')
        if 0 < max_file_size_bytes < MIN_FILE_SIZE_BYTES:
            raise ValueError(f'max_file_size_bytes={max_file_size_bytes} is below the minimum '
                             f'{MIN_FILE_SIZE_BYTES} bytes (64 KiB); 0 means no size split')
        self.path = Path(path)
        self._failed = None   # the OSError that stopped writing, if any
        try:
            self._prepare_directory(overwrite)
        except OSError as err:
            raise BagWriteError(self.path, f'cannot create the bag: {_reason(err)}') from err
        self._compression = COMPRESSIONS[compression]
        self._chunk_size = int(chunk_size_bytes)
        self._chunk_max_age_s = float(chunk_max_age_s)
        self._max_file_size = int(max_file_size_bytes)
        self._max_file_duration_ns = int(max_file_duration_s * 1e9)
        self._bag = BagRecord()
        if ros_distro:
            self._bag.ros_distro = ros_distro
        self._topics: Dict[str, _TopicSpec] = {}
        self._lock = threading.Lock()
        self._closed = False
        try:
            self._file = self._open_file(0)
        except OSError as err:
            raise BagWriteError(self.path, f'cannot create the bag: {_reason(err)}') from err

    def _prepare_directory(self, overwrite: bool) -> None:
        if self.path.exists() and not self.path.is_dir():
            raise BagExistsError(self.path, 'exists and is not a directory; not replacing it')
        existing = existing_bag_files(self.path)
        if existing and not overwrite:
            raise BagExistsError(
                self.path, f'already holds a bag ({", ".join(p.name for p in existing)}); '
                'choose another name or set overwrite')
        for old in existing:
            old.unlink()
        self.path.mkdir(parents=True, exist_ok=True)

    def _open_file(self, index: int) -> _StorageFile:
        storage = _StorageFile(self.path / storage_file_name(self.path, index), self._compression)
        self._bag.files.append(storage.record)
        for spec in self._topics.values():
            storage.add_topic(spec)
        return storage

    # -- public API -------------------------------------------------------------------------

    @property
    def files(self) -> List[Path]:
        """Paths of the storage files written so far."""
        return [self.path / f.path for f in self._bag.files]

    @property
    def topics(self) -> Dict[str, TopicRecord]:
        """Topics added so far, with their message counts."""
        return {name: spec.record for name, spec in self._topics.items()}

    @property
    def message_count(self) -> int:
        """Messages written so far (all files)."""
        return sum(f.message_count for f in self._bag.files)

    @property
    def bytes_on_disk(self) -> int:
        """Bytes handed to the OS so far (all files; the open chunk is not counted)."""
        closed = sum((self.path / f.path).stat().st_size for f in self._bag.files[:-1])
        return closed + self._file.bytes_written

    def add_topic(self, name: str, type_name: str, offered_qos_profiles=None, *,
                  type_hash: Optional[str] = None, definition: Optional[str] = None,
                  serialization_format: str = 'cdr') -> None:
        """
        Declare a topic before writing to it.

        :param name: Topic name, e.g. ``/sma/duty``.
        :param type_name: ``pkg/msg/Type``.
        :param offered_qos_profiles: QoS profiles offered by the publishers (rclpy QoSProfile
            objects or rosbag2 dicts), or the rosbag2 YAML text itself; None = unknown.
        :param type_hash: ``RIHS01_...``; default: from the installed type description.
        :param definition: Full ``ros2msg`` text; default: built from the installed .msg files.
        :raises UnknownTypeError: The type is not installed and no definition/hash was given.
        :raises BagWriteError: The topic was already added with another type, or writer closed.
        """
        type_name = normalize_type_name(type_name)
        if isinstance(offered_qos_profiles, str):
            qos_yaml = offered_qos_profiles
        else:
            qos_yaml = dump_offered_qos_profiles(list(offered_qos_profiles or []))
        spec = _TopicSpec(name, type_name, qos_yaml,
                          type_hash if type_hash is not None else type_description_hash(type_name),
                          definition if definition is not None else message_definition(type_name),
                          serialization_format)
        with self._lock:
            self._check_open()
            known = self._topics.get(name)
            if known is not None:
                if known.record.type != type_name:
                    raise BagWriteError(self.path, f"topic '{name}' already added with type "
                                                   f"'{known.record.type}', not '{type_name}'")
                return
            self._topics[name] = spec
            self._bag.topics.append(spec.record)
            self._file.add_topic(spec)

    def write(self, topic: str, data: bytes, log_time_ns: int,
              publish_time_ns: Optional[int] = None) -> None:
        """
        Write one serialized message.

        :param topic: A topic declared with :meth:`add_topic`.
        :param data: The CDR bytes, stored unchanged.
        :param log_time_ns: Receive time [ns since epoch] (MCAP log time; rosbag2 recv time).
        :param publish_time_ns: Source send time [ns]; default = ``log_time_ns``.
        :raises BagWriteError: Unknown topic, negative time, or writer closed.
        """
        with self._lock:
            self._check_open()
            spec = self._topics.get(topic)
            if spec is None:
                raise BagWriteError(self.path, f"topic '{topic}' was not added before writing")
            if log_time_ns < 0:
                raise BagWriteError(self.path, f"negative log time {log_time_ns} on '{topic}'")
            with self._io():
                if self._split_due(log_time_ns):
                    self._split()
                publish = log_time_ns if publish_time_ns is None else publish_time_ns
                self._file.write(topic, data, int(log_time_ns), int(publish))
                spec.record.message_count += 1
                self._flush_if_due_locked()

    def flush(self) -> None:
        """Close the open chunk and hand all data to the OS (it survives a crash after this)."""
        with self._lock:
            if not self._closed:
                self._check_open()
                with self._io():
                    self._file.flush()

    def flush_if_due(self) -> None:
        """Close the open chunk if it is older than ``chunk_max_age_s`` (call periodically)."""
        with self._lock:
            if not self._closed:
                self._check_open()
                with self._io():
                    self._flush_if_due_locked()

    def close(self) -> BagRecord:
        """
        Finish the open file (summary, index) and write ``metadata.yaml``; idempotent.

        :return: The bag's metadata (files, topics and counts).
        """
        with self._lock:
            if not self._closed:
                self._closed = True
                if self._failed is not None:
                    self._close_after_failure()
                else:
                    with self._io():
                        self._file.close(self._file_metadata())
                        write_metadata_yaml(self.path, self._bag)
            return self._bag

    @property
    def failed(self) -> Optional[BagWriteError]:
        """Return the error that stopped writing (full disk, file size limit...), or None."""
        return self._failed

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # -- internals ----------------------------------------------------------------------------

    def _check_open(self) -> None:
        if self._failed is not None:
            raise self._failed
        if self._closed:
            raise BagWriteError(self.path, 'bag writer is already closed')

    @contextlib.contextmanager
    def _io(self):
        """Turn an OSError (no space, file too large, I/O error) into a lasting BagWriteError."""
        try:
            yield
        except OSError as err:
            self._failed = BagWriteError(self.path, f'cannot write: {_reason(err)}')
            raise self._failed from err

    def _close_after_failure(self) -> None:
        """Close what can be closed after a write failure; what was flushed stays readable."""
        try:
            self._file.stream.close()
        except OSError:
            pass   # the unflushed tail is lost; the reader recovers the closed chunks
        try:
            write_metadata_yaml(self.path, self._bag)
        except OSError:
            pass   # no space even for metadata.yaml: the reader works without it

    def _file_metadata(self) -> str:
        """
        Return the rosbag2 metadata embedded in the open file: this file only.

        One file's record, not the whole bag's, so a split costs the same however many
        files came before (metadata.yaml, written at close, lists them all).
        """
        record = copy.copy(self._bag)
        record.files = [self._file.record]
        return dump_serialized_metadata(record)

    def _flush_if_due_locked(self) -> None:
        f = self._file
        if f.chunk_started is None:
            return
        too_big = f.pending_bytes >= self._chunk_size
        too_old = self._chunk_max_age_s and (
            time.monotonic() - f.chunk_started >= self._chunk_max_age_s)
        if too_big or too_old:
            f.flush()

    def _split_due(self, log_time_ns: int) -> bool:
        f = self._file
        if f.record.message_count == 0:
            return False
        if self._max_file_size and f.bytes_written + f.pending_bytes >= self._max_file_size:
            return True
        return bool(self._max_file_duration_ns) and (
            log_time_ns - f.record.starting_time_ns >= self._max_file_duration_ns)

    def _split(self) -> None:
        self._file.close(self._file_metadata())
        self._file = self._open_file(len(self._bag.files))


def _reason(err: OSError) -> str:
    """Return the one-line reason of an OSError ('No space left on device')."""
    return err.strerror or str(err)

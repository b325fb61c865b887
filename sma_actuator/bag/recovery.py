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
Recover an MCAP file that has no summary/footer (recorder killed, disk full, cut copy).

The file is scanned record by record from the start. Every complete record is kept; a chunk
counts only if it decompresses and its CRC matches. Scanning stops at the first incomplete or
damaged record; everything from there on is reported as lost. The cut-off record is decoded as far
as its bytes go to count the messages it held, a lower bound of what was lost: messages the
writer still held in memory when it died never reached the file and cannot be counted.
"""
from dataclasses import dataclass, field
import io
from pathlib import Path
import struct
from typing import Dict, Iterator, List, Optional, Tuple

from mcap.data_stream import ReadDataStream
from mcap.exceptions import McapError
from mcap.opcode import Opcode
from mcap.records import Channel, Chunk, Header, Message, Schema
from mcap.stream_reader import breakup_chunk

_RECORD_HEAD = struct.Struct('<BQ')  # opcode, body length
_MAGIC_SIZE = 8


@dataclass
class RecoveryReport:
    """
    What a recovery scan kept and lost in one file.

    :ivar file_size: Bytes in the file.
    :ivar recovered_bytes: Bytes up to the end of the last complete, valid record (the whole
        file if the data section is complete and only the summary is cut).
    :ivar recovered_messages: Messages in the kept part.
    :ivar lost_messages: Messages found in the cut-off tail (lower bound, see module doc).
    :ivar last_log_time_ns: Log time of the last recovered message (None if none).
    """

    path: Path
    file_size: int
    recovered_bytes: int
    recovered_messages: int
    lost_messages: int
    last_log_time_ns: Optional[int]

    @property
    def lost_bytes(self) -> int:
        """Bytes after the last complete record (cut or damaged data)."""
        return self.file_size - self.recovered_bytes

    def __str__(self) -> str:
        return (f'{self.path}: no summary (recording did not finish); recovered '
                f'{self.recovered_messages} messages in {self.recovered_bytes} of '
                f'{self.file_size} bytes; lost {self.lost_bytes} bytes holding at least '
                f'{self.lost_messages} messages')


@dataclass
class ScanResult:
    """Schemas, channels and data records found by :func:`scan`."""

    header: Optional[Header] = None
    schemas: Dict[int, Schema] = field(default_factory=dict)
    channels: Dict[int, Channel] = field(default_factory=dict)
    message_counts: Dict[int, int] = field(default_factory=dict)
    start_time_ns: Optional[int] = None
    end_time_ns: Optional[int] = None
    data_spans: List[Tuple[int, int]] = field(default_factory=list)  # (offset, length)
    report: Optional[RecoveryReport] = None


def _parse(record_type, body: bytes, length: int = 0):
    """Parse one record body; raise ValueError if it is damaged."""
    stream = ReadDataStream(io.BytesIO(body))
    try:
        if record_type is Message:
            return record_type.read(stream, length)
        return record_type.read(stream)
    except (McapError, struct.error, UnicodeDecodeError) as err:
        raise ValueError(f'damaged {record_type.__name__} record: {err}') from err


def _records_in_chunk(chunk: Chunk) -> list:
    """Decompress a chunk and check its CRC; raise ValueError if it is damaged."""
    try:
        return breakup_chunk(chunk, validate_crc=True)
    except Exception as err:  # noqa: BLE001 - zstd/lz4/CRC/parse errors all mean "damaged"
        raise ValueError(f'damaged chunk: {err}') from err


def _count_messages(data: bytes) -> int:
    """Count complete Message records at the start of (possibly cut) record data."""
    count, pos = 0, 0
    while pos + _RECORD_HEAD.size <= len(data):
        opcode, length = _RECORD_HEAD.unpack_from(data, pos)
        pos += _RECORD_HEAD.size + length
        if pos > len(data):
            break
        count += opcode == Opcode.MESSAGE
    return count


def _messages_in_partial_chunk(body: bytes) -> int:
    """Count messages decodable from the first bytes of a cut-off Chunk record body."""
    try:
        compression_len = struct.unpack_from('<I', body, 28)[0]
        compression = body[32:32 + compression_len].decode()
        data = body[32 + compression_len + 8:]
        if compression == 'zstd':
            import zstandard
            data = zstandard.ZstdDecompressor().decompressobj().decompress(data)
        elif compression == 'lz4':
            import lz4.frame
            data = lz4.frame.LZ4FrameDecompressor().decompress(data)
        return _count_messages(data)
    except Exception:  # noqa: BLE001 - a cut stream can fail anywhere; count what we have
        return 0


def _note_messages(result: ScanResult, records) -> int:
    count = 0
    for rec in records:
        if isinstance(rec, Schema):
            result.schemas[rec.id] = rec
        elif isinstance(rec, Channel):
            result.channels[rec.id] = rec
        elif isinstance(rec, Message):
            count += 1
            result.message_counts[rec.channel_id] = result.message_counts.get(rec.channel_id,
                                                                              0) + 1
            t = rec.log_time
            result.start_time_ns = t if result.start_time_ns is None else min(
                result.start_time_ns, t)
            result.end_time_ns = t if result.end_time_ns is None else max(result.end_time_ns, t)
    return count


def scan(path: Path) -> ScanResult:
    """
    Scan an MCAP file without relying on its summary (the magic is assumed checked).

    :return: What was found; ``result.report`` says what was kept and lost.
    """
    path = Path(path)
    size = path.stat().st_size
    result = ScanResult()
    recovered = lost = 0
    last_time = None
    with open(path, 'rb') as f:
        f.seek(_MAGIC_SIZE)
        pos = good_end = _MAGIC_SIZE
        while True:
            head = f.read(_RECORD_HEAD.size)
            if len(head) < _RECORD_HEAD.size:
                break
            opcode, length = _RECORD_HEAD.unpack(head)
            body = f.read(min(length, size - pos - _RECORD_HEAD.size))
            if len(body) < length:  # cut off here
                if opcode == Opcode.CHUNK:
                    lost += _messages_in_partial_chunk(body)
                lost += opcode == Opcode.MESSAGE
                break
            try:
                if opcode == Opcode.HEADER:
                    result.header = _parse(Header, body)
                elif opcode in (Opcode.SCHEMA, Opcode.CHANNEL):
                    _note_messages(result, [_parse(Schema if opcode == Opcode.SCHEMA
                                                   else Channel, body)])
                elif opcode in (Opcode.CHUNK, Opcode.MESSAGE):
                    records = (_records_in_chunk(_parse(Chunk, body)) if opcode == Opcode.CHUNK
                               else [_parse(Message, body, length)])
                    recovered += _note_messages(result, records)
                    result.data_spans.append((pos, _RECORD_HEAD.size + length))
                    last_time = result.end_time_ns
            except ValueError:
                if opcode == Opcode.CHUNK:
                    lost += _messages_in_partial_chunk(body)
                break
            pos += _RECORD_HEAD.size + length
            good_end = pos
            if opcode in (Opcode.DATA_END, Opcode.FOOTER):
                # All data is there; only the summary (indexes, statistics) is cut, and the
                # scan has rebuilt what it held.
                good_end = size
                break
    result.report = RecoveryReport(path, size, good_end, recovered, lost, last_time)
    return result


def iter_span_messages(path: Path, spans: List[Tuple[int, int]]) -> Iterator[Message]:
    """Yield the messages of the given Chunk/Message records, log-time sorted per record."""
    with open(path, 'rb') as f:
        for offset, length in spans:
            f.seek(offset)
            raw = f.read(length)
            opcode, body_len = _RECORD_HEAD.unpack_from(raw)
            body = raw[_RECORD_HEAD.size:]
            if opcode == Opcode.CHUNK:
                records = _records_in_chunk(_parse(Chunk, body))
            else:
                records = [_parse(Message, body, body_len)]
            yield from sorted((r for r in records if isinstance(r, Message)),
                              key=lambda m: m.log_time)

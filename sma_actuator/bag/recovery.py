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
Check and recover MCAP files: every chunk is decompressed and its CRC checked before use.

Two ways to find the chunks of a file:

- :func:`check_indexed`: a complete file whose summary is intact (summary CRC checked) lists
  its chunks in the summary's chunk index; each one is read and checked;
- :func:`scan`: a file without a usable summary (recorder killed, disk full, cut copy, damaged
  summary) is walked record by record from the start. A record that does not parse, a chunk
  that does not decompress or fails its CRC, or a length pointing past the end is damage: the
  scan looks for the next chunk that passes its checks (resynchronises) and goes on from there.

Damaged chunks are skipped, the others kept. What was lost is reported in
:class:`RecoveryReport` (bytes, messages, per topic and seconds where the counts are known:
from the summary statistics, or from ``metadata.yaml``; otherwise a lower bound).

All sizes read from the file are checked against the file and chunk sizes before anything is
allocated, and decompression is bounded by the chunk's declared size.
"""
from dataclasses import dataclass, field
import io
import mmap
from pathlib import Path
import struct
from typing import Dict, Iterator, List, Optional, Tuple
import zlib

import lz4.frame
from mcap.data_stream import ReadDataStream
from mcap.exceptions import McapError
from mcap.opcode import Opcode
from mcap.records import (Attachment, Channel, Chunk, DataEnd, Header, Message, MessageIndex,
                          Metadata, Schema)
from mcap.stream_reader import breakup_chunk
import zstandard

_RECORD_HEAD = struct.Struct('<BQ')  # opcode, body length
_CHUNK_FIXED = struct.Struct('<QQQII')  # start, end, uncompressed size, CRC, compression length
_MAGIC_SIZE = 8
#: Largest uncompressed chunk accepted [bytes]; writers use 256 KiB to a few MiB.
MAX_CHUNK_BYTES = 1 << 30
_READ_STEP = 1 << 20
_DATA_RECORDS = {Opcode.MESSAGE_INDEX: MessageIndex, Opcode.METADATA: Metadata,
                 Opcode.ATTACHMENT: Attachment}


class DamagedRecord(ValueError):
    """A record that does not parse or fails its check (message says why)."""


@dataclass
class Damage:
    """A damaged byte range of a file, why, and the log times it held when known [ns]."""

    offset: int
    length: int
    reason: str
    start_ns: Optional[int] = None
    end_ns: Optional[int] = None


@dataclass
class ChunkSpan:
    """An intact Chunk (or Message) record: where, and what it holds."""

    offset: int
    length: int
    counts: Dict[int, int]
    start_ns: Optional[int]
    end_ns: Optional[int]


@dataclass
class RecoveryReport:
    """
    What was kept and lost in one file that had no usable summary or damaged chunks.

    :ivar file_size: Bytes in the file.
    :ivar recovered_bytes: Bytes not counted as damaged or cut off.
    :ivar recovered_messages: Messages read back.
    :ivar lost_messages: Messages lost; exact when ``lost_exact``, else a lower bound.
    :ivar last_log_time_ns: Log time of the last recovered message (None if none).
    :ivar lost_exact: The loss is known exactly (from the summary or ``metadata.yaml``).
    :ivar lost_by_topic: Lost messages per topic, when known.
    :ivar lost_intervals_ns: Log-time intervals [ns] that lost messages (gaps in the data).
    :ivar damage: Damaged or cut-off byte ranges, with the reason.
    :ivar has_summary: The file's summary was intact (only chunks were damaged).
    """

    path: Path
    file_size: int
    recovered_bytes: int
    recovered_messages: int
    lost_messages: int
    last_log_time_ns: Optional[int]
    lost_exact: bool = False
    lost_by_topic: Dict[str, int] = field(default_factory=dict)
    lost_intervals_ns: List[Tuple[int, int]] = field(default_factory=list)
    damage: List[Damage] = field(default_factory=list)
    has_summary: bool = False
    first_log_time_ns: Optional[int] = None

    @property
    def lost_bytes(self) -> int:
        """Bytes damaged or cut off."""
        return self.file_size - self.recovered_bytes

    @property
    def lost_seconds(self) -> float:
        """Total length of the log-time intervals that lost messages [s]."""
        return sum(max(0, b - a) for a, b in self.lost_intervals_ns) * 1e-9

    def __str__(self) -> str:
        what = ('damaged chunks (summary intact)' if self.has_summary else
                'no summary (recording did not finish) or a damaged one')
        text = (f'{self.path}: {what}; recovered {self.recovered_messages} messages in '
                f'{self.recovered_bytes} of {self.file_size} bytes')
        if self.lost_messages or self.lost_exact:
            count = f'{self.lost_messages}' if self.lost_exact else \
                f'at least {self.lost_messages}'
            text += f'; lost {count} messages'
            if self.lost_by_topic:
                text += ' (' + ', '.join(f'{t} {n}' for t, n in
                                         sorted(self.lost_by_topic.items()) if n) + ')'
        else:
            text += '; lost an unknown number of messages' if self.lost_bytes else \
                '; no message lost'
        if self.lost_intervals_ns:
            origin = self.first_log_time_ns or self.lost_intervals_ns[0][0]
            spans = ', '.join(f'{(a - origin) * 1e-9:.3f} s to {(b - origin) * 1e-9:.3f} s'
                              for a, b in self.lost_intervals_ns[:3])
            text += f' over {self.lost_seconds:.3f} s of the recording ({spans} after ' \
                    'its first message)'
        if self.damage:
            text += '; damaged: ' + '; '.join(f'{d.length} bytes at byte {d.offset} '
                                              f'({d.reason})' for d in self.damage[:3])
            if len(self.damage) > 3:
                text += f'; and {len(self.damage) - 3} more'
        return text


@dataclass
class ScanResult:
    """Schemas, channels and intact data records found in a file."""

    header: Optional[Header] = None
    schemas: Dict[int, Schema] = field(default_factory=dict)
    channels: Dict[int, Channel] = field(default_factory=dict)
    spans: List[ChunkSpan] = field(default_factory=list)
    damage: List[Damage] = field(default_factory=list)
    partial_messages: int = 0   # messages decodable from a cut-off last chunk (lower bound)
    data_complete: bool = False  # the scan reached DataEnd/Footer

    @property
    def message_counts(self) -> Dict[int, int]:
        """Messages per channel id in the intact records (known channels only)."""
        counts: Dict[int, int] = {}
        for span in self.spans:
            for cid, n in span.counts.items():
                if cid in self.channels:
                    counts[cid] = counts.get(cid, 0) + n
        return counts

    @property
    def orphan_messages(self) -> int:
        """Intact messages whose channel record was lost (they cannot be read)."""
        return sum(n for s in self.spans for cid, n in s.counts.items()
                   if cid not in self.channels)

    @property
    def data_spans(self) -> List[Tuple[int, int]]:
        """(offset, length) of every intact data record."""
        return [(s.offset, s.length) for s in self.spans]


def _parse(record_type, body, length: int = 0):
    """Parse one record body; the record must use every byte; raise DamagedRecord if not."""
    raw = io.BytesIO(body)
    stream = ReadDataStream(raw)
    try:
        record = record_type.read(stream, length) if record_type is Message else \
            record_type.read(stream)
    except (McapError, struct.error, UnicodeDecodeError, ValueError, EOFError,
            OverflowError, MemoryError) as err:
        raise DamagedRecord(f'damaged {record_type.__name__} record ({err})') from None
    if raw.tell() != len(body):
        raise DamagedRecord(f'damaged {record_type.__name__} record ({len(body)} bytes, '
                            f'{raw.tell()} parsed)')
    return record


def _decompress(chunk: Chunk) -> bytes:
    """Decompress a chunk's records, never producing more than its declared size."""
    size = chunk.uncompressed_size
    if size > MAX_CHUNK_BYTES:
        raise DamagedRecord(f'chunk declares {size} uncompressed bytes (limit '
                            f'{MAX_CHUNK_BYTES})')
    try:
        if chunk.compression == '':
            data = chunk.data
        elif chunk.compression == 'zstd':
            reader = zstandard.ZstdDecompressor().stream_reader(chunk.data)
            parts, total = [], 0
            while total <= size:
                part = reader.read(min(_READ_STEP, size + 1 - total))
                if not part:
                    break
                parts.append(part)
                total += len(part)
            data = b''.join(parts)
        elif chunk.compression == 'lz4':
            data = lz4.frame.LZ4FrameDecompressor().decompress(chunk.data, max_length=size + 1)
        else:
            raise DamagedRecord(f"chunk with unknown compression '{chunk.compression[:20]}'")
    except (zstandard.ZstdError, RuntimeError, EOFError, ValueError, MemoryError) as err:
        if isinstance(err, DamagedRecord):
            raise
        raise DamagedRecord(f'{chunk.compression} data does not decompress ({err})') from None
    if len(data) != size:
        raise DamagedRecord(f'chunk decompresses to {len(data)} bytes, declares {size}')
    return data


def decode_chunk(body) -> Tuple[Chunk, list]:
    """Parse a Chunk record body, decompress it and check its CRC; return (chunk, records)."""
    chunk = _parse(Chunk, body)
    data = _decompress(chunk)
    if chunk.uncompressed_crc and zlib.crc32(data) != chunk.uncompressed_crc:
        raise DamagedRecord('chunk CRC mismatch')
    plain = Chunk(compression='', data=data, message_end_time=chunk.message_end_time,
                  message_start_time=chunk.message_start_time, uncompressed_crc=0,
                  uncompressed_size=len(data))
    try:
        records = breakup_chunk(plain)
    except (McapError, struct.error, UnicodeDecodeError, ValueError, EOFError, KeyError,
            OverflowError, MemoryError) as err:
        raise DamagedRecord(f'damaged records inside the chunk ({err})') from None
    return chunk, records


def _span(offset: int, length: int, records) -> ChunkSpan:
    counts: Dict[int, int] = {}
    times = [r.log_time for r in records if isinstance(r, Message)]
    for r in records:
        if isinstance(r, Message):
            counts[r.channel_id] = counts.get(r.channel_id, 0) + 1
    return ChunkSpan(offset, length, counts, min(times, default=None), max(times, default=None))


def _note_definitions(result: ScanResult, records) -> None:
    for rec in records:
        if isinstance(rec, Schema):
            result.schemas.setdefault(rec.id, rec)
        elif isinstance(rec, Channel):
            result.channels.setdefault(rec.id, rec)


def _chunk_candidate(mm, pos: int, size: int) -> Optional[int]:
    """Return the record length if a plausible Chunk record header starts at `pos`."""
    if pos + _RECORD_HEAD.size + _CHUNK_FIXED.size > size or mm[pos] != Opcode.CHUNK:
        return None
    _, length = _RECORD_HEAD.unpack_from(mm, pos)
    if pos + _RECORD_HEAD.size + length > size:
        return None
    start, end, _, _, clen = _CHUNK_FIXED.unpack_from(mm, pos + _RECORD_HEAD.size)
    if clen not in (0, 3, 4) or start > end:
        return None
    at = pos + _RECORD_HEAD.size + _CHUNK_FIXED.size
    if bytes(mm[at:at + clen]) not in (b'', b'lz4', b'zstd') or at + clen + 8 > size:
        return None
    (data_len,) = struct.unpack_from('<Q', mm, at + clen)
    if _CHUNK_FIXED.size + clen + 8 + data_len != length:
        return None
    return length


def _resync(mm, start: int, size: int):
    """Return (offset, length, chunk, records) of the next intact chunk after `start`."""
    pos = start
    while True:
        pos = mm.find(bytes([Opcode.CHUNK]), pos, size)
        if pos < 0:
            return None
        length = _chunk_candidate(mm, pos, size)
        if length is not None:
            body = mm[pos + _RECORD_HEAD.size:pos + _RECORD_HEAD.size + length]
            try:
                chunk, records = decode_chunk(body)
            except DamagedRecord:
                pass
            else:
                if chunk.uncompressed_crc:  # found by search: only trust a checked chunk
                    return pos, length, chunk, records
        pos += 1


def _messages_in_partial_chunk(body) -> int:
    """Count messages decodable from the first bytes of a cut-off Chunk record body."""
    try:
        compression_len = struct.unpack_from('<I', body, 28)[0]
        compression = bytes(body[32:32 + compression_len]).decode()
        data = bytes(body[32 + compression_len + 8:])
        if compression == 'zstd':
            data = zstandard.ZstdDecompressor().decompressobj().decompress(data)
        elif compression == 'lz4':
            data = lz4.frame.LZ4FrameDecompressor().decompress(data, max_length=MAX_CHUNK_BYTES)
        count, pos = 0, 0
        while pos + _RECORD_HEAD.size <= len(data):
            opcode, length = _RECORD_HEAD.unpack_from(data, pos)
            pos += _RECORD_HEAD.size + length
            if pos > len(data):
                break
            count += opcode == Opcode.MESSAGE
        return count
    except Exception:  # noqa: BLE001 - a cut stream can fail anywhere; count what decodes
        return 0


def _open_map(path: Path):
    with open(path, 'rb') as f:
        return mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ)


def scan(path: Path) -> ScanResult:
    """Walk an MCAP file record by record (the magic is assumed checked); see module doc."""
    path = Path(path)
    result = ScanResult()
    mm = _open_map(path)
    try:
        _walk(mm, len(mm), result)
    finally:
        mm.close()
    return result


def _walk(mm, size: int, result: ScanResult) -> None:
    pos = _MAGIC_SIZE
    while pos < size:
        if pos + _RECORD_HEAD.size > size:
            result.damage.append(Damage(pos, size - pos, 'cut off inside a record header'))
            return
        opcode, length = _RECORD_HEAD.unpack_from(mm, pos)
        end = pos + _RECORD_HEAD.size + length
        body = mm[pos + _RECORD_HEAD.size:min(end, size)]
        try:
            if end > size:
                raise DamagedRecord('record length points past the end of the file')
            if opcode == Opcode.CHUNK:
                _, records = decode_chunk(body)
                _note_definitions(result, records)
                result.spans.append(_span(pos, end - pos, records))
            elif opcode == Opcode.MESSAGE:
                result.spans.append(_span(pos, end - pos, [_parse(Message, body, length)]))
            elif opcode == Opcode.HEADER:
                result.header = _parse(Header, body)
            elif opcode in (Opcode.SCHEMA, Opcode.CHANNEL):
                _note_definitions(result, [_parse(Schema if opcode == Opcode.SCHEMA
                                                  else Channel, body)])
            elif opcode in _DATA_RECORDS:
                _parse(_DATA_RECORDS[opcode], body)
            elif opcode == Opcode.DATA_END:
                _parse(DataEnd, body)
                result.data_complete = True
                return
            elif opcode == Opcode.FOOTER:
                result.data_complete = True
                return
            else:
                raise DamagedRecord(f'unexpected record type 0x{opcode:02x} in the data section')
        except DamagedRecord as err:
            found = _resync(mm, pos + 1, size)
            if found is None:
                cut = end > size and opcode in (Opcode.CHUNK, Opcode.MESSAGE)
                if cut and opcode == Opcode.CHUNK:
                    result.partial_messages += _messages_in_partial_chunk(body)
                result.partial_messages += cut and opcode == Opcode.MESSAGE
                result.damage.append(Damage(pos, size - pos, 'file cut off inside a record'
                                            if cut else str(err)))
                return
            offset, length, _, records = found
            result.damage.append(Damage(pos, offset - pos, str(err)))
            _note_definitions(result, records)
            result.spans.append(_span(offset, _RECORD_HEAD.size + length, records))
            end = offset + _RECORD_HEAD.size + length
        pos = end


def check_indexed(path: Path, summary) -> ScanResult:
    """Check every chunk a verified summary lists; damaged ones go to ``result.damage``."""
    result = ScanResult(schemas=dict(summary.schemas), channels=dict(summary.channels),
                        data_complete=True)
    mm = _open_map(path)
    try:
        size = len(mm)
        for index in sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset):
            pos, length = index.chunk_start_offset, index.chunk_length
            where = Damage(pos, length, '', index.message_start_time, index.message_end_time)
            try:
                if pos + length > size or length < _RECORD_HEAD.size:
                    raise DamagedRecord('chunk index points past the end of the file')
                opcode, body_len = _RECORD_HEAD.unpack_from(mm, pos)
                if opcode != Opcode.CHUNK or body_len + _RECORD_HEAD.size != length:
                    raise DamagedRecord('chunk record header does not match the index')
                _, records = decode_chunk(mm[pos + _RECORD_HEAD.size:pos + length])
            except DamagedRecord as err:
                where.reason = str(err)
                result.damage.append(where)
                continue
            result.spans.append(_span(pos, length, records))
    finally:
        mm.close()
    return result


def iter_span_messages(path: Path, spans: List[Tuple[int, int]]) -> Iterator[Message]:
    """Yield the messages of the given (checked) Chunk/Message records, log-time sorted each."""
    mm = _open_map(path)
    try:
        for offset, length in spans:
            opcode, body_len = _RECORD_HEAD.unpack_from(mm, offset)
            body = mm[offset + _RECORD_HEAD.size:offset + length]
            if opcode == Opcode.CHUNK:
                records = decode_chunk(body)[1]
            else:
                records = [_parse(Message, body, body_len)]
            yield from sorted((r for r in records if isinstance(r, Message)),
                              key=lambda m: m.log_time)
    finally:
        mm.close()

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
Binary serial protocol between the host bridge and the PWM/ADC microcontroller.

This is the one Python implementation of the protocol; the bridge (host side) and the MCU
emulator both use it, and ``firmware/sma_mcu/sma_protocol.cpp`` is its C++ twin, checked
byte-for-byte against ``firmware/test_vectors.json``. The full specification is in
``docs/protocol.md``; in short::

    wire frame = COBS(payload) 0x00
    payload    = type:u8  seq:u8  body  crc:u32le      (2 + len(body) + 4 bytes, at most 64)
    crc        = CRC-32/ISO-HDLC (zlib.crc32) over type, seq and body

All multi-byte integers are little-endian. ``seq`` counts the frames each sender has sent
(mod 256). Duties travel as ``uint16`` counts, 0..65535 meaning duty 0..1; MCU time is
``uint32`` microsecond ticks (wraps after ~71.6 min).
"""
from __future__ import annotations

from dataclasses import dataclass, fields
import operator
import struct
from typing import ClassVar, Iterator, Union
import zlib

PROTOCOL_VERSION = 1
DUTY_FULL_SCALE = 65535          # duty counts meaning duty 1.0
MAX_PAYLOAD = 64                 # bytes, type + seq + body + crc, before COBS
MAX_ENCODED = MAX_PAYLOAD + 1    # COBS adds one byte per started 254-byte block
HEADER_SIZE = 2                  # type, seq
CRC_SIZE = 4
MIN_PAYLOAD = HEADER_SIZE + CRC_SIZE
DELIMITER = 0

# MCU fault bits, carried in AdcReport.faults and Status.faults/faults_latched.
FAULT_WATCHDOG = 1 << 0        # no valid Duty frame for watchdog_ms: both outputs off
FAULT_INTERLOCK = 1 << 1       # last Duty asked for heat the dead-time interlock holds off
FAULT_REJECTED = 1 << 2        # last Duty exceeded max_duty on a channel: ignored, kept old
FAULT_NOT_CONFIGURED = 1 << 3  # no valid Hello since reset: Duty frames ignored, outputs off
FAULT_BAD_VERSION = 1 << 4     # last Hello asked for a protocol version the MCU lacks
FAULT_NAMES = {
    FAULT_WATCHDOG: 'watchdog', FAULT_INTERLOCK: 'interlock', FAULT_REJECTED: 'rejected',
    FAULT_NOT_CONFIGURED: 'not_configured', FAULT_BAD_VERSION: 'bad_version',
}


class ProtocolError(ValueError):
    """A frame or message that is not valid under this protocol."""


def duty_to_counts(duty) -> int:
    """
    Return the counts 0..65535 of a duty fraction 0..1 (nearest).

    Raises ProtocolError for anything else (NaN, inf, 1e308, 2.0, -0.1): garbage is never
    clamped to full power.
    """
    try:
        value = float(duty)
    except (TypeError, ValueError):
        raise ProtocolError(f'duty {duty!r} is not a number') from None
    if not 0.0 <= value <= 1.0:     # also false for NaN
        raise ProtocolError(f'duty {value!r} is outside [0, 1]')
    return int(round(value * DUTY_FULL_SCALE))


def crc32(data: bytes) -> int:
    """CRC-32/ISO-HDLC (poly 0x04C11DB7 reflected, init and xorout 0xFFFFFFFF) of `data`."""
    return zlib.crc32(data) & 0xFFFFFFFF


def cobs_encode(data: bytes) -> bytes:
    """
    Consistent Overhead Byte Stuffing: `data` re-coded without any zero byte.

    A trailing 254-byte block gets no extra 0x01 code (the shortest encoding, as in
    most C implementations and in firmware/sma_mcu/sma_protocol.cpp).
    """
    out = bytearray()
    chunks = bytes(data).split(b'\x00')
    for index, chunk in enumerate(chunks):
        last = index == len(chunks) - 1
        while len(chunk) >= 254:
            out.append(0xFF)
            out += chunk[:254]
            chunk = chunk[254:]
            if last and not chunk:
                return bytes(out)
        out.append(len(chunk) + 1)
        out += chunk
    return bytes(out)


def cobs_decode(encoded: bytes) -> bytes:
    """Inverse of :func:`cobs_encode`; raises ProtocolError on a malformed encoding."""
    if DELIMITER in encoded:
        raise ProtocolError('COBS data contains a zero byte')
    out = bytearray()
    index, size = 0, len(encoded)
    while index < size:
        code = encoded[index]
        end = index + code
        if end > size:
            raise ProtocolError(
                f'COBS code {code} at byte {index} runs past the end ({size} bytes)')
        out += encoded[index + 1:end]
        index = end
        if code != 0xFF and index < size:
            out.append(0)
    return bytes(out)


@dataclass(frozen=True)
class Frame:
    """One frame that passed COBS, length and CRC checks (its message is not yet parsed)."""

    type: int  # noqa: A003 (the frame's type byte, docs/protocol.md)
    seq: int
    body: bytes


@dataclass(frozen=True)
class FrameError:
    """A rejected chunk between two delimiters; `kind` is one of ERROR_KINDS."""

    kind: str


ERROR_KINDS = ('oversize', 'cobs', 'short', 'crc')


def encode_frame(msg_type: int, seq: int, body: bytes) -> bytes:
    """Return the wire bytes (COBS + trailing delimiter) of one frame."""
    if not 0 <= msg_type <= 0xFF or not 0 <= seq <= 0xFF:
        raise ProtocolError(f'frame type {msg_type} and seq {seq} must both be in 0..255')
    payload = bytes((msg_type, seq)) + bytes(body)
    if len(payload) + CRC_SIZE > MAX_PAYLOAD:
        raise ProtocolError(
            f'frame body of {len(body)} bytes exceeds the {MAX_PAYLOAD}-byte payload limit')
    payload += crc32(payload).to_bytes(CRC_SIZE, 'little')
    return cobs_encode(payload) + b'\x00'


def decode_chunk(chunk: bytes) -> Union[Frame, FrameError]:
    """Check one delimiter-free chunk; returns the Frame or why it was rejected."""
    if len(chunk) > MAX_ENCODED:
        return FrameError('oversize')
    try:
        payload = cobs_decode(chunk)
    except ProtocolError:
        return FrameError('cobs')
    if len(payload) < MIN_PAYLOAD:
        return FrameError('short')
    if crc32(payload[:-CRC_SIZE]) != int.from_bytes(payload[-CRC_SIZE:], 'little'):
        return FrameError('crc')
    return Frame(payload[0], payload[1], payload[HEADER_SIZE:-CRC_SIZE])


class FrameDecoder:
    """
    Splits a byte stream at zero delimiters into frames, counting and skipping bad ones.

    A bad chunk costs only itself: decoding restarts after the next delimiter. Empty
    chunks (repeated delimiters, used to flush a receiver) are ignored silently.
    `errors` maps each of ERROR_KINDS to its count; `frames` counts good frames.
    """

    def __init__(self) -> None:
        self._pending = bytearray()
        self._discarding = False   # inside an oversize run: drop bytes up to the next zero
        self.frames = 0
        self.errors = dict.fromkeys(ERROR_KINDS, 0)

    def reset(self) -> None:
        """Drop any partial frame (e.g. after reopening the port); counters are kept."""
        self._pending.clear()
        self._discarding = False

    def events(self, data: bytes) -> Iterator[Union[Frame, FrameError]]:
        """Feed `data`; yield every Frame and FrameError it completes, in stream order."""
        buf = self._pending + data
        start = 0
        while (zero := buf.find(0, start)) >= 0:
            chunk = bytes(buf[start:zero])
            start = zero + 1
            if self._discarding:
                self._discarding = False
                continue
            if chunk:
                yield self._count(decode_chunk(chunk))
        rest = buf[start:]
        if self._discarding:
            rest = bytearray()
        elif len(rest) > MAX_ENCODED:
            self._discarding = True
            rest = bytearray()
            yield self._count(FrameError('oversize'))
        self._pending = rest

    def feed(self, data: bytes) -> list[Frame]:
        """Feed `data`; return the good frames it completes (errors are only counted)."""
        return [event for event in self.events(data) if isinstance(event, Frame)]

    def _count(self, event):
        if isinstance(event, Frame):
            self.frames += 1
        else:
            self.errors[event.kind] += 1
        return event


# --- messages -----------------------------------------------------------------------

_RANGES = {'B': (0, 0xFF), 'H': (0, 0xFFFF), 'I': (0, 0xFFFFFFFF)}


class Message:
    """Base of all messages: a frozen dataclass with TYPE id and little-endian FORMAT."""

    TYPE: ClassVar[int]
    FORMAT: ClassVar[struct.Struct]

    def body(self) -> bytes:
        """Return the packed body; raise ProtocolError naming any field out of its int range."""
        values = []
        for f, code in zip(fields(self), self.FORMAT.format[1:]):
            value, (low, high) = getattr(self, f.name), _RANGES[code]
            try:
                value = operator.index(value)   # accepts numpy integers, refuses floats
            except TypeError:
                value = None
            if value is None or not low <= value <= high:
                raise ProtocolError(f'{type(self).__name__}.{f.name}={getattr(self, f.name)!r} '
                                    f'is not an integer in {low}..{high}')
            values.append(value)
        return self.FORMAT.pack(*values)

    def encode(self, seq: int) -> bytes:
        """Return the complete wire frame of this message with sequence number `seq`."""
        return encode_frame(self.TYPE, seq, self.body())


@dataclass(frozen=True)
class Hello(Message):
    """Host -> MCU: handshake and configuration; the MCU may only tighten the limits."""

    TYPE = 0x01
    FORMAT = struct.Struct('<BHHI')
    protocol_version: int
    max_duty: int          # counts; a Duty above this on a channel is rejected
    interlock_duty: int    # counts; both channels above this at once is refused
    adc_period_us: int     # longest gap between ADC reports


@dataclass(frozen=True)
class Duty(Message):
    """Host -> MCU: PWM duty of both channels in counts (65535 = 100 %)."""

    TYPE = 0x02
    FORMAT = struct.Struct('<HH')
    duty_a: int
    duty_b: int


@dataclass(frozen=True)
class Heartbeat(Message):
    """Host -> MCU: echo request for round-trip time (does NOT feed the MCU watchdog)."""

    TYPE = 0x03
    FORMAT = struct.Struct('<I')
    host_us: int


@dataclass(frozen=True)
class HelloAck(Message):
    """MCU -> host: firmware identity and the limits it actually applies."""

    TYPE = 0x81
    FORMAT = struct.Struct('<BBBBIBHHHI')
    protocol_version: int
    fw_major: int
    fw_minor: int
    fw_patch: int
    tick_hz: int
    adc_bits: int
    watchdog_ms: int
    max_duty: int
    interlock_duty: int
    adc_period_us: int


@dataclass(frozen=True)
class AdcReport(Message):
    """MCU -> host: one potentiometer sample and the PWM duties applied when it was taken."""

    TYPE = 0x82
    FORMAT = struct.Struct('<IHBHHH')
    ticks_us: int
    counts: int
    duty_seq: int          # seq of the last Duty frame the MCU accepted
    faults: int
    duty_a: int
    duty_b: int


@dataclass(frozen=True)
class HeartbeatAck(Message):
    """MCU -> host: the Heartbeat's host_us echoed back, with the MCU time."""

    TYPE = 0x83
    FORMAT = struct.Struct('<II')
    host_us: int
    ticks_us: int


@dataclass(frozen=True)
class Status(Message):
    """MCU -> host: faults and receive counters; every 100 ms and on any fault change."""

    TYPE = 0x84
    FORMAT = struct.Struct('<IHHIIII')
    ticks_us: int
    faults: int
    faults_latched: int    # OR of faults since the last Hello
    rx_frames: int
    rx_crc_errors: int
    rx_framing_errors: int  # oversize + cobs + short
    rx_malformed: int       # good CRC but unknown type or wrong body length


HOST_TO_MCU = (Hello, Duty, Heartbeat)
MCU_TO_HOST = (HelloAck, AdcReport, HeartbeatAck, Status)
MESSAGES = {cls.TYPE: cls for cls in HOST_TO_MCU + MCU_TO_HOST}


def decode_message(frame: Frame, accept=MESSAGES.values()) -> Message:
    """Parse a frame's body; ProtocolError if its type is not in `accept` or size is wrong."""
    cls = MESSAGES.get(frame.type)
    if cls is None or cls not in accept:
        raise ProtocolError(f'unexpected message type 0x{frame.type:02x}')
    if len(frame.body) != cls.FORMAT.size:
        raise ProtocolError(
            f'{cls.__name__} body is {len(frame.body)} bytes, expected {cls.FORMAT.size}')
    return cls(*cls.FORMAT.unpack(frame.body))


def fault_names(faults: int) -> list[str]:
    """Names of the fault bits set in `faults` (unknown bits as 'bit<N>')."""
    return [FAULT_NAMES.get(1 << bit, f'bit{bit}') for bit in range(16) if faults >> bit & 1]


class MessageStream:
    """
    FrameDecoder plus message parsing: feed bytes, get (seq, message) pairs.

    Frames whose type is not in `accept` or whose body has the wrong size are counted in
    `malformed`; `lost` counts frames missing according to the sender's seq numbers.
    """

    def __init__(self, accept=MESSAGES.values()) -> None:
        self.frames = FrameDecoder()
        self.accept = tuple(accept)
        self.malformed = 0
        self.lost = 0
        self._next_seq = None

    def reset(self) -> None:
        """Forget the partial frame and the seq history (after a reconnect)."""
        self.frames.reset()
        self._next_seq = None

    def feed(self, data: bytes) -> list[tuple[int, Message]]:
        """Feed raw bytes; return the valid messages they complete."""
        out = []
        for frame in self.frames.feed(data):
            if self._next_seq is not None:
                self.lost += (frame.seq - self._next_seq) & 0xFF
            self._next_seq = (frame.seq + 1) & 0xFF
            try:
                out.append((frame.seq, decode_message(frame, self.accept)))
            except ProtocolError:
                self.malformed += 1
        return out


class Sender:
    """Numbers outgoing messages: each encode() uses the next seq (mod 256)."""

    def __init__(self) -> None:
        self.seq = 0

    def encode(self, msg: Message) -> bytes:
        """Wire frame of `msg` with the next sequence number."""
        frame = msg.encode(self.seq)
        self.seq = (self.seq + 1) & 0xFF
        return frame

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

"""Unit tests of the serial protocol: CRC, COBS, frames, stream resynchronisation, messages."""
import random

import pytest
from sma_actuator.hardware import protocol as p


def test_crc32_check_value_and_frame_trailer():
    # Standard CRC-32/ISO-HDLC check value; the frame trailer is that CRC, little-endian.
    assert p.crc32(b'123456789') == 0xCBF43926
    payload = p.cobs_decode(p.Duty(1, 2).encode(7)[:-1])
    assert payload[-4:] == p.crc32(payload[:-4]).to_bytes(4, 'little')


@pytest.mark.parametrize('data, encoded', [
    (b'', b'\x01'),
    (b'\x00', b'\x01\x01'),
    (b'\x11\x22\x00\x33', b'\x03\x11\x22\x02\x33'),
    (b'\x11\x00', b'\x02\x11\x01'),
    (bytes(range(1, 255)), b'\xff' + bytes(range(1, 255))),          # full block, no trailing code
    (bytes(range(1, 256)), b'\xff' + bytes(range(1, 255)) + b'\x02\xff'),
])
def test_cobs_known_encodings(data, encoded):
    assert p.cobs_encode(data) == encoded
    assert p.cobs_decode(encoded) == data


def test_cobs_round_trip_random():
    rng = random.Random(1)
    for _ in range(300):
        data = bytes(rng.choice((0, rng.randrange(256))) for _ in range(rng.randrange(0, 700)))
        encoded = p.cobs_encode(data)
        assert 0 not in encoded
        assert len(encoded) <= len(data) + len(data) // 254 + 1
        assert p.cobs_decode(encoded) == data


@pytest.mark.parametrize('bad, reason',
                         [(b'\x05\x11', 'runs past the end'), (b'\x02\x00', 'zero byte')])
def test_cobs_decode_rejects_malformed(bad, reason):
    with pytest.raises(p.ProtocolError, match=reason):
        p.cobs_decode(bad)


def test_frame_layout():
    wire = p.Duty(0x1234, 0xABCD).encode(9)
    assert wire[-1] == 0 and 0 not in wire[:-1]
    payload = p.cobs_decode(wire[:-1])
    assert payload[:2] == bytes((p.Duty.TYPE, 9))
    assert payload[2:6] == bytes((0x34, 0x12, 0xCD, 0xAB))  # little-endian u16 duties


def test_encode_frame_refuses_oversized_body():
    p.encode_frame(1, 0, bytes(p.MAX_PAYLOAD - p.MIN_PAYLOAD))  # exactly fits
    with pytest.raises(p.ProtocolError, match='payload limit'):
        p.encode_frame(1, 0, bytes(p.MAX_PAYLOAD - p.MIN_PAYLOAD + 1))


def test_message_field_range_errors_name_the_field():
    with pytest.raises(p.ProtocolError,
                       match=r'Duty\.duty_b=70000 is not an integer in 0\.\.65535'):
        p.Duty(1, 70000).encode(0)
    with pytest.raises(p.ProtocolError, match=r'Duty\.duty_a=0\.5'):
        p.Duty(0.5, 0).encode(0)
    with pytest.raises(p.ProtocolError, match='seq 256'):
        p.encode_frame(1, 256, b'')


@pytest.mark.parametrize('msg', [
    p.Hello(1, 65535, 19661, 5000), p.Duty(0, 65535), p.Heartbeat(0xFFFFFFFF),
    p.HelloAck(1, 1, 0, 0, 1_000_000, 12, 100, 65535, 19661, 5000),
    p.AdcReport(123, 4095, 255, 3, 100, 0), p.HeartbeatAck(1, 2), p.Status(1, 2, 3, 4, 5, 6, 7),
])
def test_every_message_round_trips(msg):
    stream = p.MessageStream()
    assert stream.feed(msg.encode(200)) == [(200, msg)]


def test_decoder_resynchronises_after_garbage_truncation_and_crc_error():
    good = [p.Duty(i, 0).encode(i) for i in range(4)]
    corrupt = bytearray(good[2])
    corrupt[3] ^= 0x01
    stream = (b'\xde\xad\x00' + good[0] + good[1][:5] + b'\x00' + bytes(corrupt) + good[3]
              + b'\x01' * 300 + b'\x00' + good[1])
    decoder = p.FrameDecoder()
    frames = decoder.feed(stream)
    assert [f.seq for f in frames] == [0, 3, 1]
    assert decoder.errors == {'oversize': 1, 'cobs': 1, 'short': 1, 'crc': 1}
    assert decoder.frames == 3


def test_decoder_handles_byte_by_byte_feed_like_bulk_feed():
    rng = random.Random(5)
    data = b''.join(p.AdcReport(i, i, i, 0, 0, 0).encode(i) for i in range(20))
    data = bytes(b if rng.random() > 0.02 else rng.randrange(256)
                 for b in data) + b'\x07' * 90 + b'\x00'
    bulk, trickle = p.FrameDecoder(), p.FrameDecoder()
    expected = bulk.feed(data)
    got = [f for i in range(len(data)) for f in trickle.feed(data[i:i + 1])]
    assert got == expected and trickle.errors == bulk.errors
    assert len(expected) >= 10


def test_oversize_run_split_across_feeds_drops_only_itself():
    decoder = p.FrameDecoder()
    assert decoder.feed(b'\x01' * 50) == []
    assert decoder.feed(b'\x01' * 50) == []          # now 100 bytes without delimiter
    frames = decoder.feed(b'\x01' * 10 + b'\x00' + p.Duty(5, 6).encode(1))
    assert [(f.seq, f.body) for f in frames] == [(1, b'\x05\x00\x06\x00')]
    assert decoder.errors['oversize'] == 1


def test_message_stream_counts_malformed_and_lost_frames():
    stream = p.MessageStream(accept=p.MCU_TO_HOST)
    data = (p.AdcReport(1, 2, 3, 0, 0, 0).encode(0)
            + p.Duty(1, 1).encode(1)                     # wrong direction: malformed
            + p.encode_frame(p.AdcReport.TYPE, 2, b'\x00' * 3)  # wrong body length: malformed
            + p.encode_frame(0x55, 3, b'')               # unknown type: malformed
            + p.HeartbeatAck(1, 2).encode(7))            # seq 4, 5, 6 missing
    received = stream.feed(data)
    assert [seq for seq, _ in received] == [0, 7]
    assert stream.malformed == 3
    assert stream.lost == 3


def test_fault_names():
    assert p.fault_names(p.FAULT_WATCHDOG | p.FAULT_INTERLOCK) == ['watchdog', 'interlock']
    assert p.fault_names(1 << 9) == ['bit9']
    assert p.fault_names(0) == []


def test_sender_numbers_frames_mod_256():
    sender = p.Sender()
    seqs = [p.cobs_decode(sender.encode(p.Heartbeat(0))[:-1])[1] for _ in range(258)]
    assert seqs[:3] == [0, 1, 2] and seqs[255:] == [255, 0, 1]

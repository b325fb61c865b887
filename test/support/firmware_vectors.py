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
Shared test vectors of the serial protocol: Python writes them, the C++ firmware checks them.

``python test/support/firmware_vectors.py --write`` regenerates firmware/test_vectors.json
from the protocol and MCU logic of sma_actuator.hardware; ``--check`` verifies the file is
up to date. It lives with the tests: the runtime package does not ship test data.
The firmware's host test driver (firmware/host_test/vector_driver.cpp) replays every vector
against the C++ code and must reproduce each expected output byte-for-byte.

File layout: one JSON object per vector per line, all values strings, so that the C++
driver can read it with a few lines of string search (no JSON library on the firmware
side). Kinds: crc32, cobs, frame, msg, stream, mcu (see docs/protocol.md).
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path
import random
import sys

from sma_actuator.hardware import protocol as p
from sma_actuator.hardware.mcu_core import McuCore

DEFAULT_PATH = Path(__file__).resolve().parents[2] / 'firmware' / 'test_vectors.json'
SEED = 20240604


def scenario_adc():
    """Return the ADC sequence both MCU implementations use in scenarios: 1000 + 37 n mod 4096."""
    state = {'n': 0}

    def read():
        value = (1000 + 37 * state['n']) % 4096
        state['n'] += 1
        return value
    return read


def stream_events(data: bytes) -> str:
    """Canonical text of what a fresh FrameDecoder makes of `data`."""
    tokens = []
    for event in p.FrameDecoder().events(data):
        if isinstance(event, p.Frame):
            tokens.append('F:' + (bytes((event.type, event.seq)) + event.body).hex())
        else:
            tokens.append('E:' + event.kind)
    return ' '.join(tokens) or '-'


def run_scenario(steps: list[tuple]) -> str:
    """
    Run McuCore through `steps` and return its canonical per-step output text.

    steps: ('S', t_us) start, ('P', t_us) poll, ('R', t_us, bytes) receive then poll.
    Output per step: 'pwm_a,pwm_b,faults,txhex' ('-' for nothing sent).
    """
    mcu = McuCore(scenario_adc())
    out = []
    for step in steps:
        if step[0] == 'S':
            tx = mcu.start(step[1])
        elif step[0] == 'P':
            tx = mcu.poll(step[1])
        else:
            tx = mcu.receive(step[2], step[1]) + mcu.poll(step[1])
        out.append(f'{mcu.pwm_a},{mcu.pwm_b},{mcu.faults},{tx.hex() or "-"}')
    return ' '.join(out)


def steps_text(steps: list[tuple]) -> str:
    """Canonical input text of a scenario: 'S:t', 'P:t', 'R:t:hex' tokens."""
    return ' '.join(f'{s[0]}:{s[1]}' + (f':{s[2].hex()}' if s[0] == 'R' else '') for s in steps)


def _fields_text(seq: int, msg: p.Message) -> str:
    return ' '.join([f'seq={seq}'] + [f'{k}={v}' for k, v in vars(msg).items()])


def _crc_vectors(rng):
    inputs = [b'', b'123456789', b'\x00', b'\xff\xff\xff\xff']
    inputs += [rng.randbytes(rng.randrange(1, 65)) for _ in range(8)]
    return [{'kind': 'crc32', 'in': d.hex(), 'out': f'{p.crc32(d):08x}'} for d in inputs]


def _cobs_vectors(rng):
    nonzero = bytes(range(1, 256))
    inputs = [b'', b'\x00', b'\x00\x00', b'\x11\x22\x00\x33', b'\x11\x00', nonzero[:253],
              nonzero[:254], nonzero[:254] + b'\x00', nonzero + b'\x01',
              b'\x00' + nonzero[:254] + b'\x00\x07']
    inputs += [bytes(rng.choice((0, rng.randrange(256))) for _ in range(rng.randrange(1, 600)))
               for _ in range(6)]
    return [{'kind': 'cobs', 'in': d.hex(), 'out': p.cobs_encode(d).hex()} for d in inputs]


def _messages():
    """One or more (seq, message) examples of every type, including range limits."""
    m = 0xFFFFFFFF
    return [
        (0, p.Hello(1, 65535, 19661, 5000)), (255, p.Hello(0, 0, 0, m)),
        (3, p.Duty(1000, 0)), (4, p.Duty(0, 65535)), (5, p.Duty(0, 0)), (6, p.Duty(65535, 65535)),
        (7, p.Heartbeat(123456789)), (8, p.Heartbeat(m)),
        (0, p.HelloAck(1, 1, 0, 0, 1_000_000, 12, 100, 65535, 19661, 5000)),
        (9, p.AdcReport(4_000_000_000, 4095, 17, 5, 1234, 0)), (10, p.AdcReport(0, 0, 0, 0, 0, 0)),
        (11, p.HeartbeatAck(m, 42)),
        (12, p.Status(99, 1, 9, 100000, 2, 3, 4)), (13, p.Status(m, 0xFFFF, 0xFFFF, m, m, m, m)),
    ]


def _stream_vectors(rng):
    duty = p.Duty(1000, 2).encode(1)
    adc = p.AdcReport(5, 6, 7, 8, 9, 10).encode(2)
    bad_crc = bytearray(duty)
    bad_crc[3] ^= 0x40
    streams = [
        duty + adc, b'\x13\x37garbage' + duty, duty[:5] + adc, bytes(bad_crc) + adc,
        b'\x00\x00' + duty + b'\x00', b'\x05\x11\x22\x00' + duty, b'\x09\x01\x02\x00' + adc,
        b'\x01' * 200 + duty, b'\x01' * 65 + b'\x00' + adc, b'\x01' * 66 + b'\x00' + adc,
        b'\x02\x01\x01\x01\x00',
    ]
    frames = [msg.encode(seq) for seq, msg in _messages()]
    for _ in range(24):
        data = bytearray(b''.join(rng.choice(frames) for _ in range(rng.randrange(1, 4))))
        for _ in range(rng.randrange(0, 4)):
            where = rng.randrange(len(data))
            action = rng.randrange(3)
            if action == 0:
                data[where] = rng.randrange(256)
            elif action == 1:
                del data[where]
            else:
                data.insert(where, rng.randrange(256))
        streams.append(bytes(data))
    return [{'kind': 'stream', 'in': s.hex(), 'out': stream_events(s)} for s in streams]


def _scenarios():
    hello = p.Hello(1, 60000, 19661, 5000).encode(0)

    def duty(seq, a, b):
        return p.Duty(a, b).encode(seq)
    return {
        'boot_hello_duty_reports': [
            ('S', 0), ('P', 1000), ('R', 2000, hello), ('R', 3000, duty(1, 30000, 0)),
            ('P', 7999), ('P', 8000), ('P', 13000)],
        'watchdog_100ms': [
            ('S', 0), ('R', 10, hello), ('R', 1000, duty(1, 40000, 0)), ('P', 50000),
            ('R', 60000, duty(2, 40000, 0)), ('P', 159999), ('P', 160000), ('P', 170000),
            ('R', 180000, duty(3, 20000, 0))],
        'interlock_both_above': [
            ('S', 0), ('R', 10, hello), ('R', 20, duty(1, 19662, 19662)),
            ('R', 30, duty(2, 19661, 65535)), ('R', 40, duty(3, 19662, 19661))],
        'reject_above_max': [
            ('S', 0), ('R', 10, hello), ('R', 20, duty(1, 30000, 0)), ('R', 30, duty(2, 65535, 0)),
            ('P', 100019), ('P', 100020), ('R', 100030, duty(3, 100, 0))],
        'dead_time_interlock': [
            ('S', 0), ('R', 10, hello), ('R', 1000, duty(1, 30000, 0)),
            ('R', 20000, duty(2, 0, 30000)), ('R', 44999, duty(3, 0, 30000)),
            ('R', 45000, duty(4, 0, 30000)), ('R', 55000, duty(5, 30000, 0)),
            ('R', 79999, duty(6, 30000, 0)), ('R', 80000, duty(7, 30000, 0)),
            ('R', 90000, duty(8, 30000, 30000)), ('R', 100000, duty(9, 0, 30000))],
        'hello_cannot_raise_interlock': [
            ('S', 0), ('R', 10, p.Hello(1, 65535, 65535, 100).encode(0)),
            ('R', 20, duty(1, 40000, 40000)), ('R', 30, duty(2, 32768, 32768))],
        'duty_ignored_until_hello': [
            ('S', 5), ('R', 10, duty(1, 30000, 0)), ('P', 100005),
            ('R', 100010, hello + duty(2, 30000, 0))],
        'bad_protocol_version': [
            ('S', 0), ('R', 10, p.Hello(2, 60000, 19661, 5000).encode(0)),
            ('R', 20, duty(1, 30000, 0))],
        'heartbeat_echo': [
            ('S', 0), ('R', 10, p.Heartbeat(0xDEADBEEF).encode(0)), ('P', 100000)],
        'rx_errors_counted': [
            ('S', 0), ('R', 10, b'\x01\x02\x00garbage\x00' + hello[:4] + b'\x00'),
            ('R', 20, duty(1, 1, 1)[:-3] + b'\x01\x00'), ('R', 30, b'\x01' * 100 + b'\x00'),
            ('R', 40, p.AdcReport(1, 2, 3, 4, 5, 6).encode(9)), ('P', 100000)],
        'tick_wraparound': [
            ('S', 0xFFFF0000), ('R', 0xFFFFFF00, hello), ('R', 0xFFFFFFF0, duty(1, 5000, 0)),
            ('P', 40000), ('P', 99000), ('P', 99984), ('P', 99985)],
    }


def build_vectors() -> dict:
    """All vectors, deterministic (fixed seed)."""
    rng = random.Random(SEED)
    vectors = _crc_vectors(rng) + _cobs_vectors(rng)
    for seq, msg in _messages():
        wire = msg.encode(seq)
        unframed = bytes((msg.TYPE, seq)) + msg.body()
        vectors.append({'kind': 'frame', 'in': unframed.hex(), 'out': wire.hex()})
        vectors.append({'kind': 'msg', 'type': type(msg).__name__,
                        'in': _fields_text(seq, msg), 'out': wire.hex()})
    vectors += _stream_vectors(rng)
    for name, steps in _scenarios().items():
        vectors.append({'kind': 'mcu', 'name': name, 'in': steps_text(steps),
                        'out': run_scenario(steps)})
    return {'format': 'sma_actuator serial protocol test vectors',
            'protocol_version': str(p.PROTOCOL_VERSION),
            'generator': 'python test/support/firmware_vectors.py --write', 'vectors': vectors}


def render(doc: dict) -> str:
    """Return the exact file text: header keys, then one vector object per line."""
    head = ', '.join(f'{json.dumps(k)}: {json.dumps(v)}' for k, v in doc.items() if k != 'vectors')
    lines = ',\n'.join(json.dumps(v) for v in doc['vectors'])
    return '{' + head + ', "vectors": [\n' + lines + '\n]}\n'


def main(argv=None) -> int:
    """Write or check the vectors file; exit status 1 if --check finds it out of date."""
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument('--write', action='store_true', help='regenerate the file')
    parser.add_argument('--check', action='store_true',
                        help='fail if the file differs from the generator')
    parser.add_argument('--path', type=Path, default=DEFAULT_PATH,
                        help='vectors file (default: %(default)s)')
    args = parser.parse_args(argv)
    text = render(build_vectors())
    if args.write:
        args.path.write_text(text)
        print(f'wrote {len(build_vectors()["vectors"])} vectors to {args.path}')
        return 0
    if args.path.exists() and args.path.read_text() == text:
        print(f'{args.path} is up to date')
        return 0
    print(f'{args.path} is missing or out of date: run with --write', file=sys.stderr)
    return 1


if __name__ == '__main__':
    sys.exit(main())

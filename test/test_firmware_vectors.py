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
The C++ firmware against the Python protocol, byte-for-byte.

Compiles firmware/sma_mcu (framing, CRC, messages, MCU logic) and the real sketch with g++
into a temporary directory, then checks: every vector in firmware/test_vectors.json is
reproduced; the vectors file is exactly what the Python side generates; both decoders
agree on random and mutated streams; the sketch itself switches the outputs off on the
100 ms watchdog and on the interlock.
"""
import json
from pathlib import Path
import random
import shutil
import subprocess

import pytest
from sma_actuator.hardware import protocol as p
from support import firmware_vectors as vectors

FIRMWARE = Path(__file__).resolve().parents[1] / 'firmware'
CXXFLAGS = ['-std=c++17', '-Wall', '-Wextra', '-Werror', '-O1', f'-I{FIRMWARE / "sma_mcu"}']
CORE_SOURCES = [FIRMWARE / 'sma_mcu' / f for f in ('sma_protocol.cpp', 'sma_mcu_core.cpp')]


@pytest.fixture(scope='module')
def build_dir(tmp_path_factory):
    if shutil.which('g++') is None:
        pytest.skip('g++ not found on PATH: cannot compile the firmware host tests')
    return tmp_path_factory.mktemp('firmware_build')


def _compile(build_dir, name, sources, extra=()):
    exe = build_dir / name
    cmd = ['g++', *CXXFLAGS, *extra, *map(str, sources), '-o', str(exe)]
    result = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, f'{" ".join(cmd)} failed:\n{result.stderr}'
    return exe


@pytest.fixture(scope='module')
def vector_driver(build_dir):
    sources = CORE_SOURCES + [FIRMWARE / 'host_test' / 'vector_driver.cpp']
    return _compile(build_dir, 'vector_driver', sources)


@pytest.fixture(scope='module')
def sketch_driver(build_dir):
    sources = ['-x', 'c++', FIRMWARE / 'sma_mcu' / 'sma_mcu.ino', '-x', 'none', *CORE_SOURCES,
               FIRMWARE / 'host_test' / 'sketch_driver.cpp']
    return _compile(build_dir, 'sketch_driver', sources, extra=[f'-I{FIRMWARE / "host_test"}'])


def _load_vectors():
    return json.loads((FIRMWARE / 'test_vectors.json').read_text())['vectors']


def test_vectors_file_matches_python_generator_byte_for_byte():
    expected = vectors.render(vectors.build_vectors())
    assert (FIRMWARE / 'test_vectors.json').read_text() == expected, \
        'firmware/test_vectors.json is stale: run python test/support/firmware_vectors.py --write'


@pytest.mark.slow
def test_firmware_reproduces_every_vector(vector_driver):
    result = subprocess.run([str(vector_driver), str(FIRMWARE / 'test_vectors.json')],
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 0, result.stdout + result.stderr
    n = len(_load_vectors())
    assert f'checked {n} vectors, 0 failed' in result.stdout
    for kind in ('crc32', 'cobs', 'frame', 'msg', 'stream', 'mcu'):
        assert f'{kind}=' in result.stdout


def test_driver_reports_a_wrong_vector(vector_driver, tmp_path):
    # Flip one expected bit in a scenario and one in a frame: the driver must fail both.
    lines = (FIRMWARE / 'test_vectors.json').read_text().splitlines()
    for kind in ('"kind": "frame"', '"kind": "mcu"'):
        i = next(i for i, line in enumerate(lines) if kind in line)
        vec = json.loads(lines[i].rstrip(','))
        out = vec['out']
        vec['out'] = out[:-3] + ('1' if out[-3] != '1' else '2') + out[-2:]
        lines[i] = json.dumps(vec) + (',' if lines[i].endswith(',') else '')
    bad = tmp_path / 'bad_vectors.json'
    bad.write_text('\n'.join(lines) + '\n')
    result = subprocess.run([str(vector_driver), str(bad)],
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 1
    assert result.stdout.count('FAIL') == 2 and ', 2 failed' in result.stdout


def test_vectors_show_the_firmware_watchdog_and_interlock():
    # What the C++ reproduces above, spelled out: these outputs are the safety behaviour.
    scenarios = {v['name']: (v['in'].split(), v['out'].split())
                 for v in _load_vectors() if v['kind'] == 'mcu'}
    steps, outs = scenarios['watchdog_100ms']
    state = {s.split(':')[1]: o.split(',')[:3] for s, o in zip(steps, outs)}
    # last duty at 60 ms: still on at 159.999 ms
    assert state['159999'] == ['40000', '0', '0']
    assert state['160000'] == ['0', '0', str(p.FAULT_WATCHDOG)]   # 100 ms without duty: off
    assert state['180000'] == ['20000', '0', '0']        # next duty frame re-enables
    steps, outs = scenarios['interlock_both_above']
    assert [o.split(',')[:3] for o in outs[2:]] == [
        ['0', '0', str(p.FAULT_INTERLOCK)], ['0', '0', str(p.FAULT_REJECTED)],
        ['0', '0', str(p.FAULT_INTERLOCK)]]
    # dead time 25 ms: a off at 20 ms, so b is held until 45 ms (issue 13 item 1)
    steps, outs = scenarios['dead_time_interlock']
    state = {s.split(':')[1]: o.split(',')[:3] for s, o in zip(steps, outs)}
    assert state['1000'] == ['30000', '0', '0']
    assert state['20000'] == state['44999'] == ['0', '0', str(p.FAULT_INTERLOCK)]
    assert state['45000'] == ['0', '30000', '0']
    assert state['79999'] == ['0', '0', str(p.FAULT_INTERLOCK)]
    assert state['80000'] == ['30000', '0', '0']
    assert state['90000'] == state['100000'] == ['0', '0', str(p.FAULT_INTERLOCK)]
    # a duty above max_duty is rejected, the last valid one kept, the watchdog not fed
    steps, outs = scenarios['reject_above_max']
    state = {s.split(':')[1]: o.split(',')[:3] for s, o in zip(steps, outs)}
    assert state['30'] == ['30000', '0', str(p.FAULT_REJECTED)]
    assert state['100020'] == ['0', '0', str(p.FAULT_WATCHDOG | p.FAULT_REJECTED)]


def test_differential_fuzz_cpp_and_python_decoders_agree(vector_driver):
    rng = random.Random(11)
    frames = [msg.encode(seq) for seq, msg in vectors._messages()]
    streams = []
    for i in range(3000):
        if i % 2:
            streams.append(rng.randbytes(rng.randrange(1, 120)))
            continue
        data = bytearray(b''.join(rng.choice(frames) for _ in range(rng.randint(1, 5))))
        for _ in range(rng.randint(0, 4)):
            where = rng.randrange(len(data))
            data[where:where + rng.randint(0, 2)] = rng.randbytes(rng.randint(0, 2))
        streams.append(bytes(data))
    stdin = ''.join(s.hex() + '\n' for s in streams)
    result = subprocess.run([str(vector_driver), '--decode-stream'], input=stdin,
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 0
    cpp = result.stdout.splitlines()
    assert len(cpp) == len(streams)
    mismatches = [(s.hex(), c, vectors.stream_events(s)) for s, c in zip(streams, cpp)
                  if c != vectors.stream_events(s)]
    assert not mismatches, mismatches[:3]
    assert sum(line.count('F:') for line in cpp) > 1000   # plenty of good frames in the mix


def _run_sketch(sketch_driver, steps):
    stdin = ''.join(f'{t} {data.hex()}\n' for t, data in steps)
    result = subprocess.run([str(sketch_driver)], input=stdin,
                            capture_output=True, text=True, timeout=30)
    assert result.returncode == 0, result.stderr
    rows = [line.split() for line in result.stdout.splitlines()]
    return [(int(t), int(a), int(b), bytes.fromhex(tx) if tx != '-' else b'')
            for t, a, b, tx in rows]


def test_sketch_applies_duty_and_watchdog_turns_outputs_off(sketch_driver):
    hello = p.Hello(p.PROTOCOL_VERSION, 65535, 19661, 20000).encode(0)
    steps = [(10, hello), (1000, p.Duty(40000, 0).encode(1))]
    steps += [(t, b'') for t in range(2000, 130000, 1000)]
    rows = _run_sketch(sketch_driver, steps)
    assert rows[0][1:3] == (0, 0)                           # off after setup()
    pwm = {t: (a, b) for t, a, b, _ in rows}
    assert pwm[1000] == (40000 >> 8, 0) and pwm[100000] == (40000 >> 8, 0)
    assert pwm[101000] == (0, 0) and pwm[129000] == (0, 0)  # 100 ms after the last duty frame
    received = p.MessageStream(accept=p.MCU_TO_HOST).feed(b''.join(tx for *_, tx in rows))
    ack = next(m for _, m in received if isinstance(m, p.HelloAck))
    assert ack.adc_bits == 10 and ack.watchdog_ms == 100
    tripped = [m for _, m in received if isinstance(m, p.Status) and m.faults & p.FAULT_WATCHDOG]
    assert tripped and tripped[0].ticks_us == 101000


def test_sketch_refuses_both_wires_above_interlock(sketch_driver):
    hello = p.Hello(p.PROTOCOL_VERSION, 65535, 19661, 20000).encode(0)
    rows = _run_sketch(sketch_driver, [(10, hello), (20, p.Duty(30000, 0).encode(1)),
                                       (30, p.Duty(30000, 25000).encode(2))])
    assert rows[2][1:3] == (30000 >> 8, 0)
    assert rows[3][1:3] == (0, 0)
    reports = [m for _, m in p.MessageStream().feed(rows[3][3]) if isinstance(m, p.AdcReport)]
    assert reports[0].faults & p.FAULT_INTERLOCK and reports[0].duty_seq == 2

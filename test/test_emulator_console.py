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

"""The mcu_emulator console script: pty and TCP transports, real-time MCU watchdog, signals."""
import os
import signal
import subprocess
import time

from hardware_support import console_command, NOTICE_S, start_emulator_process, stop_process
import pytest
import serial
from sma_actuator.hardware import protocol as p
from sma_actuator.hardware.mcu_core import elapsed_us


def exchange(port, frames, seconds, baud=115200, until=None):
    """
    Open the port, write frames (each (time_s, bytes)), collect (t, msg) for `seconds`.

    With `until`, go on collecting (at most NOTICE_S more) until `until(received)` holds.
    Returns (received, write_times); times in s since the port was opened.
    """
    stream = p.MessageStream(accept=p.MCU_TO_HOST)
    received, written = [], []
    with serial.serial_for_url(port, baudrate=baud, timeout=0.005) as ser:
        start = time.monotonic()
        pending = list(frames)
        while time.monotonic() - start < seconds or (
                until is not None and not until(received)
                and time.monotonic() - start < seconds + NOTICE_S):
            while pending and time.monotonic() - start >= pending[0][0]:
                ser.write(pending.pop(0)[1])
                written.append(time.monotonic() - start)
            data = ser.read(4096)
            now = time.monotonic() - start
            received += [(now, m) for _, m in stream.feed(data)]
    return received, written


@pytest.fixture
def pty_emulator(tmp_path):
    link = str(tmp_path / 'mcu')
    proc, port = start_emulator_process('--link', link, '--baud', '115200')
    yield proc, port, link
    stop_process(proc)


@pytest.mark.slow
def test_pty_handshake_duty_reports_and_real_time_watchdog(pty_emulator):
    _, port, link = pty_emulator
    assert port == link and os.readlink(link).startswith('/dev/pts/')
    sender = p.Sender()
    hello = b'\x00' + sender.encode(p.Hello(1, 65535, 19661, 10000))
    duties = [(0.05 + 0.02 * k, sender.encode(p.Duty(40000, 0)))
              for k in range(10)]   # last at 0.23 s
    last_seq = (sender.seq - 1) & 0xFF
    received, _ = exchange(port, [(0.0, hello)] + duties, 0.8,
                           until=lambda got: _final_trip(got, last_seq) is not None
                           and isinstance(got[-1][1], p.AdcReport))
    acks = [m for _, m in received if isinstance(m, p.HelloAck)]
    assert acks and acks[0].watchdog_ms == 100 and acks[0].adc_period_us == 10000
    reports = [m for _, m in received if isinstance(m, p.AdcReport)]
    assert any(m.duty_a == 40000 for m in reports)
    # the MCU watchdog on the MCU's own clock (ticks_us), not on this test's: outputs off
    # 100 ms after the last duty frame (its immediate report carries the MCU time it was
    # taken), never on after that, and not off before. (If this test is slow to write the
    # frames, the watchdog may also trip between two of them: the MCU is right to do so.)
    trip = _final_trip(received, last_seq)
    assert trip is not None, 'the MCU watchdog never tripped after the last duty frame'
    taken_us, off = trip
    assert elapsed_us(off.ticks_us, taken_us) >= 100_000
    assert all(elapsed_us(m.ticks_us, taken_us) < 100_000 for m in reports
               if m.duty_a and m.duty_seq == last_seq)
    after = [m for m in reports if elapsed_us(m.ticks_us, off.ticks_us) < 2**31]
    assert after and all(m.faults & p.FAULT_WATCHDOG and m.duty_a == 0 for m in after)


def _final_trip(received, last_seq):
    """
    Return (MCU time the last duty frame was taken, the watchdog trip's Status after it).

    None while either is missing. The Status goes out on the fault change, at the trip.
    """
    taken = [m.ticks_us for _, m in received
             if isinstance(m, p.AdcReport) and m.duty_seq == last_seq]
    if not taken:
        return None
    off = next((m for _, m in received if isinstance(m, p.Status)
                and m.faults & p.FAULT_WATCHDOG
                and elapsed_us(m.ticks_us, taken[0]) < 2**31), None)
    return None if off is None else (taken[0], off)


def test_tcp_transport_heartbeat_echo():
    proc, port = start_emulator_process('--tcp', '127.0.0.1:0', '--baud', '0')
    try:
        assert port.startswith('socket://127.0.0.1:')
        received, _ = exchange(port, [(0.05, p.Heartbeat(0xC0FFEE).encode(0))], 0.3,
                               until=lambda got: {p.HeartbeatAck, p.Status}
                               <= {type(m) for _, m in got})
        echoes = [m for _, m in received if isinstance(m, p.HeartbeatAck)]
        assert echoes and echoes[0].host_us == 0xC0FFEE
        statuses = [m for _, m in received if isinstance(m, p.Status)]
        assert statuses and statuses[-1].faults & p.FAULT_NOT_CONFIGURED   # no Hello yet
    finally:
        assert stop_process(proc) == 0


def test_sigterm_exits_cleanly_and_removes_the_link(pty_emulator):
    proc, _, link = pty_emulator
    assert stop_process(proc, sig=signal.SIGTERM) == 0
    assert not os.path.lexists(link)


def test_bad_arguments_are_refused_with_a_message():
    command = console_command('mcu_emulator', 'sma_actuator.hardware.emulator') + ['--baud', '-5']
    result = subprocess.run(command, capture_output=True, text=True, timeout=30)
    assert result.returncode == 2 and 'must not be negative' in result.stderr

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

"""The emulator on simulated time: UART line model, shared plant core behind the MCU."""
import numpy as np
import pytest
from sma_actuator.core.sensor import Potentiometer
from sma_actuator.hardware import protocol as p
from sma_actuator.hardware.emulator import Emulator, UartLine


def test_uart_line_delays_bytes_by_their_line_time_and_queues():
    line = UartLine(115200)
    line.send(b'x' * 12, 1.0)
    line.send(b'y' * 12, 1.0)                    # queued behind the first frame
    one = 12 * 10 / 115200
    assert line.arrived(1.0 + one - 1e-6) == b''
    assert line.arrived(1.0 + one) == b'x' * 12
    assert line.next_arrival_s() == pytest.approx(1.0 + 2 * one)
    assert line.arrived(1.0 + 2 * one) == b'y' * 12
    assert UartLine(0).arrived(0.0) == b'' and UartLine(0).next_arrival_s() is None


class Host:
    """Drives an Emulator through step() with explicit times, decoding what it sends."""

    def __init__(self, **kwargs):
        self.emu = Emulator(**kwargs)
        self.t = 10.0
        self.emu.start(self.t)
        self.stream = p.MessageStream(accept=p.MCU_TO_HOST)
        self.sender = p.Sender()
        self.received = []   # (t, msg)
        self.pwm = []        # (t, pwm_a, pwm_b) after every step

    def run(self, seconds, send=b'', dt=0.001):
        end = self.t + seconds
        first = True
        while self.t < end - 1e-9:
            self.t += dt
            out = self.emu.step(self.t, send if first else b'')
            first = False
            self.received += [(self.t, m) for _, m in self.stream.feed(out)]
            self.pwm.append((self.t, self.emu.mcu.pwm_a, self.emu.mcu.pwm_b))

    def send(self, msg):
        return self.sender.encode(msg)

    def reports(self):
        return [(t, m) for t, m in self.received if isinstance(m, p.AdcReport)]


def test_duty_heats_the_wire_moves_the_shaft_and_the_adc_follows():
    host = Host(baud=1_000_000, seed=1)
    host.run(0.01, host.send(p.Hello(1, 65535, 19661, 5000)))
    assert any(isinstance(m, p.HelloAck) and m.adc_bits == 12 for _, m in host.received)
    start_counts = host.reports()[-1][1].counts if host.reports() else None
    for _ in range(60):                                  # 3 s of wire A at full duty
        host.run(0.05, host.send(p.Duty(65535, 0)))
    theta_a, theta_b = host.emu.actuator.temperature_c
    assert theta_a > 60 and theta_b == pytest.approx(22.0, abs=0.5)
    last = host.reports()[-1][1]
    pot = Potentiometer()
    assert last.duty_a == 65535
    assert pot.angle(last.counts) == pytest.approx(host.emu.angle_rad, abs=pot.resolution_rad)
    assert host.emu.angle_rad > 0.3                      # wire A pulls the shaft positive
    assert start_counts is None or last.counts > start_counts
    for _ in range(60):                                  # then wire B
        host.run(0.05, host.send(p.Duty(0, 65535)))
    assert host.emu.angle_rad < 0.0


def test_emulated_mcu_watchdog_switches_off_100_ms_after_the_last_duty():
    host = Host(baud=115200)
    host.run(0.01, host.send(p.Hello(1, 65535, 19661, 5000)))
    host.run(0.2, host.send(p.Duty(30000, 0)))
    on = next(t for t, a, _ in host.pwm if a == 30000)
    off = next(t for t, a, _ in host.pwm if t > on and a == 0)
    assert off - on == pytest.approx(0.1, abs=1e-6)
    status = [(t, m) for t, m in host.received
              if isinstance(m, p.Status) and m.faults & p.FAULT_WATCHDOG]
    assert status and status[0][1].ticks_us == pytest.approx((off - 10.0) * 1e6, abs=1)
    temps = host.emu.actuator.temperature_c
    host.run(0.5)
    assert host.emu.actuator.temperature_c[0] < temps[0]   # cooling: the wire is really off


def test_line_rate_shows_in_the_duty_to_report_delay():
    delays = {}
    for baud in (115200, 1_000_000):
        host = Host(baud=baud)
        host.run(0.01, host.send(p.Hello(1, 65535, 19661, 1_000_000)))
        host.run(0.01, host.send(p.Duty(100, 0)), dt=0.0001)
        sent = host.t - 0.01
        reply = next(t for t, m in host.reports() if m.duty_a == 100)
        delays[baud] = reply - sent
    # Duty 12 bytes + AdcReport 21 bytes, 10 bits each: 2.9 ms vs 0.33 ms (+ 0.1 ms steps)
    assert delays[115200] == pytest.approx(33 * 10 / 115200, abs=0.0003)
    assert delays[1_000_000] == pytest.approx(33 * 10 / 1e6, abs=0.0003)


def test_line_noise_is_counted_by_the_host_and_does_not_stop_reports():
    host = Host(baud=1_000_000, seed=3, line_noise_hz=100.0)
    host.run(0.01, host.send(p.Hello(1, 65535, 19661, 5000)))
    host.run(1.0)
    errors = host.stream.frames.errors
    assert errors['crc'] + errors['cobs'] + errors['short'] + errors['oversize'] > 30
    assert len(host.reports()) > 150                  # 200 Hz reports, a few lost to noise
    assert np.all(np.diff([m.ticks_us for _, m in host.reports()]) > 0)

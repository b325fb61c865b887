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

"""The emulated MCU's logic (McuCore): handshake, duty limits, interlock, 100 ms watchdog."""
import pytest
from sma_actuator.hardware import protocol as p
from sma_actuator.hardware.mcu_core import FirmwareLimits, McuCore


class Rig:
    """McuCore with a host-side decoder of what it sends."""

    def __init__(self, adc=1234):
        self.mcu = McuCore(lambda: adc)
        self.host = p.MessageStream(accept=p.MCU_TO_HOST)
        self.seq = 0
        self.rx = self.host.feed(self.mcu.start(0))

    def send(self, msg, t_us):
        self.rx = self.host.feed(self.mcu.receive(msg.encode(self.seq), t_us))
        self.seq = (self.seq + 1) & 0xFF
        return [m for _, m in self.rx]

    def poll(self, t_us):
        self.rx = self.host.feed(self.mcu.poll(t_us))
        return [m for _, m in self.rx]

    def hello(self, t_us=0, max_duty=65535, interlock=19661, period=5000):
        return self.send(p.Hello(p.PROTOCOL_VERSION, max_duty, interlock, period), t_us)


def test_boot_status_reports_not_configured_and_duty_is_ignored():
    rig = Rig()
    assert [m.faults for _, m in rig.rx] == [p.FAULT_NOT_CONFIGURED]
    replies = rig.send(p.Duty(30000, 0), 10)
    assert (rig.mcu.pwm_a, rig.mcu.pwm_b) == (0, 0)
    assert replies[0].faults == p.FAULT_NOT_CONFIGURED and replies[0].duty_a == 0


def test_hello_ack_reports_applied_limits():
    rig = Rig()
    ack = rig.hello(max_duty=50000, interlock=60000, period=10)[0]
    lim = FirmwareLimits()
    assert isinstance(ack, p.HelloAck)
    assert (ack.max_duty, ack.interlock_duty) == (50000, lim.interlock_ceiling)  # only tightened
    assert ack.adc_period_us == lim.adc_period_min_us and ack.watchdog_ms == 100
    assert rig.mcu.faults == 0


def test_duty_is_applied_and_answered_with_an_adc_report():
    rig = Rig(adc=777)
    rig.hello()
    report = rig.send(p.Duty(30000, 0), 100)[0]
    assert (rig.mcu.pwm_a, rig.mcu.pwm_b) == (30000, 0)
    assert (report.counts, report.duty_seq, report.ticks_us) == (777, 1, 100)
    assert (report.duty_a, report.duty_b) == (30000, 0)


def test_watchdog_turns_outputs_off_after_100_ms_without_duty():
    rig = Rig()
    rig.hello()
    rig.send(p.Duty(30000, 0), 1000)
    rig.send(p.Heartbeat(1), 60000)            # heartbeats do not feed the watchdog
    rig.poll(100999)
    assert rig.mcu.pwm_a == 30000
    sent = rig.poll(101000)
    assert (rig.mcu.pwm_a, rig.mcu.pwm_b) == (0, 0)
    status = [m for m in sent if isinstance(m, p.Status)]
    assert status and status[0].faults == p.FAULT_WATCHDOG
    rig.send(p.Duty(100, 0), 102000)           # a new duty frame recovers
    assert rig.mcu.pwm_a == 100 and rig.mcu.faults == 0
    assert rig.mcu.faults_latched & p.FAULT_WATCHDOG


def test_interlock_switches_both_off_and_duty_above_max_is_rejected():
    rig = Rig()
    rig.hello(max_duty=40000, interlock=19661)
    rig.send(p.Duty(19662, 19662), 10)
    assert (rig.mcu.pwm_a, rig.mcu.pwm_b) == (0, 0) and rig.mcu.faults == p.FAULT_INTERLOCK
    rig.send(p.Duty(30000, 0), 20)
    rig.send(p.Duty(65535, 0), 30)        # above max_duty: rejected, last valid kept
    assert (rig.mcu.pwm_a, rig.mcu.pwm_b) == (30000, 0) and rig.mcu.faults == p.FAULT_REJECTED
    rig.send(p.Duty(0, 100), 40)          # a just went off: b held for the dead time
    assert (rig.mcu.pwm_a, rig.mcu.pwm_b) == (0, 0) and rig.mcu.faults == p.FAULT_INTERLOCK
    rig.send(p.Duty(0, 100), 25_040)
    assert (rig.mcu.pwm_a, rig.mcu.pwm_b) == (0, 100) and rig.mcu.faults == 0


def test_bad_protocol_version_leaves_mcu_unconfigured():
    rig = Rig()
    ack = rig.send(p.Hello(p.PROTOCOL_VERSION + 1, 65535, 100, 5000), 0)[0]
    assert ack.protocol_version == p.PROTOCOL_VERSION
    assert rig.mcu.faults == p.FAULT_NOT_CONFIGURED | p.FAULT_BAD_VERSION
    rig.send(p.Duty(1000, 0), 10)
    assert rig.mcu.pwm_a == 0


def test_periodic_reports_and_status():
    rig = Rig()
    rig.hello(period=5000)
    kinds = []
    for t in range(1000, 100001, 1000):
        kinds += [type(m).__name__ for m in rig.poll(t)]
    assert kinds.count('AdcReport') == 20 and kinds.count('Status') >= 1


def test_rx_errors_are_counted():
    rig = Rig()
    payload = bytearray(p.cobs_decode(p.Duty(1, 1).encode(0)[:-1]))
    payload[-1] ^= 0x10                         # wrong CRC
    bad_crc = p.cobs_encode(bytes(payload)) + b'\x00'
    rig.mcu.receive(b'junk\x00' + bad_crc + p.AdcReport(0, 0, 0, 0, 0, 0).encode(1), 5)
    assert (rig.mcu.rx_framing_errors, rig.mcu.rx_crc_errors, rig.mcu.rx_malformed) == (1, 1, 1)


@pytest.mark.parametrize('start', [0, 0xFFFFFFFF - 50_000])
def test_watchdog_across_tick_wraparound(start):
    rig = Rig()
    rig.hello(start)
    rig.send(p.Duty(10, 0), start)
    rig.poll((start + 99_999) & 0xFFFFFFFF)
    assert rig.mcu.pwm_a == 10
    rig.poll((start + 100_000) & 0xFFFFFFFF)
    assert rig.mcu.pwm_a == 0

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
The microcontroller's protocol and safety logic, free of hardware and of ROS.

Python twin of ``firmware/sma_mcu/sma_mcu_core.cpp``: both are driven with the same
scenarios in ``firmware/test_vectors.json`` and must produce the same PWM values, fault
bits and transmitted bytes. The MCU emulator runs this class against the simulated plant.

Safety rules (see docs/protocol.md):
- Duty frames are ignored until a valid Hello configured the limits.
- A Duty frame with a channel above max_duty is rejected (FAULT_REJECTED): the outputs
  keep the last valid duty and the frame does not feed the watchdog.
- Dead-time interlock (`control.interlock`, the rule shared with the plant and the
  bridge): a channel may drive only after the other has been off for dead_time_us;
  both requested at once switches both off (FAULT_INTERLOCK) instead of guessing which
  one was meant. `interlock_duty` of the Hello is kept for the protocol; the dead-time
  rule is stricter (any two non-zero duties are refused).
- No valid Duty frame for watchdog_us (100 ms): both outputs off (FAULT_WATCHDOG).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from sma_actuator.control.interlock import DeadTimeInterlock
from sma_actuator.hardware import protocol as p

FIRMWARE_VERSION = (1, 0, 0)
TICK_HZ = 1_000_000   # MCU ticks are microseconds


@dataclass(frozen=True)
class FirmwareLimits:
    """Compile-time constants of the firmware; a Hello can only tighten the duty limits."""

    max_duty: int = p.DUTY_FULL_SCALE     # counts, per channel
    interlock_ceiling: int = 32768        # counts (0.5): highest interlock a Hello may set
    watchdog_us: int = 100_000
    status_period_us: int = 100_000
    adc_period_min_us: int = 1_000
    adc_period_max_us: int = 1_000_000
    adc_bits: int = 12
    # dead time of the interlock: half the bridge's default 0.05 s, so frames of a bridge
    # that keeps its own dead time are never held off by the MCU's (25 ms jitter margin)
    dead_time_us: int = 25_000


def elapsed_us(now_us: int, then_us: int) -> int:
    """Microseconds from `then_us` to `now_us` on the wrapping uint32 tick counter."""
    return (now_us - then_us) & 0xFFFFFFFF


class McuCore:
    """
    MCU logic: feed received bytes and poll regularly; both return the bytes to send.

    `read_adc()` returns the potentiometer's ADC counts; it is called whenever an
    AdcReport is built. `pwm_a`/`pwm_b` are the duty counts the outputs must apply.
    """

    def __init__(self, read_adc: Callable[[], int],
                 limits: FirmwareLimits = FirmwareLimits()) -> None:
        self.read_adc = read_adc
        self.limits = limits
        self.decoder = p.FrameDecoder()
        self.sender = p.Sender()
        self.configured = False
        self.max_duty = 0
        self.interlock_duty = 0
        self.adc_period_us = limits.adc_period_max_us
        self.pwm_a = self.pwm_b = 0
        self.interlock = DeadTimeInterlock(limits.dead_time_us, elapsed_us)
        self.faults = self.faults_latched = p.FAULT_NOT_CONFIGURED
        self.duty_seq = 0
        self.rx_frames = self.rx_crc_errors = self.rx_framing_errors = self.rx_malformed = 0
        self._last_duty_us = self._last_report_us = self._last_status_us = 0
        self._status_faults = -1   # faults as of the last Status sent; -1 forces one

    def start(self, now_us: int) -> bytes:
        """Reset the timers at boot; returns the boot Status frame."""
        self._last_duty_us = self._last_report_us = now_us
        return self._status(now_us)

    def receive(self, data: bytes, now_us: int) -> bytes:
        """Process received bytes (all taken to arrive at `now_us`); returns replies."""
        tx = bytearray()
        for event in self.decoder.events(data):
            if isinstance(event, p.FrameError):
                if event.kind == 'crc':
                    self.rx_crc_errors += 1
                else:
                    self.rx_framing_errors += 1
                continue
            self.rx_frames += 1
            try:
                msg = p.decode_message(event, p.HOST_TO_MCU)
            except p.ProtocolError:
                self.rx_malformed += 1
                continue
            tx += self._handle(msg, event.seq, now_us)
            if self.faults != self._status_faults:
                tx += self._status(now_us)
        return bytes(tx)

    def poll(self, now_us: int) -> bytes:
        """Run the watchdog and the periodic reports; call at least every millisecond."""
        tx = bytearray()
        self.interlock.expire(now_us)
        if (self.configured and not self.faults & p.FAULT_WATCHDOG
                and elapsed_us(now_us, self._last_duty_us) >= self.limits.watchdog_us):
            self._outputs_off(now_us)
            self._set_faults(self.faults | p.FAULT_WATCHDOG)
        if self.configured and elapsed_us(now_us, self._last_report_us) >= self.adc_period_us:
            tx += self._report(now_us)
        if (self.faults != self._status_faults
                or elapsed_us(now_us, self._last_status_us) >= self.limits.status_period_us):
            tx += self._status(now_us)
        return bytes(tx)

    # --- message handlers ---------------------------------------------------------

    def _handle(self, msg: p.Message, seq: int, now_us: int) -> bytes:
        if isinstance(msg, p.Hello):
            return self._hello(msg, now_us)
        if isinstance(msg, p.Duty):
            return self._duty(msg, seq, now_us)
        return self.sender.encode(p.HeartbeatAck(msg.host_us, now_us))

    def _hello(self, msg: p.Hello, now_us: int) -> bytes:
        self._outputs_off(now_us)
        if msg.protocol_version != p.PROTOCOL_VERSION:
            self.configured = False
            self._set_faults(p.FAULT_NOT_CONFIGURED | p.FAULT_BAD_VERSION)
        else:
            lim = self.limits
            self.configured = True
            self.max_duty = min(msg.max_duty, lim.max_duty)
            self.interlock_duty = min(msg.interlock_duty, lim.interlock_ceiling)
            self.adc_period_us = min(
                max(msg.adc_period_us, lim.adc_period_min_us), lim.adc_period_max_us)
            self.faults_latched = 0
            self._set_faults(0)
            self._last_duty_us = self._last_report_us = now_us
        lim = self.limits
        return self.sender.encode(p.HelloAck(
            p.PROTOCOL_VERSION, *FIRMWARE_VERSION, TICK_HZ, lim.adc_bits, lim.watchdog_us // 1000,
            self.max_duty, self.interlock_duty, self.adc_period_us))

    def _duty(self, msg: p.Duty, seq: int, now_us: int) -> bytes:
        self.duty_seq = seq
        if self.configured:
            faults = self.faults & ~(p.FAULT_INTERLOCK | p.FAULT_REJECTED)
            if msg.duty_a > self.max_duty or msg.duty_b > self.max_duty:
                self._set_faults(faults | p.FAULT_REJECTED)   # keep the outputs as they are
                return self._report(now_us)
            (self.pwm_a, self.pwm_b), held = self.interlock.apply(msg.duty_a, msg.duty_b,
                                                                  now_us)
            faults &= ~p.FAULT_WATCHDOG
            if held:
                faults |= p.FAULT_INTERLOCK
            self._set_faults(faults)
            self._last_duty_us = now_us
        return self._report(now_us)

    # --- helpers ------------------------------------------------------------------

    def _outputs_off(self, now_us: int) -> None:
        self.pwm_a, self.pwm_b = self.interlock.reset(now_us)

    def _set_faults(self, faults: int) -> None:
        self.faults = faults
        self.faults_latched |= faults

    def _report(self, now_us: int) -> bytes:
        self._last_report_us = now_us
        return self.sender.encode(p.AdcReport(
            now_us, int(self.read_adc()), self.duty_seq, self.faults, self.pwm_a, self.pwm_b))

    def _status(self, now_us: int) -> bytes:
        self._last_status_us = now_us
        self._status_faults = self.faults
        return self.sender.encode(p.Status(
            now_us, self.faults, self.faults_latched, self.rx_frames & 0xFFFFFFFF,
            self.rx_crc_errors & 0xFFFFFFFF, self.rx_framing_errors & 0xFFFFFFFF,
            self.rx_malformed & 0xFFFFFFFF))

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
The bridge's ROS-free logic against the real MCU logic, on simulated time.

BridgeCore and McuCore exchange their bytes directly (no port, no plant): the safety
rules of issue 4 are checked at the MCU's outputs, where they matter.
"""
import math

import pytest
from sma_actuator.hardware import protocol as p
from sma_actuator.hardware.bridge_core import (BridgeConfig, BridgeCore, LinkState, sanitize_duty,
                                               to_counts)
from sma_actuator.hardware.calibration import AdcCalibration
from sma_actuator.hardware.mcu_core import FirmwareLimits, McuCore


class Rig:
    """A bridge wired to an MCU; `run(t)` advances both to time t [s] in 1 ms steps."""

    def __init__(self, config=BridgeConfig(), limits=FirmwareLimits(), adc=2048):
        self.t = 0.0
        self.adc = adc
        self.logs = []
        self.bridge = BridgeCore(config, AdcCalibration(-1.2, 2.4 / 4095), 0.0,
                                 log=lambda level, text: self.logs.append((level, text)))
        self.mcu = McuCore(lambda: self.adc, limits)
        self.samples = []
        self.pwm_trace = []          # (t, pwm_a, pwm_b) after every step
        self.connected = True
        self._to_bridge = self.mcu.start(0)
        self._to_mcu = self.bridge.on_open(0.0)

    def command(self, a, b):
        self._to_mcu += self.bridge.on_duty_command([a, b], self.t)

    def run(self, until_s, command=None):
        while self.t < until_s - 1e-9:
            self.t = round(self.t + 0.001, 6)
            if command is not None:
                self.command(*command)
            t_us = int(self.t * 1e6)
            if self.connected:
                self._to_bridge += self.mcu.receive(self._to_mcu, t_us) + self.mcu.poll(t_us)
                tx, samples = self.bridge.on_data(self._to_bridge, self.t)
                self.samples += samples
                self._to_mcu = tx
            else:
                self._to_mcu = b''
            self._to_bridge = b''
            self._to_mcu += self.bridge.tick(self.t)
            self.pwm_trace.append((self.t, self.mcu.pwm_a, self.mcu.pwm_b))

    def diag(self, name):
        return next(d for d in self.bridge.diagnostics() if d[0] == name)


def test_handshake_then_duty_reaches_the_outputs_and_reports_come_back():
    rig = Rig()
    rig.run(0.01)
    assert rig.bridge.state == LinkState.CONNECTED and rig.mcu.configured
    rig.run(0.1, command=(0.5, 0.0))
    assert (rig.mcu.pwm_a, rig.mcu.pwm_b) == (to_counts(0.5), 0)
    assert rig.samples and rig.samples[-1].counts == 2048
    assert rig.samples[-1].angle_rad == pytest.approx(-1.2 + 2048 * 2.4 / 4095)
    assert rig.diag('link')[1] == 'ok' and rig.diag('mcu')[1] == 'ok'
    assert rig.bridge.duty_latency_s and rig.bridge.rtt_s   # both round trips measured


def test_host_watchdog_sends_zero_duty_after_timeout_and_warns_once():
    rig = Rig()
    rig.run(0.5, command=(0.6, 0.0))
    assert rig.mcu.pwm_a == to_counts(0.6)
    rig.run(1.5)                                       # commands stop at t = 0.5 s
    off = next(t for t, a, b in rig.pwm_trace if t > 0.5 and a == 0)
    assert 0.7 <= off <= 0.71                          # 200 ms timeout + 5 ms tick
    assert not rig.mcu.faults & p.FAULT_WATCHDOG       # the host zeroed it, kept the MCU fed
    warnings = [text for level, text in rig.logs if level == 'warn' and 'no /sma/duty' in text]
    assert len(warnings) == 1
    assert rig.diag('duty')[1] == 'warn'
    rig.run(1.6, command=(0.1, 0.0))
    assert rig.mcu.pwm_a == to_counts(0.1) and rig.diag('duty')[1] == 'ok'


def test_mcu_watchdog_trips_when_the_host_goes_silent():
    rig = Rig()
    rig.run(0.3, command=(0.4, 0.0))
    rig.connected = False   # host->MCU bytes stop (host hung, cable cut)
    for step in range(150):
        t_us = int((0.3 + 0.001 * (step + 1)) * 1e6)
        rig.mcu.poll(t_us)
        if rig.mcu.pwm_a == 0:
            break
    assert step + 1 == 100 and rig.mcu.faults & p.FAULT_WATCHDOG


@pytest.mark.parametrize('command', [(0.6, 0.5), (0.4, 0.9), (0.3, 0.3), (0.01, 0.01)])
def test_both_wires_requested_at_once_heat_neither(command):
    rig = Rig()
    rig.run(0.2, command=command)
    assert all((a, b) == (0, 0) for _, a, b in rig.pwm_trace)
    assert rig.bridge.counters['interlock_held'] > 0
    assert not rig.mcu.faults & p.FAULT_INTERLOCK      # the firmware never had to refuse a frame


def test_alternating_commands_never_heat_a_wire_within_the_dead_time_of_the_other():
    # two controllers at 40 Hz, [0.62, 0] / [0, 0.62] (issue 13 item 1), as the MCU applies it
    rig = Rig(BridgeConfig(interlock_dead_time_s=0.1))
    for k in range(80):
        rig.command(*((0.62, 0.0) if k % 2 else (0.0, 0.62)))
        rig.run(rig.t + 0.025)
    off_at, before = [None, None], (0, 0)
    for t, *pair in rig.pwm_trace:
        for wire in (0, 1):
            if before[wire] and not pair[wire]:
                off_at[wire] = t
            if pair[wire] and off_at[1 - wire] is not None:
                assert t - off_at[1 - wire] >= 0.1 - 1e-9
        before = pair
    assert not any(a and b for _, a, b in rig.pwm_trace)
    assert not rig.mcu.faults_latched & p.FAULT_INTERLOCK


def test_a_reversal_waits_the_dead_time_then_heats():
    rig = Rig(BridgeConfig(interlock_dead_time_s=0.1))
    rig.run(0.2, command=(0.5, 0.0))
    t_off = rig.t
    rig.run(0.5, command=(0.0, 0.4))
    on_b = [t for t, a, b in rig.pwm_trace if b]
    assert on_b and 0.1 <= on_b[0] - t_off <= 0.1 + 0.03    # dead time + one refresh + 1 ms
    assert (rig.mcu.pwm_a, rig.mcu.pwm_b) == (0, to_counts(0.4))


def test_the_applied_duty_is_what_the_mcu_outputs():
    # clamped to max_duty, a reversal held at the interlock, then the host watchdog
    rig = Rig(BridgeConfig(interlock_dead_time_s=0.1, max_duty=0.7))
    applied, outputs = [], []
    for until, command in ((0.2, (0.9, 0.0)), (0.5, (0.0, 0.4)), (1.0, None)):
        while rig.t < until - 1e-9:
            if command and round(rig.t * 1000) % 25 == 0:   # a controller at 40 Hz
                rig.command(*command)
            rig.run(rig.t + 0.001)
            # the frames sent so far reach the MCU (the rig delivers them a step later)
            rig._to_bridge += rig.mcu.receive(rig._to_mcu, int(rig.t * 1e6))
            rig._to_mcu = b''
            applied.append(rig.bridge.applied_duty())
            outputs.append((rig.mcu.pwm_a / p.DUTY_FULL_SCALE, rig.mcu.pwm_b / p.DUTY_FULL_SCALE))
    assert applied == outputs
    assert set(applied) == {(0.0, 0.0), (to_counts(0.7) / p.DUTY_FULL_SCALE, 0.0),
                            (0.0, to_counts(0.4) / p.DUTY_FULL_SCALE)}
    rig.run(1.1, command=(0.3, 0.0))
    assert rig.bridge.applied_duty() != (0.0, 0.0)
    rig.bridge.on_close('read failed: device disconnected', rig.t)
    assert rig.bridge.applied_duty() == (0.0, 0.0)


def test_duty_above_max_duty_is_limited():
    rig = Rig(BridgeConfig(max_duty=0.7))
    rig.run(0.1, command=(0.9, 0.0))
    assert (rig.mcu.pwm_a, rig.mcu.pwm_b) == (to_counts(0.7), 0)
    assert rig.bridge.counters['clamped'] > 0
    assert any('duty_a=0.9 above max_duty 0.7' in text for _, text in rig.logs), rig.logs


@pytest.mark.parametrize('values, message', [
    ([0.5], 'must have 2 entries'), ([0.1, 0.2, 0.3], 'must have 2 entries'),
    ([math.nan, 0.0], 'duty_a nan is not finite'), ([0.0, math.inf], 'duty_b inf'),
    ([1e308, 0.0], 'outside [0, 1]'), ([2.0, 0.0], 'outside [0, 1]'),
    ([-0.1, 0.0], 'outside [0, 1]'), ([0.0, -math.inf], 'not finite')])
def test_bad_command_is_rejected_and_the_last_valid_one_kept(values, message):
    # issue 13 item 3: [1e308, 0] and [2.0, 0] used to become PWM 65535
    rig = Rig()
    rig.run(0.1, command=(0.5, 0.0))
    for _ in range(3):
        rig._to_mcu += rig.bridge.on_duty_command(values, rig.t)
        rig.run(rig.t + 0.01, command=None)
    assert (rig.mcu.pwm_a, rig.mcu.pwm_b) == (to_counts(0.5), 0)
    assert max(max(a, b) for _, a, b in rig.pwm_trace) == to_counts(0.5)
    level, text, = rig.diag('duty')[1:3]
    assert level == 'error' and message in text
    assert any(level == 'error' and message in text for level, text in rig.logs)
    rig.run(rig.t + 0.25)     # bad commands do not feed the host watchdog
    assert (rig.mcu.pwm_a, rig.mcu.pwm_b) == (0, 0)


def test_stale_command_is_dropped_and_does_not_feed_the_watchdog():
    rig = Rig()
    rig.run(0.1, command=(0.5, 0.0))
    rig.run(0.4)                                    # watchdog: zero
    assert (rig.mcu.pwm_a, rig.mcu.pwm_b) == (0, 0)
    rig._to_mcu += rig.bridge.on_duty_command([0.5, 0.0], rig.t, age_s=0.25)
    rig.run(0.5)
    assert all((a, b) == (0, 0) for t, a, b in rig.pwm_trace if t > 0.4)
    assert rig.bridge.counters['stale_commands'] == 1


def test_a_frame_written_after_a_freeze_becomes_zero_duty():
    # the node runs the watchdog on the clock of every write (`_write`): a process frozen
    # between checking a command and writing its frame must not send it on waking
    rig = Rig()
    rig.run(0.3, command=(0.5, 0.0))
    frame = rig.bridge.on_duty_command([0.5, 0.0], rig.t)
    assert frame and rig.bridge.watchdog(rig.t + 0.1) == b''   # a short stall: it stands
    for t_ms in range(301, 1301):                  # frozen for 1 s; the MCU runs on
        rig.mcu.poll(t_ms * 1000)
    assert rig.mcu.faults & p.FAULT_WATCHDOG and rig.mcu.pwm_a == 0
    sent = rig.bridge.watchdog(1.3) or frame
    assert sent != frame and rig.bridge.duty_timed_out
    rig.mcu.receive(sent, 1_300_000)
    assert (rig.mcu.pwm_a, rig.mcu.pwm_b) == (0, 0)
    assert any('no /sma/duty for 1.000 s' in text for _, text in rig.logs)


def test_more_than_one_duty_publisher_zeroes_the_duty_with_an_error():
    rig = Rig()
    rig.run(0.1, command=(0.5, 0.0))
    rig._to_mcu += rig.bridge.on_publisher_count(2, rig.t)
    rig.run(0.2, command=(0.5, 0.0))
    assert (rig.mcu.pwm_a, rig.mcu.pwm_b) == (0, 0)
    assert rig.diag('duty')[1] == 'error' and '2 publishers' in rig.diag('duty')[2]
    rig._to_mcu += rig.bridge.on_publisher_count(1, rig.t)
    rig.run(0.25, command=(0.5, 0.0))
    assert rig.mcu.pwm_a == to_counts(0.5)


def test_mcu_limits_tighter_than_config_are_adopted():
    rig = Rig(BridgeConfig(interlock_threshold=0.9), limits=FirmwareLimits(max_duty=40000))
    rig.run(0.2, command=(0.8, 0.0))
    assert rig.bridge.interlock_counts == FirmwareLimits().interlock_ceiling
    assert max(a for _, a, _ in rig.pwm_trace) == 40000
    assert not rig.mcu.faults & (p.FAULT_INTERLOCK | p.FAULT_REJECTED)


def test_link_closed_zero_duty_error_and_clean_reconnect():
    rig = Rig()
    rig.run(0.2, command=(0.5, 0.0))
    rig.bridge.on_close('read failed: device disconnected', rig.t)
    assert rig.bridge.state == LinkState.DISCONNECTED and rig.bridge.duty == (0, 0)
    assert rig.diag('link')[1] == 'error' and 'device disconnected' in rig.diag('link')[2]
    assert rig.bridge.on_duty_command([0.5, 0.0], rig.t) == b''   # nothing sent while closed
    assert rig.bridge.duty == (0, 0) and rig.diag('duty')[1] == 'warn'
    rig._to_mcu = rig.bridge.on_open(rig.t)
    rig.run(0.25)
    assert rig.bridge.state == LinkState.CONNECTED
    assert rig.mcu.pwm_a == 0                           # reconnect starts from zero duty


def test_silent_mcu_is_a_lost_link_and_a_reset_mcu_is_reconfigured():
    rig = Rig()
    rig.run(0.2, command=(0.5, 0.0))
    rig.connected = False
    rig.run(0.8)
    assert rig.bridge.state == LinkState.HANDSHAKING and rig.diag('link')[1] == 'error'
    errors = [text for level, text in rig.logs if level == 'error']
    assert any('no valid frame from the MCU' in text for text in errors)
    rig.mcu = McuCore(lambda: rig.adc)                 # MCU rebooted meanwhile
    rig._to_bridge = rig.mcu.start(int(rig.t * 1e6))
    rig.connected = True
    rig.run(1.2, command=(0.2, 0.0))
    assert rig.bridge.state == LinkState.CONNECTED and rig.mcu.pwm_a == to_counts(0.2)


def test_garbage_between_frames_is_counted_and_skipped():
    rig = Rig()
    rig.run(0.05)
    n = len(rig.samples)
    truncated = p.AdcReport(1, 100, 0, 0, 0, 0).encode(200)[:-4] + b'\x00'
    good = p.AdcReport(2, 300, 0, 0, 0, 0).encode(201)
    _, samples = rig.bridge.on_data(b'\x13\x37\x00' + truncated + good, rig.t)
    assert [s.counts for s in samples] == [300]
    rig.run(0.1)
    assert len(rig.samples) > n
    values = rig.diag('link')[3]
    assert values['framing_errors'] + values['crc_errors'] == 2


def test_protocol_version_mismatch_is_an_error_and_never_connects():
    rig = Rig()
    _, samples = rig.bridge.on_data(p.HelloAck(9, 1, 0, 0, 10**6, 12, 100, 1, 1, 1).encode(0), 0.0)
    assert rig.bridge.state == LinkState.HANDSHAKING
    assert 'protocol v9' in rig.diag('link')[2] and rig.diag('link')[1] == 'error'


def test_sanitize_duty_notes_and_errors():
    a, b, notes = sanitize_duty([0.2, 0.1], 65535)
    assert (a, b, notes) == (to_counts(0.2), to_counts(0.1), [])
    with pytest.raises(ValueError, match=r'2 entries \[duty_a, duty_b\], got 0'):
        sanitize_duty([], 65535)


@pytest.mark.parametrize('duty', [math.nan, math.inf, 1e308, 2.0, -0.1, 'x', None])
def test_protocol_duty_to_counts_never_clamps_garbage(duty):
    with pytest.raises(p.ProtocolError):
        p.duty_to_counts(duty)
    assert p.duty_to_counts(1.0) == 65535 and p.duty_to_counts(0.0) == 0


@pytest.mark.parametrize('field, value', [
    ('max_duty', 1.5), ('duty_timeout_s', 0.0), ('duty_refresh_s', 0.2)])
def test_config_rejects_bad_values_naming_them(field, value):
    with pytest.raises(ValueError, match=field):
        BridgeConfig(**{field: value})


def test_a_duplicate_hello_ack_restores_the_current_command():
    # A slow MCU answers the first Hello and a retried one: the second Hello switched the
    # outputs off, so the bridge must re-send the running command, not fall back to zero.
    rig = Rig()
    rig.run(0.1, command=(0.4, 0.0))
    rig._to_mcu += rig.bridge._hello(rig.t)     # what a Hello retry would send
    rig.run(0.101)
    assert rig.mcu.pwm_a == 0                   # the MCU obeyed the Hello
    rig.run(0.103)
    assert rig.bridge.state == LinkState.CONNECTED and rig.bridge.duty == (to_counts(0.4), 0)
    assert rig.mcu.pwm_a == to_counts(0.4)

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
Host side of the hardware bridge, free of ROS and of the serial port.

`BridgeCore` turns duty commands into Duty frames and received frames into joint
samples, and owns the host's safety rules:

- duty commands are validated (`control.inputs.duty_problem`, the plant's rule); invalid
  ones (wrong length, NaN/inf, outside [0, 1]) are rejected and the last valid command
  is kept; values above max_duty are limited to it;
- a command older than duty_timeout_s when it is taken (a frozen or overloaded bridge,
  see docs/safety.md) is dropped and does not feed the watchdog;
- dead-time interlock (`control.interlock`) on the duty sent to the MCU: a wire heats
  only after the other has had zero duty for interlock_dead_time_s;
- more than one publisher on the duty topic (reported by the node): zero duty, ERROR;
- host watchdog: no duty command for duty_timeout_s -> zero duty, WARN;
- a link that closes, goes silent for link_timeout_s or restarts the MCU drops to zero
  duty and re-handshakes; duty frames are only sent after a HelloAck.

All times are monotonic seconds passed in by the caller; methods return the bytes to
write to the port. The caller serialises calls (one lock) and writes in call order.
"""
from __future__ import annotations

import collections
from dataclasses import dataclass
import enum
import math
from typing import Callable

import numpy as np
from sma_actuator.control.inputs import duty_problem
from sma_actuator.control.interlock import BOTH_REQUESTED, DeadTimeInterlock, DEFAULT_DEAD_TIME_S
from sma_actuator.hardware import protocol as p
from sma_actuator.hardware.calibration import AdcCalibration, VelocityEstimator


class LinkState(enum.Enum):
    """Connection state of the bridge to the MCU."""

    DISCONNECTED = 'disconnected'   # port closed (unplugged, cannot open)
    HANDSHAKING = 'handshaking'     # port open, waiting for a HelloAck
    CONNECTED = 'connected'         # HelloAck received, duty frames flowing


@dataclass
class BridgeConfig:
    """Timing and limits of the bridge (duties as fractions 0..1, times in s)."""

    max_duty: float = 1.0
    interlock_threshold: float = 0.3
    duty_timeout_s: float = 0.2
    duty_refresh_s: float = 0.02
    link_timeout_s: float = 0.5
    hello_retry_s: float = 0.25
    heartbeat_period_s: float = 0.2
    adc_period_s: float = 0.005
    # two command periods; twice the firmware's 25 ms, so the MCU never holds off a frame
    interlock_dead_time_s: float = DEFAULT_DEAD_TIME_S

    def __post_init__(self) -> None:
        for name in ('max_duty', 'interlock_threshold'):
            value = getattr(self, name)
            if not 0.0 <= value <= 1.0:
                raise ValueError(f'{name} must be in [0, 1], got {value}')
        for name in ('duty_timeout_s', 'duty_refresh_s', 'link_timeout_s', 'hello_retry_s',
                     'heartbeat_period_s', 'adc_period_s'):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f'{name} must be a positive number of seconds, got {value}')
        if not (math.isfinite(self.interlock_dead_time_s)
                and 0.025 <= self.interlock_dead_time_s <= 10.0):
            raise ValueError(f'interlock_dead_time_s={self.interlock_dead_time_s} must be in '
                             '[0.025, 10] s (not below the firmware dead time of 0.025 s)')
        if self.duty_refresh_s >= 0.1:
            raise ValueError(
                f'duty_refresh_s={self.duty_refresh_s} must stay below the 0.1 s MCU watchdog')


@dataclass(frozen=True)
class JointSample:
    """One potentiometer reading, calibrated."""

    angle_rad: float
    velocity_rad_s: float
    counts: int
    ticks_us: int
    duty_seq: int


to_counts = p.duty_to_counts


def sanitize_duty(values, max_counts: int) -> tuple[int, int, list[str]]:
    """
    Validate and limit a [duty_a, duty_b] command; return (a, b) in counts and notes.

    Raises ValueError naming the problem for input that is not a valid duty pair (the
    plant's rule, `duty_problem`). Notes describe every change made (max_duty limit).
    """
    values = list(values)
    problem = duty_problem(values)
    if problem:
        raise ValueError(problem)
    notes, counts = [], []
    for name, value in zip(('duty_a', 'duty_b'), values):
        c = to_counts(value)
        if c > max_counts:
            notes.append(
                f'{name}={value:g} above max_duty {max_counts / p.DUTY_FULL_SCALE:.4g}, limited')
            c = max_counts
        counts.append(c)
    return counts[0], counts[1], notes


class BridgeCore:
    """State machine of the bridge; see the module docstring. `log(level, text)` reports events."""

    def __init__(self, config: BridgeConfig, calibration: AdcCalibration, now_s: float,
                 velocity_tau_s: float = 0.02,
                 log: Callable[[str, str], None] = lambda level, text: None) -> None:
        self.config, self.calibration, self._log = config, calibration, log
        self.velocity = VelocityEstimator(velocity_tau_s)
        self.stream = p.MessageStream(accept=p.MCU_TO_HOST)
        self.sender = p.Sender()
        self.state = LinkState.DISCONNECTED
        self.link_error = 'port not opened yet'
        self.mcu = None                 # HelloAck of the connected MCU
        self.mcu_status = None          # last Status
        self.mcu_faults = 0
        self.duty = (0, 0)              # counts currently commanded to the MCU
        self.requested = (0, 0)         # counts of the last valid command (before interlock)
        self.interlock = DeadTimeInterlock(config.interlock_dead_time_s)
        self.publishers = 1             # publishers on the duty topic (set by the node)
        self.max_counts = to_counts(config.max_duty)
        self.interlock_counts = to_counts(config.interlock_threshold)
        self.duty_timed_out = False
        self.watchdog_trip = None       # (silence, tick gap) [s] when the host watchdog tripped
        self._last_tick_s = now_s
        self.last_command_bad = ''
        self.counters = collections.Counter()
        self.rtt_s = collections.deque(maxlen=100)          # heartbeat round trips
        self.duty_latency_s = collections.deque(maxlen=500)  # duty frame -> its first ADC report
        self._start_s = self._last_command_s = now_s
        self._last_rx_s = self._last_hello_s = self._last_duty_s = self._last_heartbeat_s = now_s
        self._duty_sent = {}            # duty seq -> send time, until its report arrives
        self._heartbeats = {}           # host_us -> send time
        self._throttle = {}

    # --- link events --------------------------------------------------------------------

    def on_open(self, now_s: float) -> bytes:
        """Port opened: start the handshake (a leading delimiter resyncs the MCU's decoder)."""
        self.stream.reset()
        self.velocity.reset()
        self.link_error = ''
        self._enter(LinkState.HANDSHAKING, now_s)
        self._last_rx_s = now_s
        return b'\x00' + self._hello(now_s)

    def on_close(self, reason: str, now_s: float, failure: bool = True) -> None:
        """Port closed (failure=False: on purpose, at shutdown): zero duty, report why."""
        self.link_error = reason
        if failure and self.state != LinkState.DISCONNECTED:
            self._log('error', f'serial link lost: {reason}; duty set to zero, reconnecting')
        self._enter(LinkState.DISCONNECTED, now_s)

    def on_open_failed(self, reason: str, now_s: float) -> None:
        """Open the port failed (retried with backoff by the link)."""
        self.link_error = reason
        self.counters['open_failures'] += 1
        self._log_throttled('open', 'error', f'{reason} (retrying with backoff)', now_s)

    def on_data(self, data: bytes, now_s: float) -> tuple[bytes, list[JointSample]]:
        """Bytes from the MCU; returns bytes to send and the joint samples they carried."""
        tx, samples = bytearray(), []
        self.counters['bytes_received'] += len(data)
        for _, msg in self.stream.feed(data):
            self._last_rx_s = now_s
            if isinstance(msg, p.HelloAck):
                tx += self._on_hello_ack(msg, now_s)
            elif self.state != LinkState.CONNECTED:
                continue   # nothing else counts before the handshake confirmed the protocol
            elif isinstance(msg, p.AdcReport):
                samples.append(self._on_report(msg, now_s))
                tx += self._on_faults(msg.faults, now_s)
            elif isinstance(msg, p.Status):
                self.mcu_status = msg
                tx += self._on_faults(msg.faults, now_s)
            elif isinstance(msg, p.HeartbeatAck):
                sent = self._heartbeats.pop(msg.host_us, None)
                if sent is not None:
                    self.rtt_s.append(now_s - sent)
        return bytes(tx), samples

    # --- duty commands ------------------------------------------------------------------

    def on_duty_command(self, values, now_s: float, age_s: float = 0.0) -> bytes:
        """
        Take a /sma/duty command [duty_a, duty_b]; return the Duty frame to send.

        `age_s` is how long ago the command was sent (its source timestamp); a command older
        than duty_timeout_s is dropped: its sender may be dead for that long already.
        """
        self.counters['commands'] += 1
        if not age_s <= self.config.duty_timeout_s:
            self.counters['stale_commands'] += 1
            self._log_throttled('stale', 'warn', f'dropped a /sma/duty command {age_s:.3f} s '
                                f'old (older than duty_timeout_s '
                                f'{self.config.duty_timeout_s:g} s)', now_s)
            return b''
        try:
            a, b, notes = sanitize_duty(values, self.max_counts)
        except (ValueError, TypeError) as exc:
            self.counters['bad_commands'] += 1
            self.last_command_bad = str(exc)
            self._log_throttled('bad', 'error', f'rejected /sma/duty command: {exc}; keeping '
                                f'the last valid one', now_s)
            return b''   # not a command: it does not feed the watchdog either
        self.last_command_bad = ''
        self._last_command_s = now_s
        if self.duty_timed_out:
            self.duty_timed_out = False
            self._log('info', 'duty commands resumed')
        for note in notes:
            self.counters['clamped'] += 1
            self._log_throttled(note.split('=')[0], 'warn', f'/sma/duty: {note}', now_s)
        self.requested = (a, b)
        if self.state != LinkState.CONNECTED:
            self.counters['commands_dropped'] += 1   # zero-duty state until (re)connected
            return b''
        self._apply(now_s)
        return self._send_duty(now_s)

    def on_publisher_count(self, count: int, now_s: float) -> bytes:
        """
        Take the number of publishers on the duty topic; return the frame to send.

        More than one (two controllers alternating their commands): zero duty and ERROR
        until only one is left.
        """
        before, self.publishers = self.publishers, count
        if count > 1 and before <= 1:
            self.counters['publisher_conflicts'] += 1
            self._log('error', f'{count} publishers on the duty topic: zero duty until one '
                               'is left')
            self._apply(now_s)
            return self._send_duty(now_s)
        if count <= 1 < before:
            self._log('info', 'one publisher on the duty topic again')
        return b''

    def _apply(self, now_s: float) -> None:
        """Set the duty sent to the MCU from the last command, the gates and the interlock."""
        allowed = self.state == LinkState.CONNECTED and not self.duty_timed_out
        requested = self.requested if allowed and self.publishers <= 1 else (0, 0)
        self.duty, held = self.interlock.apply(*requested, now_s)
        if held:
            self.counters['interlock_held'] += 1
        if held == BOTH_REQUESTED:    # a reversal waiting out the dead time is normal
            self._log_throttled('held', 'warn', f'interlock: {held}; sending '
                                f'{self.duty[0]}/{self.duty[1]} counts', now_s)

    def tick(self, now_s: float) -> bytes:
        """Timers: host watchdog, duty refresh, heartbeat, Hello retry, link timeout."""
        cfg, tx = self.config, bytearray()
        tx += self.watchdog(now_s)
        self._last_tick_s = now_s
        if self.state == LinkState.DISCONNECTED:
            return bytes(tx)
        if now_s - self._last_rx_s > cfg.link_timeout_s:
            self.link_error = f'no valid frame from the MCU for {now_s - self._last_rx_s:.2f} s'
            if self.state == LinkState.CONNECTED:
                self._log('error', f'{self.link_error}: duty set to zero, re-handshaking')
                self._enter(LinkState.HANDSHAKING, now_s)
        if self.state == LinkState.HANDSHAKING:
            if now_s - self._last_hello_s >= cfg.hello_retry_s:
                tx += self._hello(now_s)
            return bytes(tx)
        if now_s - self._last_duty_s >= cfg.duty_refresh_s:
            self._apply(now_s)       # a wire held by the interlock starts after the dead time
            tx += self._send_duty(now_s)
        if now_s - self._last_heartbeat_s >= cfg.heartbeat_period_s:
            self._last_heartbeat_s = now_s
            host_us = int(now_s * 1e6) & 0xFFFFFFFF
            self._heartbeats = {k: v for k, v in self._heartbeats.items() if now_s - v < 5.0}
            self._heartbeats[host_us] = now_s
            tx += self.sender.encode(p.Heartbeat(host_us))
        return bytes(tx)

    def watchdog(self, now_s: float) -> bytes:
        """
        Host watchdog: no accepted command for duty_timeout_s -> zero duty; the frame to send.

        `tick` runs it first, and the node runs it again on the clock of every write: a
        process frozen (SIGSTOP, a stalled host) after it made a frame and before it wrote
        it sends zero duty when it wakes, not a frame of a command that has gone stale.
        """
        cfg = self.config
        silent_s = now_s - self._last_command_s
        if self.duty_timed_out or silent_s <= cfg.duty_timeout_s:
            return b''
        self.duty_timed_out = True
        self.watchdog_trip = (silent_s, now_s - self._last_tick_s)
        self.counters['host_watchdog_trips'] += 1
        self.requested = (0, 0)
        self._apply(now_s)
        self._log('warn', f'no /sma/duty for {silent_s:.3f} s '
                          f'(timeout {cfg.duty_timeout_s} s): sending zero duty')
        return self._send_duty(now_s)

    def applied_duty(self) -> tuple[float, float]:
        """
        Return (duty_a, duty_b) [0..1]: the duty of the last Duty frame sent to the MCU.

        What the wires get after the gates, the dead-time interlock and the max_duty clamp,
        in the MCU's counts; zero while the MCU is not connected (its watchdog has switched
        the outputs off).
        """
        if self.state != LinkState.CONNECTED:
            return 0.0, 0.0
        return self.duty[0] / p.DUTY_FULL_SCALE, self.duty[1] / p.DUTY_FULL_SCALE

    def shutdown(self) -> bytes:
        """Zero-duty frame to send before closing the port (empty if not connected)."""
        self.duty = (0, 0)
        self.requested = (0, 0)
        if self.state != LinkState.CONNECTED:
            return b''
        return self.sender.encode(p.Duty(0, 0))

    # --- internals ----------------------------------------------------------------------

    def _enter(self, state: LinkState, now_s: float) -> None:
        if state != LinkState.CONNECTED:
            # the MCU's watchdog switches off; never resume an old command
            self.duty = self.interlock.reset(now_s)
            self.requested = (0, 0)
            self._duty_sent.clear()
        self.state = state

    def _hello(self, now_s: float) -> bytes:
        self._last_hello_s = now_s
        cfg = self.config
        period_us = int(round(cfg.adc_period_s * 1e6))
        return self.sender.encode(p.Hello(p.PROTOCOL_VERSION, self.max_counts,
                                          self.interlock_counts, period_us))

    def _on_hello_ack(self, ack: p.HelloAck, now_s: float) -> bytes:
        if ack.protocol_version != p.PROTOCOL_VERSION:
            self.link_error = (f'MCU speaks protocol v{ack.protocol_version}, '
                               f'bridge v{p.PROTOCOL_VERSION}')
            self._log_throttled('version', 'error', self.link_error, now_s)
            return b''
        self.mcu, self.mcu_faults = ack, 0
        # The firmware may only tighten the limits; adopt its values so we never send a
        # frame it would refuse.
        self.max_counts = min(to_counts(self.config.max_duty), ack.max_duty)
        self.interlock_counts = min(to_counts(self.config.interlock_threshold), ack.interlock_duty)
        if self.state == LinkState.CONNECTED:
            # A second answer to a retried Hello: the MCU switched its outputs off for that
            # Hello, so restore the current command (limited to the limits just adopted).
            self.requested = tuple(min(x, self.max_counts) for x in self.requested)
            self._apply(now_s)
            return self._send_duty(now_s)
        self._log('info', f'connected: MCU firmware {ack.fw_major}.{ack.fw_minor}.'
                          f'{ack.fw_patch}, {ack.adc_bits}-bit ADC, limits max '
                          f'{ack.max_duty} interlock {ack.interlock_duty}')
        self.state = LinkState.CONNECTED
        self.link_error = ''
        self.duty = self.interlock.reset(now_s)
        self._last_heartbeat_s = now_s - self.config.heartbeat_period_s   # measure RTT at once
        return self._send_duty(now_s)

    def _on_report(self, report: p.AdcReport, now_s: float) -> JointSample:
        sent = self._duty_sent.pop(report.duty_seq, None)
        if sent is not None:
            self.duty_latency_s.append(now_s - sent)
        angle = self.calibration.angle_rad(report.counts)
        velocity = self.velocity.update(report.ticks_us, angle)
        return JointSample(angle, velocity, report.counts, report.ticks_us, report.duty_seq)

    def _on_faults(self, faults: int, now_s: float) -> bytes:
        new = faults & ~self.mcu_faults
        self.mcu_faults = faults
        if new:
            level = 'error' if new & (p.FAULT_INTERLOCK | p.FAULT_BAD_VERSION) else 'warn'
            names = ', '.join(p.fault_names(new))
            self._log_throttled(f'fault{new}', level, f'MCU fault: {names}', now_s)
        if faults & p.FAULT_NOT_CONFIGURED:
            # The MCU restarted (brown-out, reset button): configure it again.
            self._log('warn', 'MCU reports it is not configured (reset?): re-handshaking')
            self._enter(LinkState.HANDSHAKING, now_s)
            return self._hello(now_s)
        return b''

    def _send_duty(self, now_s: float) -> bytes:
        if self.state != LinkState.CONNECTED:
            return b''
        self._last_duty_s = now_s
        seq = self.sender.seq
        if len(self._duty_sent) > 64:   # reports lost: keep the map small
            self._duty_sent.clear()
        self._duty_sent[seq] = now_s
        return self.sender.encode(p.Duty(*self.duty))

    def _log_throttled(self, key: str, level: str, text: str, now_s: float,
                       period_s: float = 1.0) -> None:
        if now_s - self._throttle.get(key, -math.inf) >= period_s:
            self._throttle[key] = now_s
            self._log(level, text)

    # --- diagnostics --------------------------------------------------------------------

    def diagnostics(self) -> list[tuple[str, str, str, dict]]:
        """
        (name, level, message, values) for the link, the MCU and the duty path.

        level is 'ok', 'warn', 'error' or 'stale'.
        """
        return [self._link_diag(), self._mcu_diag(), self._duty_diag()]

    def _link_diag(self):
        errors = self.stream.frames.errors
        values = {
            'state': self.state.value, 'last_error': self.link_error,
            'frames_received': self.stream.frames.frames,
            'bytes_received': self.counters['bytes_received'], 'crc_errors': errors['crc'],
            'framing_errors': errors['cobs'] + errors['short'] + errors['oversize'],
            'malformed_frames': self.stream.malformed, 'frames_lost': self.stream.lost,
            'open_failures': self.counters['open_failures'],
            'rtt_ms_last': _ms(self.rtt_s[-1]) if self.rtt_s else 'n/a',
            'rtt_ms_p50': _ms_pct(self.rtt_s, 50),
            'rtt_ms_max': _ms(max(self.rtt_s)) if self.rtt_s else 'n/a',
            'duty_to_report_ms_p50': _ms_pct(self.duty_latency_s, 50),
            'duty_to_report_ms_p99': _ms_pct(self.duty_latency_s, 99),
        }
        if self.state == LinkState.CONNECTED:
            return 'link', 'ok', 'connected', values
        if self.state == LinkState.HANDSHAKING and not self.link_error:
            return 'link', 'warn', 'handshaking', values
        return 'link', 'error', f'{self.state.value}: {self.link_error}', values

    def _mcu_diag(self):
        values = {'faults': ' '.join(p.fault_names(self.mcu_faults)) or 'none'}
        if self.mcu:
            ack = self.mcu
            values.update({'firmware': f'{ack.fw_major}.{ack.fw_minor}.{ack.fw_patch}',
                           'adc_bits': ack.adc_bits, 'watchdog_ms': ack.watchdog_ms,
                           'max_duty': ack.max_duty, 'interlock_duty': ack.interlock_duty})
        if self.mcu_status:
            st = self.mcu_status
            values.update({'faults_latched': ' '.join(p.fault_names(st.faults_latched)) or 'none',
                           'mcu_rx_frames': st.rx_frames, 'mcu_rx_crc_errors': st.rx_crc_errors,
                           'mcu_rx_framing_errors': st.rx_framing_errors,
                           'mcu_rx_malformed': st.rx_malformed})
        if self.state != LinkState.CONNECTED:
            return 'mcu', 'stale', 'no MCU connected', values
        if self.mcu_faults & (p.FAULT_INTERLOCK | p.FAULT_BAD_VERSION):
            return 'mcu', 'error', 'fault: ' + values['faults'], values
        if self.mcu_faults:
            return 'mcu', 'warn', 'fault: ' + values['faults'], values
        return 'mcu', 'ok', 'no faults', values

    def _duty_diag(self):
        c = self.counters
        full = p.DUTY_FULL_SCALE
        values = {'duty_a': self.duty[0] / full, 'duty_b': self.duty[1] / full,
                  'commands': c['commands'], 'bad_commands': c['bad_commands'],
                  'clamped': c['clamped'], 'interlock_held': c['interlock_held'],
                  'stale_commands': c['stale_commands'], 'duty_publishers': self.publishers,
                  'host_watchdog_trips': c['host_watchdog_trips'],
                  'max_duty': self.max_counts / p.DUTY_FULL_SCALE,
                  'interlock_threshold': self.interlock_counts / p.DUTY_FULL_SCALE}
        values['commands_dropped'] = c['commands_dropped']
        if self.publishers > 1:
            text = f'{self.publishers} publishers on the duty topic: zero duty'
            return 'duty', 'error', text, values
        if self.last_command_bad:
            return 'duty', 'error', f'last command rejected: {self.last_command_bad}', values
        if self.state != LinkState.CONNECTED:
            return 'duty', 'warn', 'MCU not connected: commands dropped, zero duty', values
        if self.duty_timed_out:
            # the trip on the bridge's own clock: zero at the first tick after the timeout
            values['watchdog_trip_silence_ms'] = _ms(self.watchdog_trip[0])
            values['watchdog_trip_tick_gap_ms'] = _ms(self.watchdog_trip[1])
            text = f'no /sma/duty for over {self.config.duty_timeout_s} s: zero duty'
            return 'duty', 'warn', text, values
        return 'duty', 'ok', 'commands arriving', values


def _ms(seconds: float) -> str:
    return f'{seconds * 1e3:.3f}'


def _ms_pct(samples, q) -> str:
    return _ms(float(np.percentile(samples, q))) if samples else 'n/a'

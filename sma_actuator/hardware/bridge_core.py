"""Host side of the hardware bridge, free of ROS and of the serial port.

`BridgeCore` turns duty commands into Duty frames and received frames into joint
samples, and owns the host's safety rules:

- duty commands are validated; invalid ones (wrong length, NaN/inf) zero both wires;
  values outside [0, 1] or above max_duty are clamped;
- never both wires above the interlock threshold: the weaker command is limited to it;
- host watchdog: no duty command for duty_timeout_s -> zero duty, WARN;
- a link that closes, goes silent for link_timeout_s or restarts the MCU drops to zero
  duty and re-handshakes; duty frames are only sent after a HelloAck.

All times are monotonic seconds passed in by the caller; methods return the bytes to
write to the port. The caller serialises calls (one lock) and writes in call order.
"""
from __future__ import annotations

import collections
import enum
import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

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

    def __post_init__(self):
        for name in ('max_duty', 'interlock_threshold'):
            value = getattr(self, name)
            if not 0.0 <= value <= 1.0:
                raise ValueError(f'{name} must be in [0, 1], got {value}')
        for name in ('duty_timeout_s', 'duty_refresh_s', 'link_timeout_s', 'hello_retry_s',
                     'heartbeat_period_s', 'adc_period_s'):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f'{name} must be a positive number of seconds, got {value}')
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


def to_counts(duty: float) -> int:
    """Duty fraction 0..1 -> protocol counts 0..65535 (nearest)."""
    return int(round(duty * p.DUTY_FULL_SCALE))


def sanitize_duty(values, max_counts: int, interlock_counts: int) -> tuple[int, int, list[str]]:
    """Validate and limit a [duty_a, duty_b] command; returns (a, b) in counts and notes.

    Raises ValueError naming the problem for input that cannot be a duty command.
    Notes describe every change made (clamping, interlock). If both exceed the interlock,
    the weaker is limited to it (wire a keeps its command on a tie).
    """
    values = list(values)
    if len(values) != 2:
        raise ValueError(f'expected 2 values [duty_a, duty_b], got {len(values)}: {values}')
    notes, counts = [], []
    for name, value in zip(('duty_a', 'duty_b'), values):
        if not math.isfinite(value):
            raise ValueError(f'{name} is {value}')
        if not 0.0 <= value <= 1.0:
            notes.append(f'{name}={value:g} outside [0, 1], clamped')
        c = to_counts(min(max(value, 0.0), 1.0))
        if c > max_counts:
            notes.append(
                f'{name}={value:g} above max_duty {max_counts / p.DUTY_FULL_SCALE:g}, clamped')
            c = max_counts
        counts.append(c)
    a, b = counts
    if a > interlock_counts and b > interlock_counts:
        full = p.DUTY_FULL_SCALE
        notes.append(f'both wires above the interlock {interlock_counts / full:g} '
                     f'(a={a / full:g}, b={b / full:g}): weaker one limited')
        if a >= b:
            b = interlock_counts
        if b >= a:
            a = interlock_counts
    return a, b, notes


class BridgeCore:
    """State machine of the bridge; see the module docstring. `log(level, text)` reports events."""

    def __init__(self, config: BridgeConfig, calibration: AdcCalibration, now_s: float,
                 velocity_tau_s: float = 0.02,
                 log: Callable[[str, str], None] = lambda level, text: None):
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

    def on_close(self, reason: str, now_s: float, failure: bool = True):
        """Port closed (failure=False: on purpose, at shutdown): zero duty, report why."""
        self.link_error = reason
        if failure and self.state != LinkState.DISCONNECTED:
            self._log('error', f'serial link lost: {reason}; duty set to zero, reconnecting')
        self._enter(LinkState.DISCONNECTED, now_s)

    def on_open_failed(self, reason: str, now_s: float):
        """Opening the port failed (retried with backoff by the link)."""
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

    def on_duty_command(self, values, now_s: float) -> bytes:
        """A /sma/duty command [duty_a, duty_b]; returns the Duty frame to send (if connected)."""
        self.counters['commands'] += 1
        self._last_command_s = now_s
        if self.duty_timed_out:
            self.duty_timed_out = False
            self._log('info', 'duty commands resumed')
        try:
            a, b, notes = sanitize_duty(values, self.max_counts, self.interlock_counts)
        except (ValueError, TypeError) as exc:
            self.counters['bad_commands'] += 1
            self.last_command_bad = str(exc)
            self._log_throttled('bad', 'error', f'rejected /sma/duty command: {exc}; '
                                'both wires set to zero', now_s)
            a, b, notes = 0, 0, []
        else:
            self.last_command_bad = ''
        for note in notes:
            self.counters['interlock_limited' if 'interlock' in note else 'clamped'] += 1
            self._log_throttled(note.split('=')[0], 'warn', f'/sma/duty: {note}', now_s)
        if self.state != LinkState.CONNECTED:
            self.counters['commands_dropped'] += 1   # zero-duty state until (re)connected
            return b''
        self.duty = (a, b)
        return self._send_duty(now_s)

    def tick(self, now_s: float) -> bytes:
        """Timers: host watchdog, duty refresh, heartbeat, Hello retry, link timeout."""
        cfg, tx = self.config, bytearray()
        silent_s = now_s - self._last_command_s
        tick_gap_s, self._last_tick_s = now_s - self._last_tick_s, now_s
        if not self.duty_timed_out and silent_s > cfg.duty_timeout_s:
            self.duty_timed_out = True
            self.watchdog_trip = (silent_s, tick_gap_s)
            self.counters['host_watchdog_trips'] += 1
            self.duty = (0, 0)
            self._log('warn', f'no /sma/duty for {silent_s:.3f} s '
                              f'(timeout {cfg.duty_timeout_s} s): sending zero duty')
            tx += self._send_duty(now_s)
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
            tx += self._send_duty(now_s)
        if now_s - self._last_heartbeat_s >= cfg.heartbeat_period_s:
            self._last_heartbeat_s = now_s
            host_us = int(now_s * 1e6) & 0xFFFFFFFF
            self._heartbeats = {k: v for k, v in self._heartbeats.items() if now_s - v < 5.0}
            self._heartbeats[host_us] = now_s
            tx += self.sender.encode(p.Heartbeat(host_us))
        return bytes(tx)

    def shutdown(self) -> bytes:
        """Zero-duty frame to send before closing the port (empty if not connected)."""
        self.duty = (0, 0)
        if self.state != LinkState.CONNECTED:
            return b''
        return self.sender.encode(p.Duty(0, 0))

    # --- internals ----------------------------------------------------------------------

    def _enter(self, state: LinkState, now_s: float):
        if state != LinkState.CONNECTED:
            self.duty = (0, 0)   # the MCU's watchdog switches off; never resume an old command
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
            # Hello, so restore the current command (clamped to the limits just adopted).
            a, b, _ = sanitize_duty([self.duty[0] / p.DUTY_FULL_SCALE,
                                     self.duty[1] / p.DUTY_FULL_SCALE],
                                    self.max_counts, self.interlock_counts)
            self.duty = (a, b)
            return self._send_duty(now_s)
        self._log('info', f'connected: MCU firmware {ack.fw_major}.{ack.fw_minor}.'
                          f'{ack.fw_patch}, {ack.adc_bits}-bit ADC, limits max '
                          f'{ack.max_duty} interlock {ack.interlock_duty}')
        self.state = LinkState.CONNECTED
        self.link_error = ''
        self.duty = (0, 0)
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

    def _log_throttled(self, key: str, level: str, text: str, now_s: float, period_s: float = 1.0):
        if now_s - self._throttle.get(key, -math.inf) >= period_s:
            self._throttle[key] = now_s
            self._log(level, text)

    # --- diagnostics --------------------------------------------------------------------

    def diagnostics(self) -> list[tuple[str, str, str, dict]]:
        """(name, level, message, values) for the link, the MCU and the duty path.

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
                  'clamped': c['clamped'], 'interlock_limited': c['interlock_limited'],
                  'host_watchdog_trips': c['host_watchdog_trips'],
                  'max_duty': self.max_counts / p.DUTY_FULL_SCALE,
                  'interlock_threshold': self.interlock_counts / p.DUTY_FULL_SCALE}
        values['commands_dropped'] = c['commands_dropped']
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

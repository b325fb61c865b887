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
MCU emulator: the microcontroller's protocol logic in front of the simulated actuator.

Runs `McuCore` (the Python twin of the firmware) in real time on a pseudo-terminal or a
TCP socket, with the shared model core (`sma_actuator.core`) as the plant: the PWM duties
heat the two wires of `AntagonisticActuator`, and ADC reads come from `Potentiometer`.
So hardware_bridge <-> "MCU" <-> plant runs without hardware.

A pty or a socket carries bytes at memory speed, so the UART itself is modelled: every
byte costs 10 bit times (8N1) at `--baud` in each direction, queued behind the bytes
before it. That is what makes the 115200 vs 1 Mbaud latency difference visible.

Console script::

    mcu_emulator [--link /tmp/sma_mcu] [--tcp [HOST:]PORT] [--baud 115200] ...

The first stdout line is ``PORT <device path or socket:// URL>`` for the bridge's
``port`` parameter.
"""
from __future__ import annotations

import argparse
import collections
import os
import select
import signal
import socket
import sys
import threading
import time
import tty

import numpy as np
from sma_actuator.hardware import protocol as p
from sma_actuator.hardware.mcu_core import FirmwareLimits, McuCore

BITS_PER_BYTE = 10   # 8N1: start bit, 8 data bits, stop bit
POLL_PERIOD_S = 0.001


class UartLine:
    """
    One direction of a UART at `baud` [bit/s]: written bytes arrive after their line time.

    baud 0 means an ideal line (bytes arrive at once).
    """

    def __init__(self, baud: int) -> None:
        self.baud = int(baud)
        self._free_at_s = 0.0
        self._queue = collections.deque()   # (arrival time [s], bytes)

    def send(self, data: bytes, now_s: float) -> None:
        """Start sending `data` at `now_s` (or when the line is free)."""
        if not data:
            return
        start = max(now_s, self._free_at_s)
        done = start + (len(data) * BITS_PER_BYTE / self.baud if self.baud else 0.0)
        self._free_at_s = done
        self._queue.append((done, bytes(data)))

    def next_arrival_s(self) -> float | None:
        """Return the time [s] the next queued chunk arrives, or None."""
        return self._queue[0][0] if self._queue else None

    def arrived(self, now_s: float) -> bytes:
        """All bytes that have arrived by `now_s`."""
        out = bytearray()
        while self._queue and self._queue[0][0] <= now_s:
            out += self._queue.popleft()[1]
        return bytes(out)


class PtyTransport:
    """
    The MCU end of a pseudo-terminal; the bridge opens `port` (the slave device).

    The emulator keeps the slave open itself so the device survives bridge reconnects;
    what it writes while nobody listens is dropped like on a real unplugged UART.
    """

    def __init__(self, link_path: str | None = None) -> None:
        self.master, self._slave = os.openpty()
        tty.setraw(self._slave)          # binary frames: no echo, no CR/LF translation
        os.set_blocking(self.master, False)
        self.port = os.ttyname(self._slave)
        self.link_path = link_path
        if link_path:
            tmp = f'{link_path}.{os.getpid()}.tmp'
            os.symlink(self.port, tmp)
            os.replace(tmp, link_path)   # atomic: a restarted emulator takes over the path
            self.port = link_path
        self.dropped_bytes = 0

    def fds(self) -> list[int]:
        """Return the file descriptors to wait on."""
        return [self.master]

    def read(self, fd) -> bytes:
        """Bytes the bridge wrote (empty if none)."""
        try:
            return os.read(self.master, 4096)
        except (BlockingIOError, OSError):
            return b''

    def write(self, data: bytes) -> None:
        """Send to the bridge; drops what does not fit (nobody reading)."""
        try:
            written = os.write(self.master, data)
        except (BlockingIOError, OSError):
            written = 0
        self.dropped_bytes += len(data) - written

    def close(self) -> None:
        """Close both ends and remove the link."""
        link = self.link_path
        if link and os.path.islink(link) and os.readlink(link) == os.ttyname(self._slave):
            os.unlink(link)   # only our own link: a newer emulator may have taken it over
        os.close(self.master)
        os.close(self._slave)


class TcpTransport:
    """
    A TCP server for one bridge at a time (pyserial URL ``socket://host:port``).

    A new connection replaces the previous one; without a client, output is dropped.
    """

    def __init__(self, host: str = '127.0.0.1', port: int = 0) -> None:
        self.server = socket.create_server((host, port))
        self.server.setblocking(False)
        self.port = f'socket://{host}:{self.server.getsockname()[1]}'
        self.client = None
        self.dropped_bytes = 0

    def fds(self) -> list[socket.socket]:
        """Return the sockets to wait on."""
        return [self.server] + ([self.client] if self.client else [])

    def read(self, fd) -> bytes:
        """Accept a new client, or bytes from the current one."""
        if fd is self.server:
            try:
                client, _ = self.server.accept()
            except BlockingIOError:
                return b''
            self._drop_client()
            client.setblocking(False)
            client.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            self.client = client
            return b''
        try:
            data = self.client.recv(4096)
        except BlockingIOError:
            return b''
        except OSError:
            data = b''
        if not data:
            self._drop_client()
        return data

    def write(self, data: bytes) -> None:
        """Send to the client, if any."""
        if self.client is None:
            self.dropped_bytes += len(data)
            return
        try:
            self.client.sendall(data)
        except OSError:
            self._drop_client()

    def _drop_client(self) -> None:
        if self.client is not None:
            self.client.close()
            self.client = None

    def close(self) -> None:
        """Close the client and the server socket."""
        self._drop_client()
        self.server.close()


class Emulator:
    """McuCore + the shared actuator model + the potentiometer ADC, stepped in real time."""

    def __init__(self, baud: int = 115200, actuator_params=None, potentiometer=None,
                 seed: int | None = None, line_noise_hz: float = 0.0) -> None:
        # Imported here so that the protocol modules load without the model core.
        from sma_actuator.core.actuator import ActuatorParams, AntagonisticActuator
        from sma_actuator.core.sensor import Potentiometer
        self.actuator = AntagonisticActuator(actuator_params or ActuatorParams())
        self.pot = potentiometer or Potentiometer()
        self.rng = np.random.default_rng(seed)
        self.mcu = McuCore(self._read_adc, FirmwareLimits(adc_bits=self.pot.bits))
        self.rx_line, self.tx_line = UartLine(baud), UartLine(baud)
        self.line_noise_hz = float(line_noise_hz)
        self.angle_rad = self.actuator.step(0.0, 0.0, POLL_PERIOD_S)
        self._t0_s = self._sim_s = None
        self._next_noise_s = None

    def _read_adc(self) -> int:
        return self.pot.counts(self.angle_rad, self.rng)

    def ticks_us(self, now_s: float) -> int:
        """MCU tick counter (µs since start, wrapping at 2^32) at monotonic time `now_s`."""
        return int((now_s - self._t0_s) * 1e6) & 0xFFFFFFFF

    def start(self, now_s: float) -> None:
        """Boot the MCU at `now_s`; returns nothing (the boot Status goes onto the line)."""
        self._t0_s = self._sim_s = now_s
        self.tx_line.send(self.mcu.start(0), now_s)
        if self.line_noise_hz > 0:
            self._next_noise_s = now_s + self.rng.exponential(1.0 / self.line_noise_hz)

    def step(self, now_s: float, received: bytes = b'') -> bytes:
        """Advance plant and MCU to `now_s`, given bytes the host sent; returns bytes due to it."""
        dt = now_s - self._sim_s
        if dt >= POLL_PERIOD_S:   # duties held since the last step (PWM applied at once)
            duty = self.mcu.pwm_a / p.DUTY_FULL_SCALE, self.mcu.pwm_b / p.DUTY_FULL_SCALE
            self.angle_rad = self.actuator.step(*duty, dt)
            self._sim_s = now_s
        self.rx_line.send(received, now_s)
        t_us = self.ticks_us(now_s)
        arrived = self.rx_line.arrived(now_s)
        tx = (self.mcu.receive(arrived, t_us) if arrived else b'') + self.mcu.poll(t_us)
        self.tx_line.send(tx, now_s)
        if self._next_noise_s is not None and now_s >= self._next_noise_s:
            self.tx_line.send(self._line_noise(), now_s)
            self._next_noise_s = now_s + self.rng.exponential(1.0 / self.line_noise_hz)
        return self.tx_line.arrived(now_s)

    def _line_noise(self) -> bytes:
        """One burst of line trouble: random bytes, a truncated frame or a CRC-damaged frame."""
        frame = p.AdcReport(0, 0, 0, 0, 0, 0).encode(0)
        kind = self.rng.integers(3)
        if kind == 0:
            return bytes(self.rng.integers(
                0, 256, self.rng.integers(1, 40), dtype=np.uint8)) + b'\x00'
        if kind == 1:
            return frame[:len(frame) // 2] + b'\x00'
        payload = bytearray(p.cobs_decode(frame[:-1]))
        payload[-1] ^= 0x01   # break the CRC, keep the framing valid
        return p.cobs_encode(bytes(payload)) + b'\x00'

    def next_wakeup_s(self, now_s: float) -> float:
        """When step() next has work: the next poll or the next byte arrival."""
        wake = now_s + POLL_PERIOD_S
        for line in (self.rx_line, self.tx_line):
            arrival = line.next_arrival_s()
            if arrival is not None:
                wake = min(wake, arrival)
        return wake

    def run(self, transport, stop: threading.Event) -> None:
        """Serve `transport` in real time until `stop` is set."""
        self.start(time.monotonic())
        while not stop.is_set():
            now = time.monotonic()
            fds = transport.fds()
            ready, _, _ = select.select(fds, [], [], max(0.0, self.next_wakeup_s(now) - now))
            received = b''.join(transport.read(fd) for fd in ready)
            out = self.step(time.monotonic(), received)
            if out:
                transport.write(out)


def _parse_args(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(prog='mcu_emulator',
                                     description=__doc__.strip().splitlines()[0])
    add = parser.add_argument
    add('--link', help='also make this path a symlink to the pty (stable port name)')
    add('--tcp', metavar='[HOST:]PORT', help='serve TCP instead of a pty (port 0: any free '
        'port); the bridge port is then socket://HOST:PORT')
    add('--baud', type=int, default=115200,
        help='modelled UART rate in bit/s, 0 for an ideal line (default: %(default)s)')
    add('--adc-noise-rad', type=float, default=0.0, help='potentiometer noise, std dev [rad]')
    add('--ambient-c', type=float, default=None, help='ambient temperature [°C]')
    add('--seed', type=int, default=None, help='random seed (ADC noise, line noise)')
    add('--line-noise-hz', type=float, default=0.0, help='bursts per second of garbage, '
        'truncated or CRC-bad frames on the MCU->host line')
    add('--verbose', action='store_true', help='print plant state to stderr every second')
    args = parser.parse_args(argv)
    if args.baud < 0 or args.adc_noise_rad < 0 or args.line_noise_hz < 0:
        parser.error('--baud, --adc-noise-rad and --line-noise-hz must not be negative')
    return args


def main(argv: list[str] | None = None) -> int:
    """Console script `mcu_emulator`: serve until SIGINT/SIGTERM."""
    args = _parse_args(sys.argv[1:] if argv is None else argv)
    from sma_actuator.core.actuator import ActuatorParams
    from sma_actuator.core.sensor import Potentiometer
    params = ActuatorParams()
    if args.ambient_c is not None:
        params = params.with_changes(ambient_c=args.ambient_c)
    emulator = Emulator(args.baud, params, Potentiometer(noise_rad=args.adc_noise_rad),
                        args.seed, args.line_noise_hz)
    if args.tcp is not None:
        host, _, port = args.tcp.rpartition(':')
        transport = TcpTransport(host or '127.0.0.1', int(port))
    else:
        transport = PtyTransport(args.link)
    stop = threading.Event()
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, lambda *_: stop.set())
    print(f'PORT {transport.port}', flush=True)
    if args.verbose:
        threading.Thread(target=_report, args=(emulator, stop), daemon=True).start()
    try:
        emulator.run(transport, stop)
    finally:
        transport.close()
    return 0


def _report(emulator, stop) -> None:
    while not stop.wait(1.0):
        mcu = emulator.mcu
        theta = emulator.actuator.temperature_c
        print(f'angle {emulator.angle_rad:+.3f} rad  pwm {mcu.pwm_a}/{mcu.pwm_b}  '
              f'wires {theta[0]:.1f}/{theta[1]:.1f} °C  faults {p.fault_names(mcu.faults)}  '
              f'rx {mcu.rx_frames} ok {mcu.rx_crc_errors} crc {mcu.rx_framing_errors} framing',
              file=sys.stderr, flush=True)


if __name__ == '__main__':
    sys.exit(main())

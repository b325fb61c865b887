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
The serial side of the bridge: one pyserial port, owned by a thread, reopened with backoff.

Any pyserial URL works as the port: a device (/dev/ttyACM0, a pty), ``socket://host:port``
(the emulator's TCP mode) or ``loop://``. The thread blocks in read(), so received bytes
reach `on_data` within microseconds instead of waiting for a polling timer.

When the port cannot be opened, or a read/write fails (cable pulled, emulator killed),
the port is closed, `on_close`/`on_error` report why, and reopening is retried after an
exponential backoff (backoff_min_s doubling up to backoff_max_s; reset once data flows).
"""
from __future__ import annotations

import threading
import time
from typing import Callable

import serial


def _noop(*_):
    return b''


class SerialLink:
    """
    A pyserial port in a background thread. Callbacks run in that thread.

    on_open() -> bytes: called after each successful open; its result is written first.
    on_data(data, t_s): received bytes and the monotonic time [s] they were read.
    on_close(reason): an open port failed or was closed by stop().
    on_error(reason): opening the port failed (it will be retried).
    """

    def __init__(self, url: str, baud: int, on_open: Callable[[], bytes] = _noop,
                 on_data: Callable[[bytes, float], None] = _noop,
                 on_close: Callable[[str], None] = _noop, on_error: Callable[[str], None] = _noop,
                 backoff_min_s: float = 0.1, backoff_max_s: float = 5.0,
                 read_timeout_s: float = 0.05, write_timeout_s: float = 0.2) -> None:
        if not 0 < backoff_min_s <= backoff_max_s:
            raise ValueError(f'need 0 < backoff_min_s <= backoff_max_s, '
                             f'got {backoff_min_s}, {backoff_max_s}')
        self.url, self.baud = url, int(baud)
        self.on_open, self.on_data = on_open, on_data
        self.on_close, self.on_error = on_close, on_error
        self.backoff_min_s, self.backoff_max_s = backoff_min_s, backoff_max_s
        self.read_timeout_s, self.write_timeout_s = read_timeout_s, write_timeout_s
        self.backoff_s = backoff_min_s   # wait before the next reopen attempt
        self.opens = 0
        self.callback_errors = 0
        self.last_error = ''
        self._port = None
        self._broken = None               # reason a write failed; the thread closes the port
        self._final = b''
        self._lock = threading.Lock()     # guards _port and _broken between writer and reader
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name=f'serial {url}', daemon=True)

    @property
    def is_open(self) -> bool:
        """Return True while the port is open and no write has failed."""
        return self._port is not None and self._broken is None

    def start(self) -> None:
        """Start the thread (it opens the port)."""
        self._thread.start()

    def stop(self, final: bytes = b'', timeout_s: float = 2.0) -> None:
        """Write `final` (e.g. a zero-duty frame) if the port is open, close it, end the thread."""
        self._final = final
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout_s)

    def write(self, data: bytes) -> bool:
        """Send bytes; False if the port is not open or the write failed (then it is reopened)."""
        with self._lock:
            if self._port is None or self._broken is not None:
                return False
            try:
                self._port.write(data)
                return True
            except (serial.SerialException, OSError) as exc:
                self._broken = f'write to {self.url} failed: {exc}'
                return False

    # --- thread -----------------------------------------------------------------------

    def _run(self) -> None:
        while not self._stop.is_set():
            if self._port is None and not self._open():
                self._wait_backoff()
                continue
            reason = self._broken
            if reason is None:
                try:
                    data = self._read()
                except (serial.SerialException, OSError) as exc:
                    reason = f'read from {self.url} failed: {exc}'
                else:
                    if data:
                        self.backoff_s = self.backoff_min_s   # link works: retry fast next time
                        self._call(self.on_data, data, time.monotonic())
                    continue
            self._close(reason)
            self._wait_backoff()
        if self._port is not None:
            if self._final:
                self.write(self._final)
                try:
                    self._port.flush()
                except (serial.SerialException, OSError):
                    pass
            self._close('link stopped')

    def _open(self) -> bool:
        try:
            port = serial.serial_for_url(self.url, baudrate=self.baud, timeout=self.read_timeout_s,
                                         write_timeout=self.write_timeout_s)
            port.reset_input_buffer()   # stale bytes from before we were listening
        except (serial.SerialException, OSError, ValueError) as exc:
            self.last_error = f'cannot open {self.url}: {exc}'
            self._call(self.on_error, self.last_error)
            return False
        with self._lock:
            self._port, self._broken = port, None
        self.opens += 1
        first = self._call(self.on_open)
        if first:
            self.write(first)
        return True

    def _read(self) -> bytes:
        data = self._port.read(1)   # blocks up to read_timeout_s
        if data:
            # socket:// reports at most 1 waiting byte per call, so loop until drained
            while (waiting := self._port.in_waiting) > 0:
                data += self._port.read(waiting)
        return data

    def _close(self, reason: str) -> None:
        with self._lock:
            port, self._port, self._broken = self._port, None, None
        try:
            port.close()
        except (serial.SerialException, OSError):
            pass
        if reason != 'link stopped':
            self.last_error = reason
        self._call(self.on_close, reason)

    def _call(self, callback, *args):
        # A failing callback must not end the thread: it would stop reconnecting and could
        # no longer send the final zero-duty frame.
        try:
            return callback(*args)
        except Exception as exc:   # noqa: BLE001 - any callback bug, reported not raised
            self.callback_errors += 1
            self.last_error = f'{getattr(callback, "__name__", "callback")} raised {exc!r}'
            return b''

    def _wait_backoff(self) -> None:
        self._stop.wait(self.backoff_s)
        self.backoff_s = min(2 * self.backoff_s, self.backoff_max_s)

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

"""SerialLink (pyserial thread, reconnect with backoff) and the ADC calibration."""
import socket
import time

import pytest
from sma_actuator.hardware.calibration import AdcCalibration, VelocityEstimator
from sma_actuator.hardware.link import SerialLink


def wait_for(condition, timeout_s=3.0):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(0.005)
    return False


def test_loop_url_delivers_the_open_greeting_and_writes():
    received = bytearray()
    link = SerialLink('loop://', 115200, on_open=lambda: b'hello',
                      on_data=lambda data, t: received.extend(data))
    link.start()
    try:
        assert wait_for(lambda: bytes(received) == b'hello')
        assert link.write(b' world')
        assert wait_for(lambda: bytes(received) == b'hello world')
    finally:
        link.stop()
    assert not link.is_open


def test_unopenable_port_reports_errors_backs_off_and_stops_cleanly():
    errors = []
    link = SerialLink('/nonexistent/ttySMA', 115200, on_error=errors.append, backoff_min_s=0.02,
                      backoff_max_s=0.08)
    link.start()
    try:
        assert wait_for(lambda: len(errors) >= 4)
        assert 'cannot open /nonexistent/ttySMA' in errors[0]
        assert link.backoff_s == 0.08                   # doubled up to the ceiling
        assert not link.write(b'x')                      # not open: refused, no exception
    finally:
        start = time.monotonic()
        link.stop()
    assert time.monotonic() - start < 0.5


def test_socket_peer_closing_is_reported_and_the_link_reconnects():
    server = socket.create_server(('127.0.0.1', 0))
    port = server.getsockname()[1]
    opens, closes = [], []
    link = SerialLink(f'socket://127.0.0.1:{port}', 115200, on_open=lambda: opens.append(1) or b'',
                      on_close=closes.append, backoff_min_s=0.02, backoff_max_s=0.1)
    link.start()
    try:
        conn, _ = server.accept()
        assert wait_for(lambda: len(opens) == 1)
        conn.close()                                     # "unplugged"
        assert wait_for(lambda: len(closes) == 1)
        assert 'socket disconnected' in closes[0] or 'failed' in closes[0]
        conn2, _ = server.accept()                       # back: the link reopens by itself
        assert wait_for(lambda: len(opens) == 2)
        conn2.sendall(b'\x01')
        conn2.close()
    finally:
        link.stop()
        server.close()


def test_stop_writes_the_final_bytes_before_closing():
    server = socket.create_server(('127.0.0.1', 0))
    link = SerialLink(f'socket://127.0.0.1:{server.getsockname()[1]}', 115200)
    link.start()
    try:
        conn, _ = server.accept()
        assert wait_for(lambda: link.is_open)
        link.stop(final=b'ZERO')
        conn.settimeout(2.0)
        assert conn.recv(16) == b'ZERO'
        conn.close()
    finally:
        server.close()


def test_linear_and_polynomial_calibration():
    linear = AdcCalibration(-1.2, 2.4 / 4095)
    assert linear.angle_rad(0) == -1.2 and linear.angle_rad(4095) == pytest.approx(1.2)
    poly = AdcCalibration(polynomial=[1e-7, 5e-4, -1.0])
    assert poly.angle_rad(1000) == pytest.approx(1e-7 * 1e6 + 0.5 - 1.0)


@pytest.mark.parametrize('kwargs, message', [
    ({'scale_rad_per_count': 0.0}, 'must not be 0'),
    ({'offset_rad': float('nan')}, 'must be finite'),
    ({'polynomial': [1.0, float('inf')]}, 'must be finite')])
def test_calibration_rejects_bad_values(kwargs, message):
    with pytest.raises(ValueError, match=message):
        AdcCalibration(**kwargs)


def test_velocity_estimate_follows_a_ramp_across_tick_wraparound():
    est = VelocityEstimator(tau_s=0.0)
    t0 = 0xFFFFFFFF - 2000
    assert est.update(t0, 0.0) == 0.0
    assert est.update((t0 + 5000) & 0xFFFFFFFF, 0.01) == pytest.approx(2.0)   # 0.01 rad in 5 ms
    filtered = VelocityEstimator(tau_s=0.02)
    for k in range(200):
        v = filtered.update(k * 5000, 0.5 * k * 0.005)
    assert v == pytest.approx(0.5, rel=1e-6)
    assert filtered.update(199 * 5000, 99.0) == v       # duplicate tick: ignored


def test_a_failing_callback_does_not_end_the_link_thread():
    received = []

    def on_data(data, t):
        received.append(data)
        if len(received) == 1:
            raise RuntimeError('publisher gone')
    link = SerialLink('loop://', 115200, on_open=lambda: b'a', on_data=on_data)
    link.start()
    try:
        assert wait_for(lambda: len(received) == 1)
        assert wait_for(lambda: link.callback_errors == 1)
        assert "RuntimeError('publisher gone')" in link.last_error
        assert link.write(b'b') and wait_for(lambda: len(received) == 2)
    finally:
        link.stop()

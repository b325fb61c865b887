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
hardware_bridge node <-> MCU emulator (shared plant core) through the real topics.

The emulator runs in this process (a thread on a pty) so the tests can look at the
"MCU" outputs directly: the safety rules are checked at the PWM pins, not in the bridge.
"""
import math
import threading
import time

from diagnostic_msgs.msg import DiagnosticStatus
from hardware_support import emulator_thread, Probe, start_emulator_process, stop_process, wait_for
import pytest
import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter
from sma_actuator.core.sensor import Potentiometer
from sma_actuator.hardware import protocol as p
from sma_actuator.hardware.bridge_core import to_counts
from sma_actuator.nodes import common as c
from sma_actuator.nodes.hardware_bridge import HardwareBridge
from std_msgs.msg import Float64MultiArray

# DiagnosticStatus levels are bytes constants; the probe reports them as ints
OK, WARN, ERROR = (ord(x) for x in (DiagnosticStatus.OK, DiagnosticStatus.WARN,
                                    DiagnosticStatus.ERROR))


class Loop:
    """Bridge node + probe node spinning on one executor in a background thread."""

    def __init__(self, context, port, **params):
        params = {'port': port, 'diagnostics_rate_hz': 10.0, **params}
        self.bridge = HardwareBridge(context=context, parameter_overrides=[
            Parameter(k, value=v) for k, v in params.items()])
        self.probe = Probe(context=context)
        # single-threaded: rclpy's MultiThreadedExecutor hogs the GIL and starves the
        # in-process emulator thread (measured: 150 instead of 1000 emulator steps/s)
        self.executor = SingleThreadedExecutor(context=context)
        self.executor.add_node(self.bridge)
        self.executor.add_node(self.probe)
        self.thread = threading.Thread(target=self.executor.spin, daemon=True)
        self.thread.start()

    def close(self):
        self.executor.shutdown(timeout_sec=2.0)
        self.bridge.destroy_node()
        self.probe.destroy_node()
        self.thread.join(2.0)

    def level(self, name):
        status = self.probe.status(name)
        return status and status[0]


@pytest.fixture
def emulated(ros_context):
    """(emulator, loop) with the bridge connected to an in-process emulator at 1 Mbaud."""
    with emulator_thread(baud=1_000_000, seed=0) as (emulator, port):
        loop = Loop(ros_context, port, baud=1_000_000)
        try:
            assert wait_for(lambda: loop.level('link') == OK), 'bridge did not connect'
            yield emulator, loop
        finally:
            loop.close()


@pytest.mark.slow
def test_duty_topic_drives_the_emulated_wires_and_joint_states_follow(emulated):
    emulator, loop = emulated
    probe = loop.probe
    started_wall_s = time.time()
    probe.hold(1.0, 0.0, 1.5, until=lambda: emulator.mcu.pwm_a == p.DUTY_FULL_SCALE
               and probe.joint_states[-1][1].position[0] > 0.3)   # heat wire A
    assert emulator.mcu.pwm_a == p.DUTY_FULL_SCALE and emulator.mcu.pwm_b == 0
    t, js = probe.joint_states[-1]
    peak = js.position[0]
    assert js.name == ['shaft'] and peak > 0.3           # wire A pulls the shaft positive
    # calibrated: the latest joint state is the emulated shaft angle (once the executor has
    # caught up with the stream, however loaded the machine is)
    assert wait_for(lambda: abs(probe.joint_states[-1][1].position[0] - emulator.angle_rad)
                    < 0.02)
    # stamped with the node clock at reception: between the start of the test and now
    assert started_wall_s - 1e-3 <= js.header.stamp.sec + js.header.stamp.nanosec * 1e-9 \
        <= time.time()
    assert max(m.velocity[0] for _, m in probe.joint_states) > 0.2
    probe.hold(0.0, 1.0, 1.0, until=lambda: probe.joint_states[-1][1].position[0] < peak - 0.3)
    assert probe.joint_states[-1][1].position[0] < peak - 0.3      # wire B pulls it back
    # raw counts topic: the same samples, before calibration. The two topics reach the probe
    # through separate queues, so on a loaded machine the raw twin of the latest joint state
    # can arrive seconds after it: look for it among the raw samples that arrive near it.
    pot = Potentiometer()
    arrived_s, js = probe.joint_states[-1]
    angle = round(js.position[0], 9)
    assert wait_for(lambda: any(abs(t - arrived_s) < 5.0 and round(pot.angle(counts), 9) == angle
                                for t, counts in probe.raw))
    # the stream keeps flowing (progress, not a rate: the rate is the machine's, not the link's)
    n = len(probe.joint_states)
    assert wait_for(lambda: len(probe.joint_states) > n + 100)


def test_host_watchdog_zeroes_duty_at_its_first_tick_200_ms_after_the_last_command(
        emulated):
    emulator, loop = emulated
    loop.probe.hold(0.5, 0.0, 0.5, until=lambda: emulator.mcu.pwm_a == to_counts(0.5))
    assert emulator.mcu.pwm_a == to_counts(0.5)
    assert wait_for(lambda: emulator.mcu.pwm_a == 0)
    assert wait_for(lambda: loop.level('duty') == WARN)
    _, message, values = loop.probe.status('duty')
    assert 'no /sma/duty' in message
    # on the bridge's own clock: zero at its first tick after 200 ms of silence, not before
    # (how soon this test's threads notice it depends on the machine's load, not the bridge)
    silence_ms = float(values['watchdog_trip_silence_ms'])
    tick_gap_ms = float(values['watchdog_trip_tick_gap_ms'])
    assert 200.0 < silence_ms <= 200.0 + tick_gap_ms + 0.002, values
    assert loop.level('link') == OK                      # zero duty keeps flowing, link is fine


def test_never_both_wires_heated_at_the_mcu(emulated):
    emulator, loop = emulated
    seen = []
    end = time.monotonic() + 0.6
    while time.monotonic() < end:
        loop.probe.duty(0.6, 0.5)
        seen.append((emulator.mcu.pwm_a, emulator.mcu.pwm_b))
        time.sleep(0.002)
    assert all(pair == (0, 0) for pair in seen)
    assert not emulator.mcu.faults_latched & p.FAULT_INTERLOCK
    assert wait_for(lambda: int(loop.probe.status('duty')[2]['interlock_held']) > 0)


def test_the_applied_duty_topic_follows_the_mcu_outputs_through_a_reversal(emulated):
    emulator, loop = emulated
    probe, full = loop.probe, p.DUTY_FULL_SCALE
    heat_a, heat_b = (to_counts(0.4) / full, 0.0), (0.0, to_counts(0.5) / full)
    probe.hold(0.4, 0.0, 0.3, until=lambda: emulator.mcu.pwm_a == to_counts(0.4))
    assert wait_for(lambda: probe.applied and probe.applied[-1][1] == heat_a)
    # wire b waits out the dead time after wire a: the topic passes through zero
    probe.hold(0.0, 0.5, 0.3, until=lambda: emulator.mcu.pwm_b == to_counts(0.5))
    assert wait_for(lambda: probe.applied[-1][1] == heat_b)
    values = [v for _, v in probe.applied]
    first_b = values.index(heat_b)
    last_a = max(k for k, v in enumerate(values[:first_b]) if v == heat_a)
    assert (0.0, 0.0) in values[last_a:first_b]
    assert all(a == 0.0 or b == 0.0 for a, b in values)
    # the host watchdog's zero goes out on the topic too
    assert wait_for(lambda: emulator.mcu.pwm_b == 0 and probe.applied[-1][1] == (0.0, 0.0))


def test_bad_duty_message_is_rejected_and_the_last_valid_one_kept(emulated):
    emulator, loop = emulated
    loop.probe.hold(0.4, 0.0, 0.2, until=lambda: emulator.mcu.pwm_a == to_counts(0.4))
    assert emulator.mcu.pwm_a == to_counts(0.4)
    for bad in ((math.nan, 0.0), (1e308, 0.0), (2.0, 0.0)):
        loop.probe.duty(*bad)
    assert wait_for(lambda: loop.level('duty') == ERROR)
    assert 'outside [0, 1]' in loop.probe.status('duty')[1]
    # never full power (zero once the host watchdog runs out, if this test is slow to look)
    assert emulator.mcu.pwm_a in (to_counts(0.4), 0)
    loop.probe.hold(0.4, 0.0, 0.1, until=lambda: emulator.mcu.pwm_a == to_counts(0.4))
    assert emulator.mcu.pwm_a == to_counts(0.4)


def test_a_second_duty_publisher_zeroes_the_duty_with_an_error(emulated, ros_context):
    emulator, loop = emulated
    loop.probe.hold(0.4, 0.0, 0.3, until=lambda: emulator.mcu.pwm_a == to_counts(0.4))
    assert emulator.mcu.pwm_a == to_counts(0.4)
    other = rclpy.create_node('second_controller', context=ros_context, namespace=c.NAMESPACE)
    try:
        other.create_publisher(Float64MultiArray, c.DUTY, c.COMMAND_QOS)
        assert wait_for(lambda: emulator.mcu.pwm_a == 0 and loop.level('duty') == ERROR)
        assert '2 publishers' in loop.probe.status('duty')[1]
        loop.probe.hold(0.4, 0.0, 0.3)
        assert emulator.mcu.pwm_a == 0
    finally:
        other.destroy_node()
    assert wait_for(lambda: loop.level('duty') != ERROR)
    loop.probe.hold(0.4, 0.0, 0.3, until=lambda: emulator.mcu.pwm_a == to_counts(0.4))
    assert emulator.mcu.pwm_a == to_counts(0.4)


@pytest.mark.slow
def test_line_noise_is_counted_and_the_stream_resynchronises(ros_context):
    with emulator_thread(baud=1_000_000, seed=2, line_noise_hz=40.0) as (emulator, port):
        loop = Loop(ros_context, port, baud=1_000_000)
        try:
            assert wait_for(lambda: loop.level('link') == OK)

            def errors():
                values = loop.probe.status('link')[2]
                return int(values['crc_errors']) + int(values['framing_errors'])
            loop.probe.hold(0.3, 0.0, 1.5, until=lambda: errors() >= 10)
            assert errors() >= 10 and loop.level('link') == OK
            # after the noise the stream has resynchronised: joint states keep coming and the
            # link stays up (progress, not a rate: the rate is the machine's, not the link's)
            n, seen = len(loop.probe.joint_states), errors()
            assert wait_for(lambda: errors() > seen and len(loop.probe.joint_states) > n + 100)
            assert loop.level('link') == OK
        finally:
            loop.close()


@pytest.mark.slow
def test_unplugged_mcu_gives_error_zero_duty_and_reconnects(ros_context, tmp_path):
    link = str(tmp_path / 'sma_mcu')
    proc, port = start_emulator_process('--link', link, '--baud', '1000000')
    loop = Loop(ros_context, link, baud=1_000_000, reconnect_backoff_max_s=0.4)
    try:
        assert wait_for(lambda: loop.level('link') == OK)
        loop.probe.hold(0.5, 0.0, 0.3)
        stop_process(proc, sig=9)                         # "cable pulled"
        assert wait_for(lambda: loop.level('link') == ERROR)
        assert loop.bridge.core.duty == (0, 0)
        down_s = time.time()                              # the link is closed by now

        def received_since_down():
            # joint states are stamped at reception: ones sent before the close may still be
            # on their way to this test's probe, but none may be stamped after it
            return sum(1 for _, m in loop.probe.joint_states
                       if m.header.stamp.sec + m.header.stamp.nanosec * 1e-9 > down_s)
        time.sleep(0.5)
        assert received_since_down() == 0                 # no data while unplugged
        proc, _ = start_emulator_process('--link', link, '--baud', '1000000')
        assert wait_for(lambda: loop.level('link') == OK), loop.probe.status('link')
        assert wait_for(lambda: received_since_down() > 20)
        values = loop.probe.status('link')[2]
        assert int(values['opens']) >= 2
        assert float(values['reconnect_backoff_s']) <= 0.4   # retried at the capped backoff
    finally:
        loop.close()
        stop_process(proc)


def test_unopenable_port_is_an_error_not_a_crash(ros_context, tmp_path):
    loop = Loop(ros_context, str(tmp_path / 'no_such_tty'), reconnect_backoff_max_s=0.2)
    try:
        loop.probe.hold(0.5, 0.0, 0.8)
        assert wait_for(lambda: loop.level('link') == ERROR
                        and int(loop.probe.status('link')[2]['open_failures']) >= 2)
        level, message, values = loop.probe.status('link')
        assert 'cannot open' in message and int(values['open_failures']) >= 2
        assert loop.thread.is_alive() and loop.bridge.core.duty == (0, 0)
    finally:
        loop.close()

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
A frozen bridge must not replay the heat of a dead controller (issue 13 item 2).

The bridge runs as its own process against the in-process MCU emulator; a controller
process publishes [0.5, 0] at 40 Hz. The bridge is SIGSTOPped, the controller killed,
the bridge SIGCONTed: the emulator's record of applied PWM must show no heat after the
controller died plus the watchdog period.
"""
import os
import signal
import subprocess
import sys
import textwrap
import time

from hardware_support import console_command, emulator_thread, stop_process, wait_for
import pytest

# slow: three SIGSTOP/SIGCONT runs of bridge and emulator (quick run: -m "not slow")
pytestmark = pytest.mark.slow

pytest.importorskip('rclpy')

CONTROLLER = textwrap.dedent("""
    import time
    import rclpy
    from std_msgs.msg import Float64MultiArray
    from sma_actuator.nodes import common as c
    rclpy.init()
    node = rclpy.create_node('fake_controller', namespace=c.NAMESPACE)
    pub = node.create_publisher(Float64MultiArray, c.DUTY, c.COMMAND_QOS)
    while True:
        pub.publish(Float64MultiArray(data=[0.5, 0.0]))
        time.sleep(0.025)
""")
WATCHDOG_S = 0.2


@pytest.mark.parametrize('run', range(3))
def test_frozen_bridge_never_applies_commands_of_a_dead_controller(ros_domain_id, run):
    env = dict(os.environ, ROS_DOMAIN_ID=str(ros_domain_id))
    with emulator_thread(baud=1_000_000, seed=run) as (emulator, port):
        record = []      # (monotonic time, pwm_a, pwm_b) at every change, from the MCU

        def step(now_s, received=b'', _step=emulator.step):
            out = _step(now_s, received)
            pair = (emulator.mcu.pwm_a, emulator.mcu.pwm_b)
            if not record or record[-1][1:] != pair:
                record.append((time.monotonic(), *pair))
            return out
        emulator.step = step
        bridge = subprocess.Popen(
            console_command('hardware_bridge', 'sma_actuator.nodes.hardware_bridge')
            + ['--ros-args', '-p', f'port:={port}', '-p', 'baud:=1000000',
               '-p', f'duty_timeout_s:={WATCHDOG_S}'],
            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        controller = subprocess.Popen([sys.executable, '-c', CONTROLLER], env=env,
                                      stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        try:
            assert wait_for(lambda: emulator.mcu.pwm_a > 0, 60.0), 'no heat commanded'
            time.sleep(0.5)
            bridge.send_signal(signal.SIGSTOP)
            time.sleep(0.4)                       # commands pile up for the frozen bridge
            controller.kill()
            controller.wait(10)
            t_dead = time.monotonic()
            time.sleep(0.6)
            bridge.send_signal(signal.SIGCONT)
            time.sleep(1.5)
            assert bridge.poll() is None, bridge.stderr.read()
        finally:
            if controller.poll() is None:
                controller.kill()
                controller.wait(10)
            bridge.send_signal(signal.SIGCONT)
            stop_process(bridge, signal.SIGINT)
    assert any(a > 0 for _, a, _ in record)
    late = [(round(t - t_dead, 3), a, b) for t, a, b in record
            if t > t_dead + WATCHDOG_S and (a or b)]
    assert not late, f'heat applied after the controller died + watchdog: {late}'

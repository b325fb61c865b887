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
controller -> /sma/duty -> hardware_bridge -> "MCU" emulator -> /sma/joint_states -> controller.

The whole loop of issue 4 without hardware, in real time: the controller node (issue 3)
closes the loop through the bridge and the emulated MCU + plant.
"""
import threading
import time

from hardware_support import emulator_thread, Probe, wait_for
import numpy as np
from rclpy.executors import SingleThreadedExecutor
from rclpy.parameter import Parameter
from sma_actuator.hardware import protocol as p
from sma_actuator.nodes import common as c
from sma_actuator.nodes.controller import Controller
from sma_actuator.nodes.hardware_bridge import HardwareBridge
from std_msgs.msg import Float64

SETPOINT_RAD = 0.3


def test_controller_closes_the_loop_through_bridge_and_emulator(ros_context):
    with emulator_thread(baud=115200, seed=0) as (emulator, port):
        bridge = HardwareBridge(context=ros_context, parameter_overrides=[
            Parameter('port', value=port), Parameter('diagnostics_rate_hz', value=10.0)])
        controller = Controller(context=ros_context)
        probe = Probe(duty=False, context=ros_context)
        setpoint_pub = probe.create_publisher(Float64, c.SETPOINT, c.COMMAND_QOS)
        executor = SingleThreadedExecutor(context=ros_context)
        for node in (bridge, controller, probe):
            executor.add_node(node)
        thread = threading.Thread(target=executor.spin, daemon=True)
        thread.start()
        try:
            assert wait_for(lambda: bridge.core.state.value == 'connected', 10.0)
            assert wait_for(lambda: setpoint_pub.get_subscription_count() > 0, 5.0)
            start = time.monotonic()
            settled_at = None
            while time.monotonic() - start < 12.0:
                setpoint_pub.publish(Float64(data=SETPOINT_RAD))
                time.sleep(0.1)
                recent = [m.position[0]
                          for t, m in probe.joint_states if t > time.monotonic() - 0.5]
                if recent and np.all(np.abs(np.array(recent) - SETPOINT_RAD) < 0.05):
                    settled_at = time.monotonic() - start
                    break
            last = probe.joint_states[-1][1].position[0]
            assert settled_at is not None, f'not settled: last position {last}'
            # the duties came from the controller, through the bridge, to the MCU outputs
            counters = bridge.core.counters
            assert counters['commands'] > 50 and counters['bad_commands'] == 0
            assert emulator.mcu.rx_frames > 50
            assert not emulator.mcu.faults_latched & p.FAULT_INTERLOCK
            assert abs(emulator.angle_rad - SETPOINT_RAD) < 0.06
        finally:
            executor.shutdown(timeout_sec=2.0)
            for node in (bridge, controller, probe):
                node.destroy_node()
            thread.join(2.0)

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
Stale streams through real topics.

* controller: joint states stop -> zero duty on /sma/duty and a diagnostics ERROR.
* plant: the controller process is SIGKILLed mid-run -> the plant applies zero duty after
  its duty timeout (it reports so on /diagnostics) and the heated wire cools.
"""
import os
import signal
import subprocess
import sys
import time

from conftest import spin_until
import pytest

rclpy = pytest.importorskip('rclpy')
# after the importorskip guard, hence out of the alphabetical order
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus  # noqa: E402, I100
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402
from sensor_msgs.msg import JointState, Temperature  # noqa: E402
from sma_actuator.nodes import common as c  # noqa: E402
from sma_actuator.nodes.controller import Controller  # noqa: E402
from sma_actuator.nodes.plant_sim import PlantSim  # noqa: E402
from std_msgs.msg import Float64, Float64MultiArray, Header  # noqa: E402


def test_stale_joint_states_make_the_controller_command_zero_and_report_error(ros_context):
    ex = SingleThreadedExecutor(context=ros_context)
    ctrl = Controller(context=ros_context, parameter_overrides=[
        Parameter('feedback_timeout_s', value=0.2)])
    node = rclpy.create_node('feeder', context=ros_context, namespace=c.NAMESPACE)
    js = node.create_publisher(JointState, c.JOINT_STATES, c.SENSOR_QOS)
    sp = node.create_publisher(Float64, c.SETPOINT, c.COMMAND_QOS)
    duties, diags = [], []
    node.create_subscription(Float64MultiArray, c.DUTY,
                             lambda m: duties.append((time.monotonic(), tuple(m.data))),
                             c.COMMAND_QOS)
    node.create_subscription(DiagnosticArray, c.DIAGNOSTICS,
                             lambda m: diags.extend((time.monotonic(), s) for s in m.status),
                             c.DIAGNOSTICS_QOS)
    for n in (ctrl, node):
        ex.add_node(n)
    try:
        assert spin_until(ex, lambda: sp.get_subscription_count() > 0, 5)
        sp.publish(Float64(data=0.5))
        spin_until(ex, lambda: ctrl.setpoint.value == 0.5, 2)
        t_end = time.monotonic() + 0.5
        while time.monotonic() < t_end:               # 40 Hz feedback, shaft at 0: heat a
            js.publish(JointState(name=['shaft'], position=[0.0], velocity=[0.0],
                                  header=_stamp(node)))
            spin_until(ex, lambda: False, 0.025)
        assert duties and duties[-1][1][0] > 0.1
        t_stop = time.monotonic()
        assert spin_until(ex, lambda: any(s.level == DiagnosticStatus.ERROR and
                                          'stale' in s.message for _, s in diags), 2)
        t_error = next(t for t, s in diags if s.level == DiagnosticStatus.ERROR)
        assert 0.15 < t_error - t_stop < 1.0          # after the 0.2 s timeout, not before
        spin_until(ex, lambda: False, 0.2)
        after = [d for t, d in duties if t > t_error]
        assert after and all(d == (0.0, 0.0) for d in after)
    finally:
        ex.shutdown()
        for n in (ctrl, node):
            n.destroy_node()


def _stamp(node):
    return Header(stamp=node.get_clock().now().to_msg())


def test_killed_controller_leaves_zero_duty_after_the_plant_timeout(ros_context, ros_domain_id):
    ex = SingleThreadedExecutor(context=ros_context)
    plant = PlantSim(context=ros_context, parameter_overrides=[
        Parameter('duty_timeout_s', value=0.2)])
    node = rclpy.create_node('watcher', context=ros_context, namespace=c.NAMESPACE)
    sp = node.create_publisher(Float64, c.SETPOINT, c.COMMAND_QOS)
    diags, temps = [], []
    node.create_subscription(DiagnosticArray, c.DIAGNOSTICS,
                             lambda m: diags.extend((time.monotonic(), s) for s in m.status
                                                    if s.name.startswith('plant_sim')),
                             c.DIAGNOSTICS_QOS)
    node.create_subscription(Temperature, c.WIRE_TEMPERATURES[0],
                             lambda m: temps.append((time.monotonic(), m.temperature)),
                             c.SENSOR_QOS)
    for n in (plant, node):
        ex.add_node(n)
    proc = subprocess.Popen([sys.executable, '-m', 'sma_actuator.nodes.controller',
                             '--ros-args', '-p', 'setpoint_max_rad:=1.0'],
                            env=dict(os.environ, ROS_DOMAIN_ID=str(ros_domain_id)),
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        assert spin_until(ex, lambda: sp.get_subscription_count() > 0, 20), \
            'controller process did not come up'
        sp.publish(Float64(data=0.8))                # ask for a lot of heat on wire a
        assert spin_until(ex, lambda: plant.applied[0] > 0.2 and temps and temps[-1][1] > 50,
                          10)
        proc.send_signal(signal.SIGKILL)             # no clean shutdown, no last zero duty
        proc.wait(5)
        t_kill = time.monotonic()
        assert spin_until(ex, lambda: any('duty stale' in s.message for _, s in diags), 2)
        t_zero = next(t for t, s in diags if 'duty stale' in s.message)
        assert t_zero - t_kill < 0.2 + 0.8           # the plant timeout (+ slack on a busy host)
        stale = [s for _, s in diags if 'duty stale' in s.message][0]
        values = {kv.key: kv.value for kv in stale.values}
        assert float(values['applied_duty_a']) == 0.0 == float(values['applied_duty_b'])
        assert plant.applied == (0.0, 0.0)
        hot = max(v for t, v in temps if t <= t_zero)
        spin_until(ex, lambda: False, 1.0)
        assert temps[-1][1] < hot - 10.0             # wire a is cooling
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(5)
        ex.shutdown()
        for n in (plant, node):
            n.destroy_node()

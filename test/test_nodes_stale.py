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

from conftest import NOTICE_S, spin_until
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
                             lambda m: duties.append((len(diags), tuple(m.data))),
                             c.COMMAND_QOS)
    node.create_subscription(DiagnosticArray, c.DIAGNOSTICS,
                             lambda m: diags.extend(m.status), c.DIAGNOSTICS_QOS)
    for n in (ctrl, node):
        ex.add_node(n)
    try:
        assert spin_until(ex, lambda: sp.get_subscription_count() > 0)
        sp.publish(Float64(data=0.5))
        assert spin_until(ex, lambda: ctrl.setpoint.value == 0.5)
        t_end = time.monotonic() + 0.5
        while time.monotonic() < t_end or (not duties and time.monotonic() < t_end + NOTICE_S):
            # 40 Hz feedback, shaft at 0: the controller heats wire a
            js.publish(JointState(name=['shaft'], position=[0.0], velocity=[0.0],
                                  header=_stamp(node)))
            spin_until(ex, lambda: False, 0.025)
        assert any(d[0] > 0.1 for _, d in duties)       # wire a was heated
        n0 = len(diags)                                # the feedback stops here
        assert spin_until(ex, lambda: _first(diags[n0:], 'stale') is not None)
        error = _first(diags[n0:], 'stale')
        assert error.level == DiagnosticStatus.ERROR
        # on the controller's own clock: zero at its first check after the 0.2 s timeout,
        # not before (when this test notices depends on the machine's load, not the node)
        values = _values(error)
        last, zero, previous = (float(values[k]) for k in (
            'last_joint_state_s', 'zero_duty_since_s', 'previous_check_s'))
        assert zero - last > 0.2 >= previous - last, values
        # from the error on, only zero duty (the watchdog keeps sending it every tick)
        n_error = diags.index(error) + 1
        assert spin_until(ex, lambda: sum(1 for k, _ in duties if k >= n_error) >= 3)
        assert all(d == (0.0, 0.0) for k, d in duties if k >= n_error)
    finally:
        ex.shutdown()
        for n in (ctrl, node):
            n.destroy_node()


def _first(statuses, word):
    return next((s for s in statuses if word in s.message), None)


def _values(status):
    return {kv.key: kv.value for kv in status.values}


def _stamp(node):
    return Header(stamp=node.get_clock().now().to_msg())


@pytest.mark.slow
def test_killed_controller_leaves_zero_duty_after_the_plant_timeout(ros_context, ros_domain_id):
    ex = SingleThreadedExecutor(context=ros_context)
    plant = PlantSim(context=ros_context, parameter_overrides=[
        Parameter('duty_timeout_s', value=0.2)])
    node = rclpy.create_node('watcher', context=ros_context, namespace=c.NAMESPACE)
    sp = node.create_publisher(Float64, c.SETPOINT, c.COMMAND_QOS)
    diags, temps = [], []       # plant diagnostics; (plant stamp [s], wire a temperature [C])
    node.create_subscription(DiagnosticArray, c.DIAGNOSTICS,
                             lambda m: diags.extend(s for s in m.status
                                                    if s.name.startswith('plant_sim')),
                             c.DIAGNOSTICS_QOS)
    node.create_subscription(Temperature, c.WIRE_TEMPERATURES[0],
                             lambda m: temps.append((c.stamp_to_s(m.header.stamp),
                                                     m.temperature)), c.SENSOR_QOS)
    for n in (plant, node):
        ex.add_node(n)
    proc = subprocess.Popen([sys.executable, '-m', 'sma_actuator.nodes.controller',
                             '--ros-args', '-p', 'setpoint_max_rad:=1.0'],
                            env=dict(os.environ, ROS_DOMAIN_ID=str(ros_domain_id)),
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        assert spin_until(ex, lambda: sp.get_subscription_count() > 0), \
            'controller process did not come up'
        sp.publish(Float64(data=0.8))                # ask for a lot of heat on wire a
        assert spin_until(ex, lambda: plant.applied[0] > 0.2 and temps and temps[-1][1] > 50)
        proc.send_signal(signal.SIGKILL)             # no clean shutdown, no last zero duty
        proc.wait(NOTICE_S)
        n0 = len(diags)
        assert spin_until(ex, lambda: _first(diags[n0:], 'duty stale') is not None)
        values = _values(_first(diags[n0:], 'duty stale'))
        assert float(values['applied_duty_a']) == 0.0 == float(values['applied_duty_b'])
        # on the plant's own clock: zero applied at its first step after the 0.2 s timeout,
        # not before, i.e. within duty_timeout_s plus one step period of the last valid duty
        # (when this test notices depends on the machine's load, not on the plant)
        last, zero, previous = (float(values[k]) for k in (
            'last_valid_duty_s', 'zero_duty_applied_s', 'previous_step_s'))
        assert zero - last > 0.2 >= previous - last, values
        assert zero - last <= 0.2 + (zero - previous)
        assert plant.applied == (0.0, 0.0)
        hot = max(v for t, v in temps if t <= zero)
        assert spin_until(ex, lambda: temps[-1][1] < hot - 10.0)   # wire a is cooling
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(NOTICE_S)
        ex.shutdown()
        for n in (plant, node):
            n.destroy_node()

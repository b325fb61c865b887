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

"""SIGINT/SIGTERM handling shared by every console script (nodes.ros_console)."""
import os
import signal
import subprocess
import sys
import threading
import time

from conftest import NOTICE_S, spin_until
import pytest
import rclpy
from rclpy.executors import SingleThreadedExecutor
from sma_actuator.nodes import common as c, ros_console
from std_msgs.msg import Float64MultiArray
from support.stopping import stopped_cleanly


@pytest.fixture
def restore_signal_handlers():
    saved = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)}
    yield
    for sig, handler in saved.items():
        signal.signal(sig, handler)


@pytest.mark.parametrize('sig', [signal.SIGINT, signal.SIGTERM])
def test_a_signal_sets_the_stop_flag_and_raises_nothing(restore_signal_handlers, sig):
    stop = ros_console.install_stop_signals()
    assert not stop.is_set()
    os.kill(os.getpid(), sig)   # a KeyboardInterrupt here would fail the test
    assert stop.wait(2.0)


HUNG_TEARDOWN = """
import threading
from sma_actuator.nodes import ros_console
stop = ros_console.install_stop_signals(grace_s={grace})
print('ready', flush=True)
stop.wait()
lock = threading.Lock()
lock.acquire()
lock.acquire({hang})   # a teardown that never ends: deadlocked in the middleware, say
"""


@pytest.mark.parametrize('sig', [signal.SIGINT, signal.SIGTERM])
def test_a_process_hung_after_its_stop_signal_dumps_its_stacks_and_exits_1(sig):
    proc = subprocess.Popen([sys.executable, '-c', HUNG_TEARDOWN.format(grace=0.5, hang='')],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline() == 'ready\n'
        t0 = time.monotonic()
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=NOTICE_S + 0.5)
    finally:
        proc.kill()
    assert proc.returncode == 1
    assert time.monotonic() - t0 >= 0.5           # not before its grace
    assert 'Timeout (0:00:00.500000)!' in err      # faulthandler's dump of every thread
    assert 'File "<string>", line 9 in <module>' in err   # where the main thread hangs


@pytest.mark.parametrize('hung_in', ['destroy_node', 'spin_once'])
def test_only_a_hang_inside_rclpy_destroy_node_counts_as_a_clean_stop(tmp_path, hung_in):
    # the stop grace's own dump (faulthandler) of a process blocked in rclpy's node.py
    (tmp_path / 'rclpy').mkdir()
    (tmp_path / 'rclpy' / '__init__.py').write_text('')
    (tmp_path / 'rclpy' / 'node.py').write_text(f'import time\n\n\ndef {hung_in}():\n'
                                                '    time.sleep(30)\n')
    script = ('import faulthandler, sys\nsys.path.insert(0, sys.argv[1])\n'
              'faulthandler.dump_traceback_later(0.5, exit=True)\n'
              f'from rclpy.node import {hung_in}\n{hung_in}()\n')
    done = subprocess.run([sys.executable, '-c', script, str(tmp_path)], capture_output=True,
                          text=True, timeout=60)
    assert done.returncode == 1 and 'Timeout (0:00:00.500000)!' in done.stderr, done.stderr
    assert stopped_cleanly(done.returncode, done.stderr) == (hung_in == 'destroy_node')
    assert not stopped_cleanly(1, 'Traceback (most recent call last):\n')
    assert stopped_cleanly(0, '')


def test_a_process_that_stops_within_its_grace_exits_normally():
    proc = subprocess.Popen(
        [sys.executable, '-c', HUNG_TEARDOWN.format(grace=NOTICE_S + 5.0, hang='timeout=0.2')],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stdout.readline() == 'ready\n'
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=NOTICE_S)
    finally:
        proc.kill()
    assert (proc.returncode, err) == (0, '')


def test_spin_until_stopped_returns_on_the_flag_with_the_context_still_up(ros_context):
    node = rclpy.create_node('spinner', context=ros_context)
    stop, ticks = threading.Event(), []

    def tick():
        ticks.append(time.monotonic())
        if len(ticks) == 5:
            stop.set()
    node.create_timer(0.01, tick)
    try:
        executor = ros_console.spin_until_stopped(node, stop)
        assert len(ticks) == 5           # no callback after the flag
        assert ros_context.ok()          # the caller can still publish its last word
        assert isinstance(executor, SingleThreadedExecutor)
        executor.shutdown()
    finally:
        node.destroy_node()


def test_spin_until_stopped_returns_when_done_or_the_context_is_shut_down(ros_domain_id):
    context = rclpy.context.Context()
    rclpy.init(context=context, domain_id=ros_domain_id)
    node = rclpy.create_node('spinner', context=context)
    count = []
    node.create_timer(0.01, lambda: count.append(1))
    ros_console.spin_until_stopped(node, threading.Event(), done=lambda: len(count) >= 3)
    assert len(count) == 3
    threading.Timer(0.1, context.try_shutdown).start()
    t0 = time.monotonic()
    ros_console.spin_until_stopped(node, threading.Event())   # returns once the context is down
    assert time.monotonic() - t0 < NOTICE_S and not context.ok()
    node.destroy_node()


@pytest.mark.slow
def test_controller_console_script_exits_0_and_zeroes_the_duty_on_sigint_under_traffic(
        ros_context, ros_domain_id):
    """
    Regression.

    Under load, rclpy's SIGINT handler could interrupt a `take_message` and end the process with
    status 1 (bridge CI failure). Flood the controller with setpoints and joint states, interrupt
    it mid-stream, and expect exit 0 and a final zero duty.
    """
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64
    probe = rclpy.create_node('probe', context=ros_context, namespace=c.NAMESPACE)
    duties = []
    probe.create_subscription(Float64MultiArray, c.DUTY, lambda m: duties.append(list(m.data)),
                              c.COMMAND_QOS)
    sp_pub = probe.create_publisher(Float64, c.SETPOINT, c.COMMAND_QOS)
    js_pub = probe.create_publisher(JointState, c.JOINT_STATES, c.SENSOR_QOS)
    executor = SingleThreadedExecutor(context=ros_context)
    executor.add_node(probe)
    proc = subprocess.Popen([sys.executable, '-m', 'sma_actuator.nodes.controller'],
                            env=dict(os.environ, ROS_DOMAIN_ID=str(ros_domain_id)),
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        deadline = time.monotonic() + NOTICE_S
        while not duties and time.monotonic() < deadline:
            sp_pub.publish(Float64(data=0.2))
            js = JointState(name=[c.JOINT_NAME], position=[0.0], velocity=[0.0])
            js.header.stamp = probe.get_clock().now().to_msg()
            js_pub.publish(js)
            executor.spin_once(timeout_sec=0.002)
        assert duties, 'controller never published a duty'
        t_signal, sent = time.monotonic() + 0.3, False
        while proc.poll() is None and time.monotonic() < t_signal + NOTICE_S:
            if not sent and time.monotonic() >= t_signal:
                proc.send_signal(signal.SIGINT)   # mid-stream: traffic goes on while it stops
                sent = True
            js.header.stamp = probe.get_clock().now().to_msg()
            js_pub.publish(js)
            executor.spin_once(timeout_sec=0.001)
        _, err = proc.communicate(timeout=NOTICE_S)
        assert stopped_cleanly(proc.returncode, err), err
        assert 'Traceback' not in err
        assert spin_until(executor, lambda: duties[-1] == [0.0, 0.0])   # its last word
    finally:
        if proc.poll() is None:
            proc.kill()
        executor.shutdown()
        probe.destroy_node()

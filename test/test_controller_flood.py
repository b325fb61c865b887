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
A setpoint flood must not starve the control step, and rejections are logged throttled.

plant_sim and the controller run as processes; a third process floods the setpoint topic
as fast as it can (about 10 kHz), every other message garbage. The duty messages'
source timestamps (the controller's own clock) must keep the 25 ms cadence with bounded
gaps, and the controller's stderr holds about one rejection WARN per second (issue 13
item 4).
"""
import os
import subprocess
import sys
import textwrap

from conftest import spin_until
import pytest

rclpy = pytest.importorskip('rclpy')
# after the importorskip guard, hence out of the alphabetical order
from rclpy.executors import SingleThreadedExecutor  # noqa: E402, I100
from sma_actuator.nodes import common as c  # noqa: E402
from std_msgs.msg import Float64MultiArray  # noqa: E402

FLOODER = textwrap.dedent("""
    import sys
    import time
    import rclpy
    from std_msgs.msg import Float64
    from sma_actuator.nodes import common as c
    rclpy.init()
    node = rclpy.create_node('flooder', namespace=c.NAMESPACE)
    pub = node.create_publisher(Float64, c.SETPOINT, c.COMMAND_QOS)
    end = time.monotonic() + float(sys.argv[1])
    n = 0
    start = time.time()
    while time.monotonic() < end:
        pub.publish(Float64(data=float('nan') if n % 2 else 0.3))
        n += 1
    print(n, start, time.time(), flush=True)
""")
FLOOD_S = 5.0


@pytest.mark.slow
def test_setpoint_flood_keeps_the_control_period_and_throttles_warnings(ros_context,
                                                                        ros_domain_id):
    env = dict(os.environ, ROS_DOMAIN_ID=str(ros_domain_id))
    node = rclpy.create_node('duty_watch', context=ros_context, namespace=c.NAMESPACE)
    stamps = []    # source timestamps [s] of the duty messages: the controller's clock

    def on_duty(msg, info):
        stamps.append(info['source_timestamp'] * 1e-9)
    node.create_subscription(Float64MultiArray, c.DUTY, on_duty, c.COMMAND_QOS)
    ex = SingleThreadedExecutor(context=ros_context)
    ex.add_node(node)
    plant = subprocess.Popen([sys.executable, '-m', 'sma_actuator.nodes.plant_sim'], env=env,
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    controller = subprocess.Popen([sys.executable, '-m', 'sma_actuator.nodes.controller'],
                                  env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                                  text=True)
    flooder = None
    try:
        assert spin_until(ex, lambda: len(stamps) > 80, 60), 'no duty from the controller'
        spin_until(ex, lambda: False, 1.0)
        flooder = subprocess.Popen([sys.executable, '-c', FLOODER, str(FLOOD_S)], env=env,
                                   stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
                                   text=True)
        spin_until(ex, lambda: flooder.poll() is not None, FLOOD_S + 30)
        sent, flood_start, flood_end = (float(x) for x in flooder.stdout.read().split())
        spin_until(ex, lambda: False, 2.0)
    finally:
        for proc in (flooder, controller, plant):
            if proc is not None and proc.poll() is None:
                proc.terminate()
                proc.wait(10)
        ex.shutdown()
        node.destroy_node()
    log = controller.stderr.read()
    warnings = log.count('rejected setpoint')
    print(f'flood: {sent} setpoints in {FLOOD_S} s ({sent / FLOOD_S:.0f} Hz), '
          f'{warnings} rejection WARN lines, {len(stamps)} duties')
    # duties sent during the flood, and the gaps between them, by the controller's clock
    during = [t for t in stamps if flood_start <= t <= flood_end]
    after = [t for t in stamps if t > flood_end]
    edges = [flood_start] + during + [flood_end]
    gaps = sorted(b - a for a, b in zip(edges, edges[1:]))
    print(f'{len(during)} duties during the flood, {len(after)} after; gaps: median '
          f'{gaps[len(gaps) // 2] * 1e3:.1f} ms, max {gaps[-1] * 1e3:.1f} ms')
    assert sent > 2000 * FLOOD_S, 'the flood was too thin to show anything'
    assert warnings <= FLOOD_S + 5, f'{warnings} rejection warnings in {FLOOD_S} s'
    assert after, 'the controller stopped publishing duty'
    assert len(during) >= 0.5 * (flood_end - flood_start) / 0.025
    assert gaps[len(gaps) // 2] < 0.035            # the 25 ms cadence holds throughout
    # a starved step lengthens many gaps; one long gap is the scheduler of a busy machine
    # (the flooder and the nodes share 2 cores with the other tests: 0.66 s seen once)
    assert gaps[int(0.95 * len(gaps))] < 0.1, 'the control step stalled during the flood'
    assert gaps[-1] < 2.0, 'the control step stopped during the flood'

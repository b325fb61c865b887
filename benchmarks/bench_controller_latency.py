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
Controller timing.

Joint-state arrival -> duty publication (p50/p99) and the 25 ms watchdog timer's jitter (p99), with
the controller running as its own process.

A probe in this process publishes /sma/joint_states at 40 Hz (a slowly moving shaft, so
the controller does real work in mode pi_inverse) and listens on /sma/duty and
/diagnostics. Printed:
  round trip     probe publish -> duty received (two DDS hops + the controller)
  controller     rmw arrival of the joint state -> duty published, as measured inside the
                 controller and reported in its diagnostics (the figure with the < 2 ms target;
                 over the controller's last 2000 samples)
  timer jitter   p99 of |interval − 25 ms| of the controller's watchdog timer

Run: python benchmarks/bench_controller_latency.py [--seconds 30] [--mode pi_inverse] [--rt 50]
(--rt: the controller under SCHED_FIFO, as a real-time deployment would run it; on a busy
host the p99 without it is set by the scheduler, not by the controller)
"""
import argparse
import math
import os
import random
import subprocess
import sys
import time

from diagnostic_msgs.msg import DiagnosticArray
import numpy as np
import rclpy
from rclpy.executors import SingleThreadedExecutor
from sensor_msgs.msg import JointState
from sma_actuator.nodes import common as c
from std_msgs.msg import Float64, Float64MultiArray, Header


def main():
    ap = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    ap.add_argument('--seconds', type=float, default=30.0)
    ap.add_argument('--mode', default='pi_inverse', choices=['pi', 'pi_inverse', 'on_off'])
    ap.add_argument('--warmup', type=float, default=2.0, help='seconds not counted')
    ap.add_argument('--rt', type=int, default=0, metavar='PRIO',
                    help='run the controller under SCHED_FIFO priority PRIO (chrt; needs the '
                         'privilege), as a real-time deployment would')
    ns = ap.parse_args()
    domain = random.SystemRandom().randint(101, 200)
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
    os.environ.update(ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
    prefix = ['chrt', '-f', str(ns.rt)] if ns.rt else []
    cmd = [sys.executable, '-m', 'sma_actuator.nodes.controller', '--ros-args',
           '-p', f'mode:={ns.mode}', '-p', 'feedback_timeout_s:=1.0']
    proc = subprocess.Popen(prefix + cmd, env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    context = rclpy.context.Context()
    rclpy.init(context=context, domain_id=domain)
    node = rclpy.create_node('latency_probe', context=context, namespace=c.NAMESPACE)
    ex = SingleThreadedExecutor(context=context)
    ex.add_node(node)
    sent, rtt, stats = [None], [], {}
    js = node.create_publisher(JointState, c.JOINT_STATES, c.SENSOR_QOS)
    sp = node.create_publisher(Float64, c.SETPOINT, c.COMMAND_QOS)

    def on_duty(_):
        if sent[0] is not None:
            rtt.append(time.perf_counter() - sent[0])
            sent[0] = None

    def on_diag(msg):
        for s in msg.status:
            if s.name.startswith('controller'):
                stats.update({kv.key: kv.value for kv in s.values})

    node.create_subscription(Float64MultiArray, c.DUTY, on_duty, c.COMMAND_QOS)
    node.create_subscription(DiagnosticArray, c.DIAGNOSTICS, on_diag, c.DIAGNOSTICS_QOS)
    t_start, cleared = [None], []

    def tick():
        now = time.perf_counter()
        t = 0.0 if t_start[0] is None else now - t_start[0]
        if t_start[0] is None:
            t_start[0] = now
        if t >= ns.warmup and not cleared:
            rtt.clear()                      # discovery and first samples are not counted
            cleared.append(True)
        sent[0] = time.perf_counter()
        js.publish(JointState(name=[c.JOINT_NAME], position=[0.3 * math.sin(0.3 * t)],
                              velocity=[0.0],
                              header=Header(stamp=node.get_clock().now().to_msg())))

    try:
        deadline = time.monotonic() + 30
        while sp.get_subscription_count() == 0 and time.monotonic() < deadline:
            ex.spin_once(timeout_sec=0.1)
        if sp.get_subscription_count() == 0:
            sys.exit('controller process did not come up')
        sp.publish(Float64(data=0.2))
        node.create_timer(0.025, tick)
        end = time.monotonic() + ns.seconds + ns.warmup
        while time.monotonic() < end:
            ex.spin_once(timeout_sec=0.05)
        stats.clear()                        # wait for a report covering the whole run
        end = time.monotonic() + 3
        while not stats and time.monotonic() < end:
            ex.spin_once(timeout_sec=0.05)
    finally:
        proc.terminate()
        proc.wait(10)
        ex.shutdown()
        node.destroy_node()
        rclpy.shutdown(context=context)
    r = np.asarray(rtt) * 1e3
    print(f'controller latency benchmark, mode {ns.mode}, {ns.seconds:g} s at 40 Hz '
          f'({len(r)} samples), {os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f}, '
          f'{"SCHED_FIFO %d" % ns.rt if ns.rt else "normal scheduling"}')
    print(f'{"figure":44s} {"p50 [ms]":>9s} {"p99 [ms]":>9s}')
    print(f'{"round trip probe -> controller -> probe":44s} {np.percentile(r, 50):9.3f} '
          f'{np.percentile(r, 99):9.3f}')
    print(f'{"controller: arrival -> duty published":44s} '
          f'{float(stats.get("latency_p50_ms", "nan")):9.3f} '
          f'{float(stats.get("latency_p99_ms", "nan")):9.3f}   (target p99 < 2 ms)')
    print(f'{"controller: 25 ms timer jitter":44s} {"":9s} '
          f'{float(stats.get("timer_jitter_p99_ms", "nan")):9.3f}')


if __name__ == '__main__':
    main()

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
Replay timing error p50/p99 against the recorded log times.

Writes a bag of the five /sma topics at RATE Hz each (log times exactly periodic, topics phase
shifted), plays it with the replay console script at each rate factor, and subscribes in
this process. For every message it compares the DDS source timestamp (when replay published
it) and the receive timestamp with the schedule ``log time / factor``, after removing the
constant offset (median); it prints p50/p99/max of the absolute error and the messages missed.

    python benchmarks/bench_replay.py                       # 200 Hz x 5 topics, factors 1, 2
    python benchmarks/bench_replay.py --rate 1000 --factors 1 --duration 10
"""
import argparse
import os
from pathlib import Path
import random
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np

TOPICS = ['/sma/setpoint', '/sma/duty', '/sma/joint_states', '/sma/wire_a/temperature',
          '/sma/ambient_temperature']
T0 = 1_700_000_000_000_000_000


def write_bag(path, rate_hz, duration_s):
    """Bag with message k of topic j logged at T0 + k/rate + j/(5 rate); payload holds k."""
    from sma_actuator.bag.synthetic import SMA_TOPICS, offered_profile, stamp, to_cdr
    from sma_actuator.bag.writer import BagWriter
    period_ns = int(1e9 / rate_hz)
    written = []   # (topic, message, time [ns])
    for k in range(int(rate_hz * duration_s)):
        for j, topic in enumerate(TOPICS):
            t = T0 + k * period_ns + j * period_ns // len(TOPICS)
            if topic == '/sma/setpoint':
                msg = {'data': float(k)}
            elif topic == '/sma/duty':
                msg = {'data': [float(k), 0.0]}
            elif topic == '/sma/joint_states':
                msg = {'header': {'stamp': stamp(t)}, 'name': ['shaft'],
                       'position': [float(k)], 'velocity': [0.0]}
            else:
                msg = {'header': {'stamp': stamp(t)}, 'temperature': float(k)}
            written.append((topic, msg, t))
    payloads = to_cdr([(SMA_TOPICS[topic][0], msg) for topic, msg, _ in written])
    with BagWriter(path) as bag:
        for topic in TOPICS:
            type_name, reliability = SMA_TOPICS[topic]
            bag.add_topic(topic, type_name, [offered_profile(reliability)])
        for (topic, _, t), data in zip(written, payloads):
            bag.write(topic, data, t)


def measure(bag, factor, rate_hz, duration_s):
    """Play the bag at ``factor``; return (errors_source_ns, errors_received_ns, missed)."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState, Temperature
    from std_msgs.msg import Float64, Float64MultiArray

    types = {'/sma/setpoint': Float64, '/sma/duty': Float64MultiArray,
             '/sma/joint_states': JointState, '/sma/wire_a/temperature': Temperature,
             '/sma/ambient_temperature': Temperature}
    context = rclpy.context.Context()
    rclpy.init(context=context)
    node = rclpy.create_node('bench_replay_probe', context=context)
    got = []
    for topic, ty in types.items():
        # deep queues: measure the replay, not this probe's queue overflowing
        qos = QoSProfile(depth=1000) if ty in (Float64, Float64MultiArray) else \
            QoSProfile(depth=1000, reliability=ReliabilityPolicy.BEST_EFFORT)
        node.create_subscription(ty, topic, lambda m, info, t=topic: got.append((t, m, info)),
                                 qos)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    command = [str(Path(sys.prefix) / 'lib' / 'sma_actuator' / 'replay')]
    if not Path(command[0]).exists():
        command = [sys.executable, '-m', 'sma_actuator.nodes.replay']
    proc = subprocess.Popen(command + ['--ros-args', '-p', f'bag_path:={bag}',
                                       '-p', f'rate:={float(factor)}',
                                       '-p', 'wait_for_subscribers_s:=10.0'],
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        end = time.monotonic() + 10 + duration_s / factor + 10
        while proc.poll() is None and time.monotonic() < end:
            executor.spin_once(timeout_sec=0.01)
        for _ in range(50):
            executor.spin_once(timeout_sec=0.01)
    finally:
        if proc.poll() is None:
            proc.kill()
        proc.wait()
        executor.shutdown()
        node.destroy_node()
        rclpy.shutdown(context=context)
    period_ns = int(1e9 / rate_hz)
    duty_at = [i for i, (topic, _, _) in enumerate(got) if topic == '/sma/duty']
    if duty_at and list(got[duty_at[-1]][1].data) == [0.0, 0.0] and len(duty_at) > 1:
        del got[duty_at[-1]]  # the zero duty the replay sends when it ends
    scheduled, source, received = [], [], []
    for topic, msg, info in got:
        k = int(msg.data[0] if topic == '/sma/duty' else msg.position[0] if
                topic == '/sma/joint_states' else msg.temperature if hasattr(msg, 'temperature')
                else msg.data)
        j = TOPICS.index(topic)
        scheduled.append((k * period_ns + j * period_ns // len(TOPICS)) / factor)
        source.append(info['source_timestamp'])
        received.append(info['received_timestamp'])
    scheduled = np.asarray(scheduled)
    errors = []
    for stamps in (np.asarray(source, dtype=float), np.asarray(received, dtype=float)):
        offset = np.median(stamps - scheduled)
        errors.append(np.abs(stamps - scheduled - offset))
    return errors[0], errors[1], len(TOPICS) * int(rate_hz * duration_s) - len(scheduled)


def main():
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument('--rate', type=float, default=200.0, help='per-topic rate in the bag')
    parser.add_argument('--duration', type=float, default=5.0, help='bag length [s]')
    parser.add_argument('--factors', type=float, nargs='*', default=[1.0, 2.0])
    args = parser.parse_args()
    os.environ.setdefault('ROS_DOMAIN_ID', str(random.SystemRandom().randint(101, 200)))
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    workdir = Path(tempfile.mkdtemp(prefix='bench_replay_'))
    try:
        write_bag(workdir / 'bag', args.rate, args.duration)
        print(f'bag: {len(TOPICS)} topics x {args.rate:.0f} Hz x {args.duration:.0f} s '
              f'({len(TOPICS) * args.rate:.0f} msg/s); {os.cpu_count()} CPUs')
        for factor in args.factors:
            src, rcv, missed = measure(workdir / 'bag', factor, args.rate, args.duration)
            print(f'rate factor {factor:g}: {len(src)} messages, missed {missed}; timing error '
                  f'publish p50 {np.percentile(src, 50) / 1e3:.0f} us, p99 '
                  f'{np.percentile(src, 99) / 1e3:.0f} us, max {src.max() / 1e3:.0f} us; '
                  f'receive p50 {np.percentile(rcv, 50) / 1e3:.0f} us, p99 '
                  f'{np.percentile(rcv, 99) / 1e3:.0f} us', flush=True)
    finally:
        shutil.rmtree(workdir, ignore_errors=True)


if __name__ == '__main__':
    main()

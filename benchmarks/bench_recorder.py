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
Recorder throughput: messages recorded without loss at 1 kHz on 5 topics, and the highest rate.

A publisher process sends the five /sma topics with their contract QoS (setpoint/duty reliable,
joint states/temperatures best effort), each at RATE Hz for DURATION s, a sequence number in
every message. The recorder runs as its console script in its own process; after the
publisher ends it gets SIGINT, and the bag is read back to count, per topic, messages lost
(sequence numbers missing). Rates are stepped up until something is lost.

    python benchmarks/bench_recorder.py                 # 1 kHz, then 2, 4, 6, 8... kHz
    python benchmarks/bench_recorder.py --rates 1000 3000 --duration 10

Prints one line per rate: sent/recorded per topic, loss, recorder CPU share. Uses a private
ROS_DOMAIN_ID; numbers depend on the machine and on what else runs on it.
"""
import argparse
import os
from pathlib import Path
import random
import shutil
import signal
import subprocess
import sys
import tempfile
import time

DEFAULT_RATES = [1000, 2000, 4000, 6000, 8000, 12000, 16000]
TOPICS = ['/sma/setpoint', '/sma/duty', '/sma/joint_states', '/sma/wire_a/temperature',
          '/sma/ambient_temperature']


def publisher(rate_hz, duration_s):
    """Publish the five topics at rate_hz each; print how many were sent per topic."""
    import rclpy
    from rclpy.duration import Duration
    from rclpy.qos import QoSProfile, qos_profile_sensor_data
    from sensor_msgs.msg import JointState, Temperature
    from std_msgs.msg import Float64, Float64MultiArray

    rclpy.init()
    node = rclpy.create_node('bench_publisher')
    reliable = QoSProfile(depth=100)
    msgs = {'/sma/setpoint': (Float64(), reliable),
            '/sma/duty': (Float64MultiArray(data=[0.0, 0.0]), reliable),
            '/sma/joint_states': (JointState(name=['shaft'], position=[0.0], velocity=[0.0]),
                                  qos_profile_sensor_data),
            '/sma/wire_a/temperature': (Temperature(), qos_profile_sensor_data),
            '/sma/ambient_temperature': (Temperature(), qos_profile_sensor_data)}
    pubs = {t: node.create_publisher(type(m), t, q) for t, (m, q) in msgs.items()}
    deadline = time.monotonic() + 20
    while min(p.get_subscription_count() for p in pubs.values()) == 0:
        if time.monotonic() > deadline:
            sys.exit('recorder did not subscribe to every topic within 20 s')
        time.sleep(0.05)
    time.sleep(1.0)  # let every connection settle before counting

    def set_seq(topic, msg, seq):
        if topic == '/sma/setpoint':
            msg.data = float(seq)
        elif topic == '/sma/duty':
            msg.data[0] = float(seq)
        elif topic == '/sma/joint_states':
            msg.position[0] = float(seq)
            msg.header.stamp = node.get_clock().now().to_msg()
        else:
            msg.temperature = float(seq)

    total = int(rate_hz * duration_s)
    start = time.perf_counter()
    sent = 0
    while sent < total:
        due = int((time.perf_counter() - start) * rate_hz) + 1
        for seq in range(sent, min(due, total)):
            for topic, (msg, _) in msgs.items():
                set_seq(topic, msg, seq)
                pubs[topic].publish(msg)
        sent = max(sent, min(due, total))
        time.sleep(max(0.0, (sent / rate_hz) - (time.perf_counter() - start)))
    elapsed = time.perf_counter() - start
    for pub in pubs.values():  # reliable ones: do not exit before the recorder has them
        pub.wait_for_all_acked(Duration(seconds=5.0))
    time.sleep(0.5)
    print(f'SENT {total} {elapsed:.3f}', flush=True)
    node.destroy_node()
    rclpy.shutdown()


def _cpu_seconds(pid):
    """User+system CPU time [s] of a process so far (Linux /proc)."""
    fields = Path(f'/proc/{pid}/stat').read_text().rsplit(')', 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf('SC_CLK_TCK')


def _sequences(bag):
    """Sequence numbers recorded per topic."""
    from rclpy.serialization import deserialize_message
    from sensor_msgs.msg import JointState, Temperature
    from std_msgs.msg import Float64, Float64MultiArray

    from sma_actuator.bag.reader import BagReader
    decode = {'/sma/setpoint': lambda d: deserialize_message(d, Float64).data,
              '/sma/duty': lambda d: deserialize_message(d, Float64MultiArray).data[0],
              '/sma/joint_states': lambda d: deserialize_message(d, JointState).position[0],
              '/sma/wire_a/temperature': lambda d: deserialize_message(d, Temperature).temperature,
              '/sma/ambient_temperature':
                  lambda d: deserialize_message(d, Temperature).temperature}
    seqs = {t: [] for t in TOPICS}
    for msg in BagReader(bag).messages(TOPICS):
        seqs[msg.topic].append(int(decode[msg.topic](msg.data)))
    return seqs


def run_rate(rate_hz, duration_s, workdir):
    """Record one run at rate_hz per topic; return (sent per topic, seqs, cpu share, wall)."""
    bag = Path(tempfile.mkdtemp(prefix=f'rate{rate_hz}_', dir=workdir)) / 'bag'
    recorder = [str(Path(sys.prefix) / 'lib' / 'sma_actuator' / 'recorder')]
    if not Path(recorder[0]).exists():
        recorder = [sys.executable, '-m', 'sma_actuator.nodes.recorder']
    rec = subprocess.Popen(recorder + ['--ros-args', '-p', f'bag_path:={bag}',
                                       '-p', 'topics:=[/sma/*]'],
                           stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        time.sleep(1.0)
        if rec.poll() is not None:
            raise RuntimeError(f'recorder exited: {rec.stderr.read().decode()}')
        cpu0, t0 = _cpu_seconds(rec.pid), time.monotonic()
        pub = subprocess.run([sys.executable, __file__, '--publisher', str(rate_hz),
                              str(duration_s)], capture_output=True, text=True, timeout=600)
        if pub.returncode != 0:
            raise RuntimeError(f'publisher failed: {pub.stdout}{pub.stderr}')
        sent_line = [ln for ln in pub.stdout.splitlines() if ln.startswith('SENT')][0]
        sent, pub_elapsed = int(sent_line.split()[1]), float(sent_line.split()[2])
        time.sleep(1.0)
        cpu = (_cpu_seconds(rec.pid) - cpu0) / (time.monotonic() - t0)
        rec.send_signal(signal.SIGINT)
        rec.wait(timeout=60)
    finally:
        if rec.poll() is None:
            rec.kill()
            rec.wait()
    return sent, _sequences(bag), cpu, pub_elapsed


def _ranges(numbers):
    """'3-7, 12' style summary of sorted integers (first 5 ranges)."""
    spans, start, prev = [], numbers[0], numbers[0]
    for n in numbers[1:] + [None]:
        if n is None or n != prev + 1:
            spans.append(f'{start}-{prev}' if prev > start else f'{start}')
            start = n
        prev = n if n is not None else prev
    return ', '.join(spans[:5]) + (f' ... ({len(spans)} gaps)' if len(spans) > 5 else '')


def main():
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument('--rates', type=int, nargs='*', default=None,
                        help='per-topic rates [Hz] to run (default: 1 kHz up, until loss)')
    parser.add_argument('--duration', type=float, default=5.0, help='seconds per rate')
    parser.add_argument('--max-rate', type=int, default=16000)
    parser.add_argument('--publisher', nargs=2, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.publisher:
        return publisher(int(args.publisher[0]), float(args.publisher[1]))
    os.environ.setdefault('ROS_DOMAIN_ID', str(random.SystemRandom().randint(101, 200)))
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    rates = args.rates or [r for r in DEFAULT_RATES if r <= args.max_rate]
    workdir = tempfile.mkdtemp(prefix='bench_recorder_')
    print(f'{len(TOPICS)} topics, {args.duration:.0f} s per rate, ROS_DOMAIN_ID='
          f"{os.environ['ROS_DOMAIN_ID']}, {os.cpu_count()} CPUs")
    best = None
    try:
        for rate in rates:
            sent, seqs, cpu, pub_elapsed = run_rate(rate, args.duration, workdir)
            lost = {t: sent - len(set(s)) for t, s in seqs.items()}
            total_lost = sum(lost.values())
            achieved = sent / pub_elapsed
            print(f'rate {rate:6d} Hz/topic ({len(TOPICS) * rate:6d} msg/s): publisher '
                  f'achieved {achieved:7.0f} Hz/topic; recorded '
                  f'{sum(len(s) for s in seqs.values())}/{sent * len(TOPICS)}; lost '
                  f'{total_lost} ' + ' '.join(f'{t.rsplit("/", 1)[1]}={n}'
                                              for t, n in lost.items() if n)
                  + f'; recorder CPU {100 * cpu:.0f}% of one core', flush=True)
            for topic, seq in seqs.items():
                missing = sorted(set(range(sent)) - set(seq))
                if missing:
                    print(f'    {topic}: missing {_ranges(missing)}')
            if total_lost == 0 and achieved >= 0.97 * rate:
                best = rate
            elif args.rates is None:
                break
    finally:
        shutil.rmtree(workdir, ignore_errors=True)
    print(f'highest rate without loss: {best} Hz per topic '
          f'({best * len(TOPICS) if best else 0} msg/s)')


if __name__ == '__main__':
    main()

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
Replay a recorded run's duty into a fresh plant_sim, N times, and compare the shaft angles.

Records a reference closed-loop run (plant_sim + controller + square setpoint in lockstep on
sim time, with the recorder), then N times: starts plant_sim (accelerated, lockstep) and
replay with follow_clock (topics: the duty only), collects the plant's joint states from
this process and compares them with the recorded ones at the same bag time. Prints
RMS and max |error| [rad] per run and whether each is within the tolerance. With --busy K,
K busy loops (`python -c 'while True: pass'`) load the machine during the runs; they are
killed by PID at the end.

    python benchmarks/bench_replay_plant.py --runs 10 --busy 2
"""
import argparse
import os
from pathlib import Path
import random
import signal
import subprocess
import sys
import tempfile
import time

import numpy as np

# the replayed plant must reproduce the recording within these [rad]
RMS_TOLERANCE_RAD = 0.005
MAX_TOLERANCE_RAD = 0.02
PROFILE = {'profile': 'square', 'amplitude': 0.3, 'offset': 0.0, 'period_s': 8.0,
           'delay_s': 1.0}


def _console(name):
    script = Path(sys.prefix) / 'lib' / 'sma_actuator' / name
    if script.exists():
        return [str(script)]
    return [sys.executable, '-m', f'sma_actuator.nodes.{name}']


def record_reference(bag, duration_s=16.0):
    """Record a lockstep closed-loop run (sim time) to ; return the bag path."""
    import rclpy

    from sma_actuator.in_process import run_closed_loop
    from sma_actuator.nodes.recorder import RecorderNode
    context = rclpy.context.Context()
    rclpy.init(context=context)
    try:
        run_closed_loop(context, PROFILE, duration_s, mode='pi', real_time_factor=20.0,
                        attach=[lambda ctx: RecorderNode(context=ctx, bag_path=str(bag),
                                                         use_sim_time=True)])
    finally:
        rclpy.try_shutdown(context=context)
    return bag


def joint_states(bag, topic='/sma/joint_states'):
    """Return (stamp [s], position [rad]) of a bag's joint states, sorted by stamp."""
    from mcap_ros2.reader import read_ros2_messages
    files = sorted(Path(bag).glob('*.mcap')) if Path(bag).is_dir() else [Path(bag)]
    rows = [(m.ros_msg.header.stamp.sec + 1e-9 * m.ros_msg.header.stamp.nanosec,
             m.ros_msg.position[0]) for f in files
            for m in read_ros2_messages(str(f), topics=[topic])]
    rows.sort()
    return np.array([r[0] for r in rows]), np.array([r[1] for r in rows])


def replay_once(bag, domain_id, wall_limit_s=180.0):
    """
    Play the bag's duty into a new plant_sim on /clock; return the plant's (stamp, position).

    The replay waits until the plant's duty subscription is matched before it plays.
    """
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState

    from sma_actuator.nodes import common as c
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain_id))
    context = rclpy.context.Context()
    rclpy.init(context=context, domain_id=domain_id)
    node = rclpy.create_node('replay_probe', context=context, namespace=c.NAMESPACE)
    got = []
    # a deep queue: this process may be starved by the busy loops while the plant runs ahead
    deep = QoSProfile(depth=10000, reliability=ReliabilityPolicy.BEST_EFFORT)
    node.create_subscription(JointState, c.JOINT_STATES, lambda m: got.append(
        (c.stamp_to_s(m.header.stamp), m.position[0])), deep)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    # the plant owns the time and steps in lockstep with the replay (follow_clock), as it
    # did with the controller when the run was recorded; its duty timeout is also the duty
    # samples' lifespan in wall time, which a starved plant must not outwait
    plant = subprocess.Popen(_console('plant_sim') + [
        '--ros-args', '-p', 'accelerated:=true', '-p', 'lockstep:=true',
        '-p', 'lockstep_timeout_s:=10.0', '-p', 'real_time_factor:=20.0',
        '-p', 'duty_timeout_s:=5.0'], env=env,
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    replay = None
    try:
        # the probe must see the plant's joint states before the replay starts them: a
        # starved probe process that discovers the plant late would miss the short replay
        deadline = time.monotonic() + wall_limit_s
        while node.count_publishers(c.JOINT_STATES) < 1 and time.monotonic() < deadline:
            if plant.poll() is not None:
                raise RuntimeError(f'plant_sim exited {plant.returncode} before the replay')
            executor.spin_once(timeout_sec=0.05)
        replay = subprocess.Popen(_console('replay') + [
            '--ros-args', '-p', f'bag_path:={bag}', '-p', "topics:=['/sma/duty']",
            '-p', 'follow_clock:=true', '-p', 'wait_for_subscribers_s:=60.0'], env=env,
            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        deadline = time.monotonic() + wall_limit_s
        while replay.poll() is None and time.monotonic() < deadline:
            if plant.poll() is not None:
                raise RuntimeError(f'plant_sim exited {plant.returncode} during the replay')
            executor.spin_once(timeout_sec=0.05)
        end = time.monotonic() + 1.0
        while time.monotonic() < end:      # the last joint states in flight
            executor.spin_once(timeout_sec=0.05)
    finally:
        procs = [proc for proc in (replay, plant) if proc is not None]
        for proc in procs:
            if proc.poll() is None:
                proc.send_signal(signal.SIGINT)
        for proc in procs:
            try:
                proc.wait(30.0)
            except subprocess.TimeoutExpired:
                proc.kill()
        node.destroy_node()
        rclpy.try_shutdown(context=context)
    if replay.returncode != 0:
        raise RuntimeError(f'replay exited {replay.returncode}: {replay.stderr.read()[-500:]}')
    got.sort()
    return np.array([g[0] for g in got]), np.array([g[1] for g in got])


def compare(reference, replayed, period_s=0.025, max_shift_s=30.0):
    """
    Return (RMS, max) |replayed - recorded| [rad] and the time offset [s] of the replay.

    The plant's time starts before the replay joins it, so its stamps are the bag's plus a
    constant offset (a whole number of plant steps): the one that fits best is used.
    """
    (t_ref, p_ref), (t, p) = reference, replayed
    best = None
    for shift in np.arange(0.0, max_shift_s, period_s):
        tt = t - shift
        inside = (tt >= t_ref[0]) & (tt <= t_ref[-1])
        if inside.sum() < 0.5 * len(t_ref):   # a best-effort probe may miss some
            continue
        error = p[inside] - np.interp(tt[inside], t_ref, p_ref)
        rms = float(np.sqrt(np.mean(error ** 2)))
        if best is None or rms < best[0]:
            best = (rms, float(np.max(np.abs(error))), float(shift))
    if best is None:
        raise RuntimeError(f'the plant published {len(t)} joint states; the recording has '
                           f'{len(t_ref)}')
    return best


def main(argv=None):
    """Run the benchmark; print one line per run and a summary."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    ap.add_argument('--runs', type=int, default=10)
    ap.add_argument('--busy', type=int, default=2, help='busy loops during the runs')
    ap.add_argument('--duration', type=float, default=16.0, help='reference length [sim s]')
    ap.add_argument('--domain', type=int, default=int(os.environ.get('ROS_DOMAIN_ID', 0)))
    args = ap.parse_args(argv)
    domain = args.domain or random.SystemRandom().randint(1, 100)
    with tempfile.TemporaryDirectory() as tmp:
        bag = record_reference(Path(tmp) / 'reference', args.duration)
        reference = joint_states(bag)
        print(f'reference: {len(reference[0])} joint states over '
              f'{reference[0][-1] - reference[0][0]:.1f} sim s; tolerance RMS '
              f'{RMS_TOLERANCE_RAD} rad, max {MAX_TOLERANCE_RAD} rad; {args.busy} busy loops')
        busy = [subprocess.Popen([sys.executable, '-c', 'while True: pass'])
                for _ in range(args.busy)]
        results = []
        try:
            for run in range(1, args.runs + 1):
                t0 = time.monotonic()
                rms, worst, shift = compare(reference, replay_once(bag, domain))
                ok = rms <= RMS_TOLERANCE_RAD and worst <= MAX_TOLERANCE_RAD
                results.append(ok)
                print(f'run {run:2d}: RMS {rms:.4f} rad  max {worst:.4f} rad  offset '
                      f'{shift:.3f} s  {"ok" if ok else "OUTSIDE TOLERANCE"}  '
                      f'({time.monotonic() - t0:.1f} s wall)', flush=True)
        finally:
            for proc in busy:
                os.kill(proc.pid, signal.SIGKILL)
                proc.wait()
    print(f'{sum(results)} of {len(results)} runs within tolerance')
    return 0 if all(results) else 1


if __name__ == '__main__':
    sys.exit(main())

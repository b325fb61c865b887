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
Bridge round-trip latency over the MCU emulator.

/sma/duty in -> Duty frame out -> ADC report back -> /sma/joint_states out, p50/p99 at 1 Mbaud and
115200 baud.

Three processes, as on a real rig: `mcu_emulator` (pty, UART modelled at the given baud),
the `hardware_bridge` console script, and this script's probe node, which publishes a
duty command every 20 ms and times the first joint state that follows it. The bridge's
periodic reports are slowed to 1 Hz (and the MCU restarts that period at every duty
frame) and its duty refresh to 11 Hz, so every joint state in the window answers the
probe's own command. Also printed: the bridge's own duty-frame -> report time from its
diagnostics (excludes DDS), and the pure wire time of the two frames.

    .venv/bin/python benchmarks/bench_bridge_latency.py [--samples 500] [--bauds 1000000 115200]
"""
import argparse
import os
from pathlib import Path
import random
import sys
import threading
import time

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'test'))
from hardware_support import (console_command, Probe, start_emulator_process,  # noqa: E402
                              stop_process, wait_for)
import numpy as np  # noqa: E402
import rclpy  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from sma_actuator.hardware import protocol as p  # noqa: E402

PERIOD_S = 0.02
WIRE_BYTES = len(p.Duty(0, 0).encode(0)) + len(p.AdcReport(0, 0, 0, 0, 0, 0).encode(0))


def measure(baud, samples, domain):
    """Median/percentiles [ms] of the duty -> joint state latency at `baud`."""
    import subprocess
    emulator, port = start_emulator_process('--baud', str(baud))
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain))
    bridge = subprocess.Popen(
        console_command('hardware_bridge', 'sma_actuator.nodes.hardware_bridge')
        + ['--ros-args', '-p', f'port:={port}', '-p', f'baud:={baud}',
           '-p', 'publish_rate_hz:=1.0', '-p', 'duty_refresh_hz:=11.0', '-p', 'heartbeat_hz:=0.2',
           '-p', 'diagnostics_rate_hz:=2.0',
           '--log-level', 'warn'],
        env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    context = rclpy.context.Context()
    rclpy.init(context=context, domain_id=domain)
    probe = Probe(context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(probe)
    spinner = threading.Thread(target=executor.spin, daemon=True)
    spinner.start()
    try:
        if not wait_for(lambda: probe.status('link')
                        and probe.status('link')[1] == 'connected', 30.0):
            raise RuntimeError(f'bridge did not connect: {probe.status("link")}')
        latencies, unmatched = [], 0
        for k in range(samples + 20):                      # 20 warm-up commands
            n = len(probe.joint_states)
            probe.duty(0.02 * (k % 2), 0.0)
            sent = probe.last_duty_s
            time.sleep(PERIOD_S)
            replies = [t for t, _ in probe.joint_states[n:] if t > sent]
            if k < 20:
                continue
            if replies:
                latencies.append(replies[0] - sent)
            else:
                unmatched += 1
        probe.duty(0.0, 0.0)
        time.sleep(0.6)
        internal = probe.status('link')[2]
    finally:
        executor.shutdown(timeout_sec=2.0)
        probe.destroy_node()
        rclpy.shutdown(context=context)
        stop_process(bridge)
        stop_process(emulator)
    ms = np.array(latencies) * 1e3
    p50, p90, p99 = np.percentile(ms, [50, 90, 99])
    return {'n': len(ms), 'unmatched': unmatched, 'p50': p50, 'p90': p90, 'p99': p99,
            'max': ms.max(), 'wire': WIRE_BYTES * 10 / baud * 1e3,
            'bridge': f"{internal['duty_to_report_ms_p50']}/{internal['duty_to_report_ms_p99']}"}


def main():
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument(
        '--samples',
        type=int,
        default=500,
        help='commands per baud rate (default: %(default)s)')
    parser.add_argument('--bauds', type=int, nargs='+', default=[1_000_000, 115200])
    args = parser.parse_args()
    domain = random.SystemRandom().randint(101, 200)
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    print(f'bridge round trip /sma/duty -> frame -> ADC report -> /sma/joint_states, '
          f'{args.samples} commands at {1 / PERIOD_S:.0f} Hz per baud rate; '
          f'load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} CPUs')
    columns = ('baud', 'n', 'p50 ms', 'p90 ms', 'p99 ms', 'max ms', 'wire ms')
    print(' '.join(f'{c:>9}' for c in columns), f'{"bridge p50/p99 ms":>18} {"unmatched":>9}')
    for baud in args.bauds:
        r = measure(baud, args.samples, domain)
        numbers = [f'{r[k]:>9.3f}' for k in ('p50', 'p90', 'p99', 'max', 'wire')]
        print(f'{baud:>9} {r["n"]:>9}', *numbers, f'{r["bridge"]:>18} {r["unmatched"]:>9}',
              flush=True)


if __name__ == '__main__':
    main()

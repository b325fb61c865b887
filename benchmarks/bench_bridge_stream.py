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
Joint-state stream rate through hardware_bridge, with and without line noise.

The figure test_bridge_node no longer asserts (a rate measured by the test process depends
on the machine's load; the test asserts progress). The bridge node and the MCU emulator run
in this process, as in that test (emulator thread on a pty at 1 Mbaud, 200 Hz ADC reports);
a probe node counts the /sma/joint_states it receives over `--seconds` while it commands a
duty at 40 Hz. Prints joint states per second and the link's CRC and framing errors for
each line-noise rate, and the load average.

    .venv/bin/python benchmarks/bench_bridge_stream.py [--seconds 5] [--noise-hz 0 40]
"""
import argparse
import os
from pathlib import Path
import random
import sys
import threading
import time

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / 'test'))
from hardware_support import emulator_thread, Probe, wait_for  # noqa: E402
import rclpy  # noqa: E402
from rclpy.executors import SingleThreadedExecutor  # noqa: E402
from rclpy.parameter import Parameter  # noqa: E402
from sma_actuator.nodes.hardware_bridge import HardwareBridge  # noqa: E402


def measure(noise_hz, seconds, domain):
    """Return (joint states per second, CRC errors, framing errors) at `noise_hz` line noise."""
    context = rclpy.context.Context()
    rclpy.init(context=context, domain_id=domain)
    with emulator_thread(baud=1_000_000, seed=2, line_noise_hz=noise_hz) as (_, port):
        bridge = HardwareBridge(context=context, parameter_overrides=[
            Parameter('port', value=port), Parameter('baud', value=1_000_000),
            Parameter('diagnostics_rate_hz', value=10.0)])
        probe = Probe(context=context)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(bridge)
        executor.add_node(probe)
        spinner = threading.Thread(target=executor.spin, daemon=True)
        spinner.start()
        try:
            if not wait_for(lambda: probe.status('link')
                            and probe.status('link')[1] == 'connected', 30.0):
                raise RuntimeError(f'bridge did not connect: {probe.status("link")}')
            probe.hold(0.3, 0.0, 1.0)                       # warm-up
            n0, t0 = len(probe.joint_states), time.monotonic()
            probe.hold(0.3, 0.0, seconds)
            rate = (len(probe.joint_states) - n0) / (time.monotonic() - t0)
            values = probe.status('link')[2]
        finally:
            executor.shutdown(timeout_sec=2.0)
            bridge.destroy_node()
            probe.destroy_node()
            spinner.join(2.0)
            rclpy.shutdown(context=context)
    return rate, int(values['crc_errors']), int(values['framing_errors'])


def main():
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument('--seconds', type=float, default=5.0,
                        help='counting window per noise rate [s] (default: %(default)s)')
    parser.add_argument('--noise-hz', type=float, nargs='+', default=[0.0, 40.0],
                        help='line-noise bursts per second (default: %(default)s)')
    args = parser.parse_args()
    domain = random.SystemRandom().randint(101, 200)
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    print(f'hardware_bridge joint-state stream at 1 Mbaud, 200 Hz reports, {args.seconds:g} s '
          f'per row; load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} CPUs')
    print(f'{"noise Hz":>9} {"js per s":>9} {"crc err":>8} {"framing err":>12}')
    for noise_hz in args.noise_hz:
        rate, crc, framing = measure(noise_hz, args.seconds, domain)
        print(f'{noise_hz:>9.1f} {rate:>9.1f} {crc:>8} {framing:>12}', flush=True)


if __name__ == '__main__':
    main()

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

"""The hardware_bridge console script with config/hardware_bridge.yaml, stopped by SIGINT."""
from pathlib import Path
import signal
import subprocess
import threading
import time

from hardware_support import console_command, emulator_thread, Probe, stop_process, wait_for
import pytest
from rclpy.executors import SingleThreadedExecutor
from sma_actuator.hardware import protocol as p
from sma_actuator.hardware.bridge_core import to_counts

CONFIG = Path(__file__).resolve().parents[1] / 'config' / 'hardware_bridge.yaml'


def test_console_script_runs_from_params_file_and_zeroes_duty_on_sigint(
        ros_context, ros_domain_id):
    with emulator_thread(baud=115200) as (emulator, port):
        proc = subprocess.Popen(
            console_command('hardware_bridge', 'sma_actuator.nodes.hardware_bridge')
            + ['--ros-args', '--params-file', str(CONFIG), '-p', f'port:={port}',
               '-p', 'diagnostics_rate_hz:=5.0'],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        probe = Probe(context=ros_context)
        executor = SingleThreadedExecutor(context=ros_context)
        executor.add_node(probe)
        thread = threading.Thread(target=executor.spin, daemon=True)
        thread.start()
        try:
            assert wait_for(lambda: emulator.mcu.configured, 20.0), 'bridge never sent Hello'
            assert wait_for(lambda: probe.duty_pub.get_subscription_count() > 0, 10.0)
            probe.hold(0.5, 0.0, 0.5)
            assert emulator.mcu.pwm_a == to_counts(0.5)
            assert len(probe.joint_states) > 20 and len(probe.raw) > 20
            assert wait_for(lambda: probe.status('link') is not None, 2.0)
            assert probe.status('link')[2]['port'] == port
            # Keep commanding while the node shuts down, and watch the MCU outputs: they must
            # go to zero by the bridge's final Duty(0, 0) frame.
            done = threading.Event()
            samples = []

            def feed_and_watch():
                while not done.is_set():
                    probe.duty(0.5, 0.0)
                    for _ in range(20):
                        samples.append((emulator.mcu.pwm_a, emulator.mcu.faults))
                        time.sleep(0.001)
            watcher = threading.Thread(target=feed_and_watch)
            watcher.start()
            code = stop_process(proc, sig=signal.SIGINT)
            time.sleep(0.05)
            done.set()
            watcher.join()
            assert code == 0
            first_off = next(i for i, (pwm, _) in enumerate(samples) if pwm == 0)
            assert all(pwm == 0 for pwm, _ in samples[first_off:])
            # pwm 0 without the watchdog fault: a Duty(0, 0) frame arrived (a duty frame
            # clears the fault; the watchdog alone would leave it set)
            assert any(not faults & p.FAULT_WATCHDOG for _, faults in samples[first_off:])
        finally:
            executor.shutdown(timeout_sec=2.0)
            probe.destroy_node()
            thread.join(2.0)
            stop_process(proc, sig=signal.SIGKILL)


@pytest.mark.parametrize('override, named', [
    ('max_duty:=1.5', 'max_duty'), ('adc_scale_rad_per_count:=0.0', 'scale_rad_per_count')])
def test_bad_parameter_stops_with_a_message_naming_it(ros_domain_id, override, named):
    result = subprocess.run(
        console_command('hardware_bridge', 'sma_actuator.nodes.hardware_bridge')
        + ['--ros-args', '-p', 'port:=loop://', '-p', override],
        capture_output=True, text=True, timeout=60)
    assert result.returncode == 1
    assert named in result.stderr and 'not started' in result.stderr
    assert 'Traceback' not in result.stderr

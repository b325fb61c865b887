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

"""Helpers for the bridge/emulator tests: emulator processes and threads, a probe node."""
import contextlib
from pathlib import Path
import select
import shutil
import signal
import subprocess
import sys
import threading
import time

from conftest import NOTICE_S
from diagnostic_msgs.msg import DiagnosticArray
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from sma_actuator.hardware.emulator import Emulator, PtyTransport, TcpTransport
from sma_actuator.nodes import common as c
from sma_actuator.nodes.hardware_bridge import POTENTIOMETER_RAW
from std_msgs.msg import Float64MultiArray, UInt16


def wait_for(condition, timeout_s=NOTICE_S, period_s=0.005):
    """Poll `condition` until true (returns True) or timeout (returns False)."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(period_s)
    return bool(condition())


def console_command(name, module):
    """Return the installed console script `name`, else `python -m module`."""
    script = Path(sys.prefix) / 'lib' / 'sma_actuator' / name
    if script.exists():
        return [str(script)]
    found = shutil.which(name)
    return [found] if found else [sys.executable, '-m', module]


def start_emulator_process(*args, timeout_s=15.0):
    """Start `mcu_emulator args...`; returns (process, port) once it printed its PORT line."""
    command = console_command('mcu_emulator', 'sma_actuator.hardware.emulator') + list(args)
    proc = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    ready, _, _ = select.select([proc.stdout], [], [], timeout_s)
    line = proc.stdout.readline() if ready else ''
    if not line.startswith('PORT '):
        stop_process(proc)
        raise RuntimeError(f'mcu_emulator did not start: {line!r} {proc.stderr.read()}')
    return proc, line.split(None, 1)[1].strip()


def stop_process(proc, sig=signal.SIGTERM, timeout_s=10.0):
    """Signal a subprocess and wait for it (kill if it hangs); returns its exit code."""
    if proc.poll() is None:
        proc.send_signal(sig)
        try:
            proc.wait(timeout_s)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
    for stream in (proc.stdout, proc.stderr):
        if stream:
            stream.close()
    return proc.returncode


@contextlib.contextmanager
def emulator_thread(tcp=False, **kwargs):
    """Return an in-process Emulator serving a pty (or TCP); yields (emulator, port)."""
    emulator = Emulator(**kwargs)
    transport = TcpTransport() if tcp else PtyTransport()
    stop = threading.Event()
    thread = threading.Thread(target=emulator.run, args=(transport, stop), daemon=True)
    thread.start()
    try:
        yield emulator, transport.port
    finally:
        stop.set()
        thread.join(5.0)
        transport.close()


class Probe(Node):
    """
    Publishes /sma/duty; records what the bridge publishes, with arrival times.

    Joint states, raw counts, applied duties (as (duty_a, duty_b) tuples) and diagnostics.
    """

    def __init__(self, duty=True, **kwargs):
        super().__init__('bridge_probe', **c.node_options(kwargs))
        self.joint_states, self.raw, self.diagnostics, self.applied = [], [], [], []
        # duty=False beside a controller: a second duty publisher makes the bridge send zero
        self.duty_pub = (self.create_publisher(Float64MultiArray, c.DUTY, c.COMMAND_QOS)
                         if duty else None)

        def keep(into, value=lambda m: m):
            return lambda m: into.append((time.monotonic(), value(m)))
        self.create_subscription(JointState, c.JOINT_STATES, keep(self.joint_states),
                                 c.SENSOR_QOS)
        self.create_subscription(UInt16, POTENTIOMETER_RAW, keep(self.raw, lambda m: m.data),
                                 c.SENSOR_QOS)
        self.create_subscription(DiagnosticArray, c.DIAGNOSTICS, keep(self.diagnostics),
                                 c.DIAGNOSTICS_QOS)
        # deep: a starved executor must not drop a change it has not taken yet
        self.create_subscription(Float64MultiArray, c.APPLIED_DUTY,
                                 keep(self.applied, lambda m: tuple(m.data)),
                                 QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE))

    def duty(self, a, b):
        self.duty_pub.publish(Float64MultiArray(data=[float(a), float(b)]))
        self.last_duty_s = time.monotonic()

    def hold(self, a, b, seconds, rate_hz=40.0, until=None):
        """
        Publish the duty pair at rate_hz for `seconds` (like a controller would).

        With `until`, keep publishing past `seconds` until `until()` holds (at most NOTICE_S
        more): on a loaded machine the effect of the duty may take longer to show.
        """
        end = time.monotonic() + seconds
        give_up = end + NOTICE_S
        while time.monotonic() < end or (until is not None and not until()
                                         and time.monotonic() < give_up):
            self.duty(a, b)
            time.sleep(1.0 / rate_hz)

    def status(self, name, since=0.0):
        """
        Latest DiagnosticStatus `hardware_bridge.

        <name>` received after `since`, as (level, message, values dict), or None.
        """
        for t, msg in reversed(self.diagnostics):
            if t < since:
                break
            for st in msg.status:
                if st.name == f'hardware_bridge: {name}':
                    return st.level[0] if isinstance(st.level, bytes) else st.level, st.message, \
                        {kv.key: kv.value for kv in st.values}
        return None

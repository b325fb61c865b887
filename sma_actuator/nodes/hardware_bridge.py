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
hardware_bridge: /sma/duty -> serial PWM/ADC microcontroller -> /sma/joint_states.

Drives the real rig (or the `mcu_emulator`) over the protocol of docs/protocol.md. The
logic is in `hardware.bridge_core` (safety, handshake, calibration) and
`hardware.link` (pyserial port thread with reconnect/backoff); this node wires them to
topics:

- subscribes /sma/duty (std_msgs/Float64MultiArray [duty_a, duty_b]) and sends each
  command at once, refreshed every 1/duty_refresh_hz to feed the 100 ms MCU watchdog;
- publishes every ADC report as /sma/joint_states (joint `shaft`, calibrated position,
  filtered velocity, stamp = node clock at reception) and the raw counts as
  /sma/potentiometer_raw (std_msgs/UInt16);
- publishes /sma/applied_duty (std_msgs/Float64MultiArray [duty_a, duty_b]): the duty the
  bridge sent to the MCU, after the interlock, the max_duty clamp and the watchdog, zero
  while no MCU is connected; at each change and at least every APPLIED_REPEAT_S, so a bag
  holds what the wires got beside the commands on /sma/duty (docs/recording.md);
- publishes /diagnostics: `hardware_bridge: link` (state, frame/CRC errors, lost
  frames, round-trip times), `hardware_bridge: mcu` (faults, firmware, MCU-side
  receive errors) and `hardware_bridge: duty` (host watchdog, rejected/clamped commands).

On shutdown a zero-duty frame is sent before the port closes.

Stale commands (docs/safety.md): the duty subscription has a QoS lifespan of
duty_timeout_s, so the middleware drops samples that expired while this process could
not take them, and each command's age (now minus its source timestamp) is checked again
in the callback, because a sample taken after a freeze can be older than it was when the
middleware queued it. The host watchdog runs again on the clock of every write, so a
freeze between checking a command and writing its frame sends zero duty on waking. More
than one publisher on the duty topic means zero duty + ERROR.
"""
import math
import sys
import threading
import time
from typing import Any, Dict, Optional, Sequence

import rclpy
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, UInt16

from . import common as c
from .ros_console import (
    create_node,
    fail,
    handle_command_line,
    init_with_stop_signals,
    spin_until_stopped,
)
from .ros_diagnostics import Diagnostics, LEVELS
from .ros_params import declare_parameters, Param
from ..control.interlock import DEFAULT_DEAD_TIME_S
from ..core.sensor import POT_RANGE_RAD, Potentiometer
from ..hardware.bridge_core import BridgeConfig, BridgeCore
from ..hardware.calibration import AdcCalibration
from ..hardware.link import SerialLink

POTENTIOMETER_RAW = 'potentiometer_raw'
TICK_PERIOD_S = 0.005   # resolution of the host watchdog, duty refresh and heartbeat timers
PUBLISHER_CHECK_PERIOD_S = 0.05   # how often the duty topic's publishers are counted
# an unchanged applied duty is published again this often, for a recorder that joins late
APPLIED_REPEAT_S = 0.1


# every parameter is read-only: they take effect at start
PARAMETERS = (
    Param('port', '/dev/ttyACM0', 'Serial device or pyserial URL (socket://host:port, '
          'loop://).', read_only=True),
    Param('baud', 115200, 'Serial baud rate [bit/s].', (1200, 4_000_000), read_only=True),
    Param('adc_offset_rad', POT_RANGE_RAD[0], 'Shaft angle at 0 ADC counts [rad].',
          (-10.0, 10.0), read_only=True),
    Param('adc_scale_rad_per_count', Potentiometer().resolution_rad,
          'Shaft angle per ADC count [rad].', (-1.0, 1.0), read_only=True),
    Param('adc_polynomial', [0.0], 'With 2 or more coefficients: angle [rad] = '
          'polyval(coefficients, counts), highest power first, replacing offset and scale. '
          '[0.0] = not used (YAML has no typed empty list).', read_only=True),
    Param('publish_rate_hz', 200.0, 'ADC report (and joint state) rate requested from the '
          'MCU; each duty frame also gets an immediate report [Hz].', (1.0, 1000.0),
          read_only=True),
    Param('duty_refresh_hz', 50.0, 'Re-send the current duty at this rate (> 10 Hz keeps '
          'the 100 ms MCU watchdog fed) [Hz].', (11.0, 1000.0), read_only=True),
    Param('max_duty', 1.0, 'Per-wire duty limit.', (0.0, 1.0), read_only=True),
    Param('interlock_threshold', 0.3, 'The two duties are never both above this (the '
          'firmware caps it at 0.5).', (0.0, 0.5), read_only=True),
    Param('duty_timeout_s', 0.2, 'Host watchdog: no /sma/duty this long -> zero duty + '
          'WARN [s].', (0.01, 10.0), read_only=True),
    Param('interlock_dead_time_s', DEFAULT_DEAD_TIME_S, 'A wire heats only after the other '
          'has had zero duty this long; not below the firmware dead time 0.025 s [s].',
          (0.025, 10.0), read_only=True),
    Param('link_timeout_s', 0.5, 'No valid frame from the MCU this long -> link lost, zero '
          'duty, re-handshake [s].', (0.05, 10.0), read_only=True),
    Param('heartbeat_hz', 5.0, 'Round-trip probe rate [Hz].', (0.1, 100.0), read_only=True),
    Param('reconnect_backoff_min_s', 0.1, 'First reopen delay [s]; doubles per failure.',
          (0.01, 10.0), read_only=True),
    Param('reconnect_backoff_max_s', 5.0, 'Longest reopen delay [s].', (0.1, 60.0),
          read_only=True),
    Param('velocity_filter_tau_s', 0.02, 'Low-pass time constant of the velocity estimate '
          '[s].', (0.0, 1.0), read_only=True),
    Param('diagnostics_rate_hz', 1.0, 'Diagnostics rate [Hz].', (0.1, 50.0), read_only=True),
)


class HardwareBridge(Node):
    """
    Bridge node (see module docstring).

    :param kwargs: rclpy ``Node`` keyword arguments (context, parameter_overrides,
        namespace: default ``sma``, ...); the parameters are those of ``PARAMETERS``.
    :raises ParameterError: A parameter value the node cannot run with.
    """

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('hardware_bridge', **c.node_options(kwargs))
        f = declare_parameters(self, PARAMETERS)
        self.port, baud, poly = f['port'], f['baud'], f['adc_polynomial']
        calibration = AdcCalibration(f['adc_offset_rad'], f['adc_scale_rad_per_count'],
                                     poly if len(poly) >= 2 else ())
        config = BridgeConfig(
            max_duty=f['max_duty'], interlock_threshold=f['interlock_threshold'],
            duty_timeout_s=f['duty_timeout_s'], duty_refresh_s=1.0 / f['duty_refresh_hz'],
            link_timeout_s=f['link_timeout_s'], heartbeat_period_s=1.0 / f['heartbeat_hz'],
            adc_period_s=1.0 / f['publish_rate_hz'],
            interlock_dead_time_s=f['interlock_dead_time_s'])

        self._lock = threading.Lock()   # BridgeCore is shared by the executor and the link thread
        self._stopping = False
        self.core = BridgeCore(config, calibration, time.monotonic(),
                               f['velocity_filter_tau_s'], self._log)
        self.js_pub = self.create_publisher(JointState, c.JOINT_STATES, c.SENSOR_QOS)
        self.raw_pub = self.create_publisher(UInt16, POTENTIOMETER_RAW, c.SENSOR_QOS)
        # reliable, as the commands: a lost change would misstate the heating until the next
        self.applied_pub = self.create_publisher(Float64MultiArray, c.APPLIED_DUTY,
                                                 c.COMMAND_QOS)
        self._applied, self._applied_at_s = None, -math.inf
        # the serial port names the hardware: one rig, whichever node drives it
        self.diag = Diagnostics(self, hardware_id=self.port)
        self.duty_sub = self.create_subscription(
            Float64MultiArray, c.DUTY, self.on_duty,
            c.expiring_command_qos(config.duty_timeout_s))
        self.create_timer(TICK_PERIOD_S, self.on_tick)
        self.create_timer(PUBLISHER_CHECK_PERIOD_S, self.check_duty_publishers)
        self.create_timer(1.0 / f['diagnostics_rate_hz'], self.publish_diagnostics)
        self.link = SerialLink(self.port, baud, self._on_open, self._on_data, self._on_close,
                               self._on_open_failed, f['reconnect_backoff_min_s'],
                               f['reconnect_backoff_max_s'])
        self.link.start()
        self.get_logger().info(f'hardware_bridge on {self.port} at {baud} baud')

    # --- callbacks (executor thread) ----------------------------------------------------

    def on_duty(self, msg: Float64MultiArray, info: Dict[str, int]) -> None:
        """Check a duty command (value, age) and send it to the MCU at once."""
        sent_ns = info.get('source_timestamp', 0) if isinstance(info, dict) else 0
        with self._lock:
            # the age is taken once the lock is held: a wait for the lock (or a freeze during
            # it) must not pass an old command as fresh; both clocks are read together, so a
            # freeze after this point leaves the receive time old and `_write` trips the
            # watchdog instead of sending the command
            # source timestamps are the sender's system clock (same host, or synchronised)
            now_s = time.monotonic()
            age_s = (time.time_ns() - sent_ns) * 1e-9 if sent_ns > 0 else 0.0
            self._write(self.core.on_duty_command(msg.data, now_s, age_s))

    def check_duty_publishers(self) -> None:
        """Count the duty publishers: more than one means zero duty + ERROR."""
        count = self.count_publishers(self.duty_sub.topic_name)
        with self._lock:
            self._write(self.core.on_publisher_count(count, time.monotonic()))

    def on_tick(self) -> None:
        """Run the host watchdog, duty refresh and heartbeat."""
        with self._lock:
            self._write(self.core.tick(time.monotonic()))

    def publish_diagnostics(self) -> None:
        """Publish the link, mcu and duty statuses in one DiagnosticArray."""
        with self._lock:
            statuses = self.core.diagnostics()
        out = []
        for name, level, text, values in statuses:
            if name == 'link':
                values = dict(values, port=self.port, opens=self.link.opens,
                              reconnect_backoff_s=self.link.backoff_s)
            out.append(self.diag.status(LEVELS[level], text, values, part=name))
        self.diag.publish_statuses(out)

    # --- callbacks (link thread) --------------------------------------------------------

    def _on_open(self) -> bytes:
        with self._lock:
            return self.core.on_open(time.monotonic())

    def _on_data(self, data: bytes, t_s: float) -> None:
        with self._lock:
            tx, samples = self.core.on_data(data, t_s)
            self._write(tx)
        if self._stopping or not self.context.ok():
            return   # shutting down: publishers may already be invalid
        for sample in samples:
            stamp = self.get_clock().now().to_msg()
            js = JointState(name=[c.JOINT_NAME], position=[sample.angle_rad],
                            velocity=[sample.velocity_rad_s])
            js.header.stamp = stamp
            self.js_pub.publish(js)
            self.raw_pub.publish(UInt16(data=sample.counts))

    def _on_close(self, reason: str) -> None:
        with self._lock:
            self.core.on_close(reason, time.monotonic(), failure=not self._stopping)

    def _on_open_failed(self, reason: str) -> None:
        with self._lock:
            self.core.on_open_failed(reason, time.monotonic())

    # --- helpers ------------------------------------------------------------------------

    def _write(self, data: bytes) -> None:
        # under self._lock: frames leave in seq order; the host watchdog runs again on the
        # clock of the write, so a freeze since `data` was made sends zero duty instead
        data = self.core.watchdog(time.monotonic()) or data
        if data:
            self.link.write(data)
        self._publish_applied(time.monotonic())

    def _publish_applied(self, now_s: float) -> None:
        # under self._lock, after the frame is written: the messages leave in the order the
        # duties were sent, each about when the MCU applies it
        duty = self.core.applied_duty()
        if duty == self._applied and now_s - self._applied_at_s < APPLIED_REPEAT_S:
            return
        if self._stopping or not self.context.ok():
            return   # shutting down: publishers may already be invalid
        self._applied, self._applied_at_s = duty, now_s
        self.applied_pub.publish(Float64MultiArray(data=list(duty)))

    def _log(self, level: str, text: str) -> None:
        # one call site per severity: rclpy refuses a severity change at the same call site
        logger = self.get_logger()
        if level == 'error':
            logger.error(text)
        elif level == 'warn':
            logger.warning(text)
        else:
            logger.info(text)

    def destroy_node(self) -> None:
        """Send zero duty, close the port, then destroy the node."""
        with self._lock:
            self._stopping = True
            final = self.core.shutdown()
        self.link.stop(final)
        if self._applied not in (None, (0.0, 0.0)) and self.context.ok():
            # the zero frame is out: a recorder still running logs it
            self.applied_pub.publish(Float64MultiArray(data=[0.0, 0.0]))
        super().destroy_node()


def main(args: Optional[Sequence[str]] = None) -> int:
    """Run the bridge until SIGINT/SIGTERM; exit status 2 on bad parameters."""
    handle_command_line('hardware_bridge', __doc__, PARAMETERS, args)
    stop = init_with_stop_signals(args, 'hardware_bridge')
    node = None
    try:
        node = create_node('hardware_bridge', HardwareBridge, args)
        spin_until_stopped(node, stop)
    except ValueError as exc:
        # a configuration mistake the parameter table cannot see (e.g. a bad calibration)
        fail('hardware_bridge', f'not started: {exc}')
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())

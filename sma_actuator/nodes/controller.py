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
controller: discrete PI (25 ms) with anti-windup, modes pi / pi_inverse / on_off.

The control law (`control.law.ControllerCore`) runs when a fresh /sma/joint_states
sample arrives, at most once per `period_s` (0.025 s, the paper's sampling time; the
plant publishes at 40 Hz), and publishes /sma/duty at once, so the output lags the
feedback by the computation only. The `period_s` timer on the node clock (sim time
with use_sim_time) is the watchdog: no valid joint state for `feedback_timeout_s` ->
zero duty on every tick + diagnostics ERROR until feedback returns.

Setpoints that are NaN/inf/outside [setpoint_min_rad, setpoint_max_rad] are rejected
(log + diagnostics WARN, each at most once per second) and the last valid setpoint is kept.
The setpoint subscription keeps only the newest sample (depth 1) and its callback only
stores it, so a setpoint flood of any rate costs the executor one cheap callback per
turn and the control step keeps its cadence (docs/safety.md). Mode, gains and limits are
parameters that can be changed at runtime (validated; an invalid set is refused).
"""
from collections import deque
from dataclasses import fields
import time
from typing import Any, Dict, List, Optional, Sequence
import warnings

import numpy as np
from rcl_interfaces.msg import SetParametersResult
import rclpy
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState, Temperature
from std_msgs.msg import Float64, Float64MultiArray

from . import common as c
from .ros_console import (
    create_node,
    handle_command_line,
    init_with_stop_signals,
    spin_until_stopped,
)
from .ros_diagnostics import Diagnostics, ERROR, OK, WARN
from .ros_params import declare_parameters, Param, ParameterError
from ..control.inputs import LastValid, setpoint_problem
from ..control.law import ControllerCore, ControllerSettings, MODES
from ..core.actuator import AMBIENT_RANGE_C
from ..core.model_file import load_model, ModelFormatWarning
from ..core.sensor import ANGLE_LIMIT_RAD

SETPOINT_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE)

_D = ControllerSettings()
# runtime-tunable settings of ControllerSettings: (name, lo, hi, description)
TUNABLE = (
    ('kp', -1.0, 100.0, 'Proportional gain [duty/rad]; negative: SIMC from the model.'),
    ('ki', -1.0, 100.0, 'Integral gain [duty/(rad s)]; negative: SIMC from the model.'),
    ('duty_max', 0.0, 1.0, 'Per-wire duty limit.'),
    ('both_threshold', 0.0, 1.0, 'The two duties are never both above this.'),
    ('max_temp_c', 30.0, 200.0, 'Thermal guard: estimated wire temperature limit [°C].'),
    ('guard_horizon_s', 0.05, 10.0, 'Thermal guard look-ahead [s].'),
    ('on_off_band_rad', 0.0, 1.0, 'on_off: relay half-band on the setpoint [rad].'),
    ('on_off_duty', 0.0, 1.0, 'on_off: duty of the heated wire.'),
    ('ff_horizon_s', 0.0, 10.0, 'pi_inverse: thermal inverse horizon [s]; 0 = static map.'),
    ('drift_time_s', 1.0, 3600.0, 'pi_inverse: memory of the drift estimator [s].'),
    ('dead_time_s', 0.0, 1.0, 'Interlock dead time between the wires [s], every mode (as '
     'interlock_dead_time_s of plant_sim and the bridge).'),
)
# runtime-switchable settings: (name, description)
SWITCHES = (
    ('smith', 'pi_inverse: predict the measurement over the model delay (Smith).'),
    ('drift_correction', 'pi_inverse: correct offset and stroke from the measurements.'),
    ('preheat', 'pi_inverse: early handover to the incoming wire at a zero crossing.'),
)
PARAMETERS = (
    Param('mode', _D.mode, 'Control mode (changeable at runtime).', choices=MODES),
    *(Param(name, -1.0 if getattr(_D, name) is None else getattr(_D, name), desc, (lo, hi))
      for name, lo, hi, desc in TUNABLE),
    *(Param(name, getattr(_D, name), desc) for name, desc in SWITCHES),
    Param('period_s', 0.025, 'Control period and watchdog timer [s].', (0.001, 1.0),
          read_only=True),
    Param('feedback_timeout_s', 0.2, 'No joint state for this long -> zero duty + ERROR '
          '[s].', (0.01, 10.0)),
    Param('setpoint_min_rad', -1.0, 'Lowest accepted setpoint [rad].',
          (-ANGLE_LIMIT_RAD, ANGLE_LIMIT_RAD), read_only=True),
    Param('setpoint_max_rad', 1.0, 'Highest accepted setpoint [rad].',
          (-ANGLE_LIMIT_RAD, ANGLE_LIMIT_RAD), read_only=True),
    Param('initial_setpoint_rad', 0.0, 'Setpoint until one arrives [rad].',
          (-ANGLE_LIMIT_RAD, ANGLE_LIMIT_RAD), read_only=True),
    Param('model_file', '', 'Model file (sma-model fit --out); empty: '
          'config/controller_model.yaml.', read_only=True),
    Param('use_ambient_topic', False, 'Feed /sma/ambient_temperature to the model.',
          read_only=True),
)


class Controller(Node):
    """
    Controller node (see module docstring).

    :param kwargs: rclpy ``Node`` keyword arguments (context, parameter_overrides,
        namespace: default ``sma``, ...); the parameters are those of ``PARAMETERS``.
    :raises ParameterError: A parameter value the node cannot run with.
    """

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('controller', **c.node_options(kwargs))
        p = declare_parameters(self, PARAMETERS)
        mode, model_file = p['mode'], p['model_file']
        values = {name: p[name] for name, *_ in TUNABLE}
        values.update({name: p[name] for name, _ in SWITCHES})
        self.period_s, self.feedback_timeout_s = p['period_s'], p['feedback_timeout_s']
        self.sp_min, self.sp_max = p['setpoint_min_rad'], p['setpoint_max_rad']
        initial = p['initial_setpoint_rad']
        self.use_ambient_topic = p['use_ambient_topic']
        self.model_path = model_file or str(c.config_path('controller_model.yaml'))
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter('always', ModelFormatWarning)
                model = load_model(self.model_path)
        except (OSError, ValueError) as err:
            raise ParameterError(f'parameter model_file: cannot load {self.model_path}: '
                                 f'{err}') from err
        for w in caught:
            self.get_logger().warn(str(w.message))
        self.core = ControllerCore(model, ControllerSettings(mode=mode, **values))
        # run every compiled kernel once now, so the first real sample is not late
        ControllerCore(model, ControllerSettings(mode='pi_inverse')).step(0.1, 0.0, self.period_s)
        self.setpoint = LastValid(lambda v: setpoint_problem(v, self.sp_min, self.sp_max), initial)
        if setpoint_problem(initial, self.sp_min, self.sp_max):
            raise ParameterError('parameter initial_setpoint_rad: outside [setpoint_min_rad, '
                                 'setpoint_max_rad]')
        self.ambient_c = None
        self.last_feedback = None     # node-clock time [s] of the last valid joint state
        self.last_sample = None       # header stamp [s] of the last sample used for control
        self.last_step = None
        self.stale = False
        self.last_check = None        # node time [s] of the previous watchdog check
        self.zeroed = None            # node times [s] (zero duty, check before) of a timeout
        self.rejected_feedback = 0
        self._last_reject_diag = 0.0
        self._last_setpoint_diag = -1.0
        # timing health, reported in diagnostics (and read by bench_controller_latency):
        # joint-state arrival (rmw reception time) -> duty published, and watchdog intervals
        self.latencies = deque(maxlen=2000)
        self.tick_intervals = deque(maxlen=2000)
        self._last_tick_wall = None

        self.duty_pub = self.create_publisher(Float64MultiArray, c.DUTY, c.COMMAND_QOS)
        self.diag = Diagnostics(self, 'controller')
        # newest setpoint wins: a flood is dropped in the middleware, not queued for Python
        self.create_subscription(Float64, c.SETPOINT, self.on_setpoint, SETPOINT_QOS)
        self.create_subscription(JointState, c.JOINT_STATES, self.on_joint_state, c.SENSOR_QOS)
        if self.use_ambient_topic:
            self.create_subscription(Temperature, c.AMBIENT_TEMPERATURE, self.on_ambient,
                                     c.SENSOR_QOS)
        self.add_on_set_parameters_callback(self.on_set_parameters)
        self.create_timer(self.period_s, self.on_watchdog)
        self.create_timer(1.0, self.publish_status)
        kp, ki = self.core.gains()
        self.get_logger().info(f'controller mode {mode}, model {self.model_path}, '
                               f'kp {kp:.3g} duty/rad, ki {ki:.3g} duty/(rad s)')

    def now_s(self) -> float:
        """Return the node clock (sim time with use_sim_time) [s]."""
        return self.get_clock().now().nanoseconds * 1e-9

    # inputs ---------------------------------------------------------------------------
    def on_setpoint(self, msg: Float64) -> None:
        """Keep a valid setpoint; reject (log, WARN) any other."""
        problem = self.setpoint.offer(msg.data)
        if problem:
            self.get_logger().warn(f'rejected setpoint: {problem}; keeping '
                                   f'{self.setpoint.value:.4g} rad (throttled: '
                                   f'{self.setpoint.rejected} rejected so far)',
                                   throttle_duration_sec=1.0)
            now = time.monotonic()
            if now - self._last_setpoint_diag >= 1.0:
                self._last_setpoint_diag = now
                self.diag.publish(WARN, f'rejected setpoint: {problem}', self._status())

    def on_ambient(self, msg: Temperature) -> None:
        """Take the ambient temperature for the thermal model when it is plausible."""
        if AMBIENT_RANGE_C[0] <= msg.temperature <= AMBIENT_RANGE_C[1]:  # NaN fails both
            self.ambient_c = msg.temperature

    def on_joint_state(self, msg: JointState, info: Dict[str, int]) -> None:
        """Run one control step on a fresh, valid joint state and publish the duty."""
        received_ns = info.get('received_timestamp', 0) if isinstance(info, dict) else 0
        arrival_ns = received_ns if received_ns > 0 else time.time_ns()
        try:
            position = msg.position[list(msg.name).index(c.JOINT_NAME)]
        except (ValueError, IndexError):
            position = float('nan')
        if not -ANGLE_LIMIT_RAD <= position <= ANGLE_LIMIT_RAD:   # also rejects NaN/inf
            self.rejected_feedback += 1
            self.get_logger().warn(f'rejected joint state (shaft position {position})',
                                   throttle_duration_sec=1.0)
            if self.rejected_feedback == 1 or time.monotonic() - self._last_reject_diag > 1.0:
                self._last_reject_diag = time.monotonic()
                self.diag.publish(WARN, f'rejected joint state (position {position})',
                                  self._status())
            return
        self.last_feedback = self.now_s()
        stamp = c.stamp_to_s(msg.header.stamp)
        if self.last_sample is not None and stamp < self.last_sample:
            self.last_sample = None               # the feedback's clock restarted
        if self.last_sample is not None and stamp - self.last_sample < 0.75 * self.period_s:
            return                                # faster feedback than the control period
        dt = self.period_s if self.last_sample is None else stamp - self.last_sample
        self.last_sample = stamp
        dt = min(max(dt, 0.25 * self.period_s), self.feedback_timeout_s)
        if self.stale:
            self.stale = False
            self.get_logger().info('feedback back: control resumed')
        out = self.core.step(self.setpoint.value, position, dt, self.ambient_c)
        self.last_step = out
        self.duty_pub.publish(Float64MultiArray(data=[out.duty_a, out.duty_b]))
        self.latencies.append((time.time_ns() - arrival_ns) * 1e-9)

    # watchdog -------------------------------------------------------------------------
    def on_watchdog(self) -> None:
        """Zero the duty while no valid joint state arrived for feedback_timeout_s."""
        wall = time.perf_counter()
        if self._last_tick_wall is not None:
            self.tick_intervals.append(wall - self._last_tick_wall)
        self._last_tick_wall = wall
        now = self.now_s()
        previous_check, self.last_check = self.last_check, now
        if self.last_feedback is not None and now - self.last_feedback <= self.feedback_timeout_s:
            return
        first = not self.stale
        if first:
            self.zeroed = (now, previous_check)
        self.stale = True
        self.last_sample = None
        self.last_step = self.core.idle(self.period_s, self.ambient_c)
        self.duty_pub.publish(Float64MultiArray(data=[0.0, 0.0]))
        if first:
            self._report_stale()

    def _report_stale(self) -> None:
        if self.last_feedback is None:
            self.diag.publish(WARN, 'waiting for joint states: zero duty', self._status())
        else:
            self.get_logger().error(f'no joint state for > {self.feedback_timeout_s:g} s: '
                                    'zero duty')
            self.diag.publish(ERROR, 'stale feedback: zero duty', self._status())

    def publish_status(self) -> None:
        """Publish the 1 Hz diagnostics status."""
        if self.stale:
            self._report_stale()
        else:
            self.diag.publish(OK, f'mode {self.core.settings.mode}', self._status())

    def _status(self) -> Dict[str, Any]:
        s = self.last_step
        out = {'mode': self.core.settings.mode, 'setpoint_rad': float(self.setpoint.value),
               'rejected_setpoints': self.setpoint.rejected,
               'rejected_joint_states': self.rejected_feedback}
        out.update(self.timing_stats())
        if self.stale and self.last_feedback is not None and None not in self.zeroed:
            # the timeout as the controller saw it, on its own clock (full precision)
            out.update(last_joint_state_s=f'{self.last_feedback:.6f}',
                       zero_duty_since_s=f'{self.zeroed[0]:.6f}',
                       previous_check_s=f'{self.zeroed[1]:.6f}')
        if s is not None:
            out.update(duty_a=s.duty_a, duty_b=s.duty_b, error_rad=s.error,
                       theta_est_a_c=float(s.theta_est_c[0]),
                       theta_est_b_c=float(s.theta_est_c[1]),
                       limit_a=float(s.limits[0]), limit_b=float(s.limits[1]),
                       guard_active=s.guard_active)
        return out

    def timing_stats(self) -> Dict[str, float]:
        """
        Return latency and timer jitter over the last 2000 samples.

        Latency p50/p99 [ms] (joint-state arrival -> duty published) and watchdog-timer
        jitter p99 [ms] (|interval − period_s|).
        """
        out = {}
        if self.latencies:
            lat = np.asarray(self.latencies) * 1e3
            out.update(latency_p50_ms=float(np.percentile(lat, 50)),
                       latency_p99_ms=float(np.percentile(lat, 99)))
        if self.tick_intervals:
            jit = np.abs(np.asarray(self.tick_intervals) - self.period_s) * 1e3
            out.update(timer_jitter_p99_ms=float(np.percentile(jit, 99)))
        return out

    # parameters -----------------------------------------------------------------------
    def on_set_parameters(self, params: List[Parameter]) -> SetParametersResult:
        """Apply runtime changes of the tunable settings; refuse an invalid set."""
        names = {f.name for f in fields(ControllerSettings)}
        changes = {p.name: p.value for p in params if p.name in names}
        for p in params:
            if p.name == 'feedback_timeout_s':
                self.feedback_timeout_s = p.value   # range checked by its descriptor
        if not changes:
            return SetParametersResult(successful=True)
        try:
            self.core.configure(**changes)
        except (ValueError, TypeError) as e:
            return SetParametersResult(successful=False, reason=str(e))
        self.get_logger().info(f'settings changed: {changes}')
        return SetParametersResult(successful=True)


def main(args: Optional[Sequence[str]] = None) -> None:
    """Run the controller until SIGINT/SIGTERM, then publish a final zero duty."""
    handle_command_line('controller', __doc__, PARAMETERS, args)
    stop = init_with_stop_signals(args, 'controller')
    node = None
    try:
        node = create_node('controller', Controller, args)
        spin_until_stopped(node, stop)
    finally:
        if node is not None:
            # last word on the duty topic: heat off (the plant's timeout is the backstop)
            if rclpy.ok():
                node.duty_pub.publish(Float64MultiArray(data=[0.0, 0.0]))
                # reliable QoS: wait (bounded) until subscribers have it before the process
                # and its DDS participant go away
                node.duty_pub.wait_for_all_acked(rclpy.duration.Duration(seconds=0.5))
            node.destroy_node()
        rclpy.try_shutdown()


if __name__ == '__main__':
    main()

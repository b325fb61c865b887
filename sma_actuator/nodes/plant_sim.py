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
plant_sim: the antagonistic SMA actuator of the core, driven by /sma/duty.

Topic names are relative to the node's namespace (default /sma; `-r __ns:=/left`).

Publishes /sma/joint_states (joint `shaft`: position = potentiometer + ADC reading,
velocity = finite difference of consecutive *sensed* positions, as a real pot/ADC chain
would give), /sma/wire_a/temperature and /sma/wire_b/temperature (simulated, not sensed) and
/diagnostics. Every physical effect of `ActuatorParams` is a read-only parameter.

Time: normally the node clock (wall, or /clock with use_sim_time). With `accelerated`
the plant owns time: it steps sim time by 1/rate_hz on a wall-clock timer running
`real_time_factor` times faster and publishes /clock; the other nodes use use_sim_time.
With `lockstep` it also waits (up to `lockstep_timeout_s` wall time) for the duty reply
to its last joint state before the next step, so the loop sees the same one-sample
delay on any host instead of whatever the executor's scheduling gives.
`start_subscribers` + `warmup_s` hold sim time at 0 until the other nodes listen, and
`duration_s` ends the run (the node exits) at a fixed sim time: a recording of fixed
sim-time length.

Safety (docs/safety.md): a duty that is NaN/inf/outside [0, 1] is rejected (log + WARN) and
the last valid one kept; if no valid duty arrived for `duty_timeout_s` (plant time) zero duty
is applied, so a dead controller never leaves a wire heated. The applied duty passes the
dead-time interlock (`control.interlock`): a wire heats only after the other has had zero
duty for `interlock_dead_time_s`. More than one publisher on the duty topic (two
controllers) applies zero duty and reports ERROR while it lasts.
"""
import math
import time
from typing import Any, Dict, Optional, Sequence

from builtin_interfaces.msg import Time as TimeMsg
import numpy as np
import rclpy
from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.time import Time
from rosgraph_msgs.msg import Clock as ClockMsg
from sensor_msgs.msg import JointState, Temperature
from std_msgs.msg import Float64MultiArray, Header

from . import common as c
from .ros_console import (
    create_node,
    handle_command_line,
    init_with_stop_signals,
    spin_until_stopped,
)
from .ros_diagnostics import Diagnostics, ERROR, OK, WARN
from .ros_params import declare_parameters, initial_value, Param, ParameterError
from ..control.inputs import duty_problem, LastValid
from ..control.interlock import BOTH_REQUESTED, DeadTimeInterlock, DEFAULT_DEAD_TIME_S
from ..core import actuator as act
from ..core.actuator import ActuatorParams, AMBIENT_RANGE_C, AntagonisticActuator
from ..core.model_file import load_model
from ..core.sensor import POT_RANGE_RAD, Potentiometer

# (parameter, lower, upper, description) of every effect parameter, from its declaration in
# `ActuatorParams`; each range lies within the workbench's fit bounds, so any record the plant
# makes can be diagnosed
EFFECTS = tuple((name, *act.PARAMETERS[name].plant, act.PARAMETERS[name].label)
                for name in act.PLANT_PARAMETERS)
# wall time between two counts of the duty topic's publishers [s]; count_publishers costs
# about 18 µs, which matters at 4000 steps/s in accelerated mode
PUBLISHER_CHECK_PERIOD_S = 0.025


_BASE = ActuatorParams()
PARAMETERS = (
    Param('rate_hz', 40.0, 'Publication and step rate [Hz].', (1.0, 1000.0), read_only=True),
    Param('accelerated', False, 'Own the time: step sim time on a wall timer and publish '
          '/clock (other nodes: use_sim_time).', read_only=True),
    Param('real_time_factor', 10.0, 'Sim seconds per wall second in accelerated mode.',
          (0.1, 1000.0), read_only=True),
    Param('lockstep', False, 'Accelerated mode: advance only after the duty reply to the '
          'last joint state arrived (or lockstep_timeout_s wall seconds passed), so the '
          'loop delay does not depend on the host speed.', read_only=True),
    Param('lockstep_timeout_s', 0.1, 'Longest wall wait for a duty in lockstep [s].',
          (0.001, 10.0), read_only=True),
    Param('start_subscribers', 0, 'Accelerated mode: sim time starts only once '
          '/sma/joint_states has this many subscribers (e.g. 2: controller and recorder).',
          (0, 100), read_only=True),
    Param('warmup_s', 0.0, 'Accelerated mode: wall seconds between start_subscribers being '
          'reached and the first step, so that every node has matched every topic [s].',
          (0.0, 60.0), read_only=True),
    Param('duration_s', 0.0, 'Accelerated mode: stop stepping after this much sim time and '
          'exit; 0 = never [s]. Fixes the length of a recording on sim time.', (0.0, 1e6),
          read_only=True),
    Param('duty_timeout_s', 0.2, 'No valid /sma/duty for this long [plant s] -> zero duty.',
          (0.01, 10.0)),
    Param('interlock_dead_time_s', DEFAULT_DEAD_TIME_S, 'A wire heats only after the other '
          'has had zero applied duty for this long [plant s] (docs/safety.md).', (0.0, 10.0),
          read_only=True),
    Param('model_file', '', 'Optional model file (sma-model fit --out) for the plant; the '
          'effect parameters override it.', read_only=True),
    Param('ambient_c', 22.0, 'Nominal ambient temperature [°C].', AMBIENT_RANGE_C,
          read_only=True),
    Param('use_ambient_topic', False, 'Take the ambient from /sma/ambient_temperature.',
          read_only=True),
    Param('adc_bits', 12, 'ADC resolution [bit].', (4, 24), read_only=True),
    Param('noise_rad', 0.001, 'Potentiometer noise std [rad].', (0.0, 0.1), read_only=True),
    Param('seed', 0, 'Noise seed.', (0, 2 ** 31 - 1), read_only=True),
) + tuple(Param(name, getattr(_BASE, name), f'{desc} (default: model_file, else neutral)',
                (lo, hi), read_only=True) for name, lo, hi, desc in EFFECTS)


class PlantSim(Node):
    """
    Simulated actuator node (see module docstring).

    :param kwargs: rclpy ``Node`` keyword arguments (context, parameter_overrides,
        namespace: default ``sma``, ...); the parameters are those of ``PARAMETERS``.
    :raises ParameterError: A parameter value the node cannot run with.
    """

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('plant_sim', **c.node_options(kwargs))
        base = _base_model(initial_value(self, PARAMETERS, 'model_file'))
        p = declare_parameters(self, PARAMETERS,
                               defaults={name: getattr(base, name) for name, *_ in EFFECTS})
        self.rate_hz, self.accelerated = p['rate_hz'], p['accelerated']
        self.rtf, self.lockstep = p['real_time_factor'], p['lockstep']
        self.lockstep_timeout_s, self.duty_timeout_s = p['lockstep_timeout_s'], p['duty_timeout_s']
        dead_time_s = p['interlock_dead_time_s']
        self.start_subscribers, self.warmup_s = p['start_subscribers'], p['warmup_s']
        self.start_wall = None     # wall time of the first step (accelerated mode)
        self.duration_s, self.finished = p['duration_s'], False
        ambient, self.use_ambient_topic = p['ambient_c'], p['use_ambient_topic']
        bits, noise, seed = p['adc_bits'], p['noise_rad'], p['seed']
        effects = {name: p[name] for name, *_ in EFFECTS}
        self.params = base.with_changes(ambient_c=ambient, **effects)
        self.actuator = AntagonisticActuator(self.params)
        self.pot = Potentiometer(bits, *POT_RANGE_RAD, noise)
        self.rng = np.random.default_rng(seed)

        self.duty = LastValid(duty_problem, initial=(0.0, 0.0))
        self.ambient_c = ambient
        self.applied = (0.0, 0.0)
        self.applied_time_s = None     # plant time [s] at which `applied` was decided
        self.interlock = DeadTimeInterlock(dead_time_s)
        self.duty_publishers = 0       # publishers on the duty topic at the last tick
        self._last_reject_diag = -1.0  # monotonic time of the last rejected-duty WARN
        self._publishers_checked = -1.0   # monotonic time of the last publisher count
        self.last_duty_time = None     # plant time [s] of the last valid duty
        self.last_position = None
        self.sim_time = 0.0
        self.last_tick = None
        self.was_stale = True
        self.last_step_time = None     # plant time [s] of the previous step
        self.zeroed = None             # plant times [s] (zero applied, step before) of a timeout
        self.awaiting_since = None     # wall time of the joint state awaiting a duty (lockstep)

        self.js_pub = self.create_publisher(JointState, c.JOINT_STATES, c.SENSOR_QOS)
        self.temp_pubs = [self.create_publisher(Temperature, topic, c.SENSOR_QOS)
                          for topic in c.WIRE_TEMPERATURES]
        self.diag = Diagnostics(self, 'plant')
        # lifespan in wall seconds (DDS source timestamps): a frozen plant does not replay
        self.duty_sub = self.create_subscription(
            Float64MultiArray, c.DUTY, self.on_duty, c.expiring_command_qos(self.duty_timeout_s))
        if self.use_ambient_topic:
            self.create_subscription(Temperature, c.AMBIENT_TEMPERATURE, self.on_ambient,
                                     c.SENSOR_QOS)
        period = 1.0 / self.rate_hz
        if self.accelerated:
            self.clock_pub = self.create_publisher(ClockMsg, c.CLOCK, c.CLOCK_QOS)
            self.timer = self.create_timer(period / self.rtf, self.on_tick,
                                           clock=Clock(clock_type=ClockType.STEADY_TIME))
        else:
            self.timer = self.create_timer(period, self.on_tick)
        self.steps_per_diag = max(1, int(round(self.rate_hz)))
        self.steps = 0
        timebase = f'accelerated x{self.rtf:g}' if self.accelerated else 'node clock'
        self.get_logger().info(f'plant_sim at {self.rate_hz:g} Hz, {timebase}, '
                               f'duty timeout {self.duty_timeout_s:g} s')

    # time -----------------------------------------------------------------------------
    def now_s(self) -> float:
        """Plant time [s]: own sim time in accelerated mode, else the node clock."""
        if self.accelerated:
            return self.sim_time
        return self.get_clock().now().nanoseconds * 1e-9

    def stamp(self) -> TimeMsg:
        """Return the stamp of plant time now (builtin_interfaces/Time)."""
        if self.accelerated:
            return Time(nanoseconds=int(round(self.sim_time * 1e9))).to_msg()
        return self.get_clock().now().to_msg()

    # inputs ---------------------------------------------------------------------------
    def on_duty(self, msg: Float64MultiArray) -> None:
        """Keep a valid duty pair; reject (log, WARN) any other."""
        self.awaiting_since = None
        problem = self.duty.offer(tuple(msg.data))
        if problem:
            self.get_logger().warn(f'rejected duty: {problem}; keeping {self.duty.value} '
                                   f'({self.duty.rejected} rejected so far)',
                                   throttle_duration_sec=1.0)
            now = time.monotonic()
            if now - self._last_reject_diag >= 1.0:
                self._last_reject_diag = now
                self.diag.publish(WARN, f'rejected duty: {problem}', self._status(),
                                  self.stamp())
            return
        self.last_duty_time = self.now_s()

    def on_ambient(self, msg: Temperature) -> None:
        """Take a plausible ambient temperature; reject (log, WARN) any other."""
        t = msg.temperature
        if not (math.isfinite(t) and AMBIENT_RANGE_C[0] <= t <= AMBIENT_RANGE_C[1]):
            self.get_logger().warn(f'rejected ambient temperature {t}')
            self.diag.publish(WARN, f'rejected ambient temperature {t}', self._status(),
                              self.stamp())
            return
        self.ambient_c = t

    # step -----------------------------------------------------------------------------
    def on_tick(self) -> None:
        """Step the actuator one period and publish joint state, temperatures, diagnostics."""
        if self.accelerated:
            if not self.sim_started():
                return
            if self.duration_s and self.sim_time >= self.duration_s - 0.5 / self.rate_hz:
                self.finished = True
                return
            if (self.lockstep and self.awaiting_since is not None
                    and time.monotonic() - self.awaiting_since < self.lockstep_timeout_s):
                return
            dt = 1.0 / self.rate_hz
            self.sim_time += dt
            self.clock_pub.publish(ClockMsg(clock=self.stamp()))
        else:
            now = self.now_s()
            dt = 1.0 / self.rate_hz if self.last_tick is None else now - self.last_tick
            self.last_tick = now
            if dt <= 0:   # sim clock not running yet, or went backwards
                return
        stale = self.duty_stale()
        conflict = self.check_duty_publishers()
        requested = (0.0, 0.0) if stale or conflict else self.duty.value
        self.applied_time_s = self.now_s()
        self.applied, held = self.interlock.apply(*requested, self.applied_time_s)
        if held == BOTH_REQUESTED:    # a reversal waiting out the dead time is normal
            self.get_logger().warn(f'interlock: {held}; applying {self.applied}',
                                   throttle_duration_sec=1.0)
        if stale and not self.was_stale and self.last_duty_time is not None:
            self.zeroed = (self.now_s(), self.last_step_time)
            self.get_logger().warn(f'no valid duty for {self.duty_timeout_s:g} s: zero duty')
            self.diag.publish(WARN, 'duty stale: applying zero duty', self._status(),
                              self.stamp())
        self.was_stale = stale
        self.last_step_time = self.now_s()
        angle = self.actuator.step(*self.applied, dt,
                                   self.ambient_c if self.use_ambient_topic else None)
        position = self.pot.angle(self.pot.counts(angle, self.rng))
        velocity = 0.0 if self.last_position is None else (position - self.last_position) / dt
        self.last_position = position
        stamp = self.stamp()
        self.js_pub.publish(JointState(name=[c.JOINT_NAME], position=[position],
                                       velocity=[velocity], header=_header(stamp, '')))
        self.awaiting_since = time.monotonic()
        for pub, frame, theta in zip(self.temp_pubs, c.WIRE_FRAMES, self.actuator.temperature_c):
            pub.publish(Temperature(header=_header(stamp, frame), temperature=float(theta),
                                    variance=0.0))
        self.steps += 1
        if self.steps % self.steps_per_diag == 0:
            if conflict:
                self.diag.publish(ERROR, self._conflict_text(), self._status(), stamp)
            elif stale and self.last_duty_time is not None:
                self.diag.publish(WARN, 'duty stale: applying zero duty', self._status(), stamp)
            else:
                self.diag.publish(OK, 'running' if not stale else 'no duty yet (zero applied)',
                                  self._status(), stamp)

    def check_duty_publishers(self) -> bool:
        """
        Return True while more than one node publishes on the duty topic.

        Two controllers alternate their commands, and the plant cannot tell which one is
        meant: zero duty is applied and ERROR reported until one of them is gone.
        """
        now = time.monotonic()
        if now - self._publishers_checked < PUBLISHER_CHECK_PERIOD_S:
            return self.duty_publishers > 1    # accelerated: not on every fast step
        self._publishers_checked = now
        count = self.count_publishers(self.duty_sub.topic_name)
        before, self.duty_publishers = self.duty_publishers, count
        if count > 1 and before <= 1:
            self.get_logger().error(self._conflict_text())
            self.diag.publish(ERROR, self._conflict_text(), self._status(), self.stamp())
        elif count <= 1 < before:
            self.get_logger().info(f'{count} publisher on {self.duty_sub.topic_name} again')
        return count > 1

    def _conflict_text(self) -> str:
        return (f'{self.duty_publishers} publishers on {self.duty_sub.topic_name}: '
                'applying zero duty')

    def sim_started(self) -> bool:
        """Accelerated mode: whether start_subscribers and warmup_s allow stepping."""
        if self.start_wall is None:
            if self.js_pub.get_subscription_count() < self.start_subscribers:
                return False
            self.start_wall = time.monotonic() + self.warmup_s
        return time.monotonic() >= self.start_wall

    def duty_stale(self) -> bool:
        """No valid duty for duty_timeout_s of plant time (or never)."""
        return (self.last_duty_time is None
                or self.now_s() - self.last_duty_time > self.duty_timeout_s)

    def _status(self) -> Dict[str, Any]:
        th = self.actuator.temperature_c
        out = {'applied_duty_a': float(self.applied[0]), 'applied_duty_b': float(self.applied[1]),
               'theta_a_c': float(th[0]), 'theta_b_c': float(th[1]),
               'rejected_duties': self.duty.rejected, 'interlock_held': self.interlock.held,
               'duty_publishers': self.duty_publishers, 'sim_time_s': float(self.now_s())}
        # the timeout as the plant saw it, on its own clock (full precision: epoch seconds)
        if self.zeroed and self.last_duty_time is not None \
                and self.last_duty_time <= self.zeroed[0]:
            zero_s, previous_step_s = self.zeroed
            out.update(last_valid_duty_s=f'{self.last_duty_time:.6f}',
                       zero_duty_applied_s=f'{zero_s:.6f}',
                       previous_step_s=f'{previous_step_s:.6f}')
        return out


def _base_model(model_file: str) -> ActuatorParams:
    """Return the ActuatorParams of `model_file` (empty: the defaults)."""
    if not model_file:
        return ActuatorParams()
    try:
        return load_model(model_file)
    except (OSError, ValueError, TypeError) as err:
        raise ParameterError(f'parameter model_file: cannot load {model_file}: {err}') from err


def _header(stamp: TimeMsg, frame: str) -> Header:
    return Header(stamp=stamp, frame_id=frame)


def main(args: Optional[Sequence[str]] = None) -> None:
    """Run the plant until SIGINT/SIGTERM or the end of duration_s."""
    handle_command_line('plant_sim', __doc__, PARAMETERS, args)
    stop = init_with_stop_signals(args, 'plant_sim')
    node = None
    try:
        node = create_node('plant_sim', PlantSim, args)
        spin_until_stopped(node, stop, done=lambda: node.finished)
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()


if __name__ == '__main__':
    main()

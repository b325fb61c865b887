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
setpoint: publishes /sma/setpoint [rad] from a profile (step, ramp, sine, square, chirp).

The profile (`sma_actuator.profiles.Profile`) runs on the node clock (sim time with
use_sim_time) from the first timer tick; profile parameters can be changed at runtime.
`one_shot`: wait for a subscriber, publish `offset` once, wait until it is acknowledged,
exit (for users without the ros2 CLI):

    setpoint --ros-args -p one_shot:=true -p offset:=0.3
"""
from dataclasses import fields, replace
import sys
import threading
import time
from typing import Any, List, Optional, Sequence

from rcl_interfaces.msg import SetParametersResult
import rclpy
from rclpy.node import Node
from rclpy.parameter import Parameter
from std_msgs.msg import Float64

from . import common as c
from .ros_console import (
    create_node,
    handle_command_line,
    init_with_stop_signals,
    spin_until_stopped,
)
from .ros_diagnostics import Diagnostics, OK, WARN
from .ros_params import declare_parameters, Param
from ..profiles import Profile, PROFILES

_D = Profile()
# Profile fields: (name, lo, hi, description)
PROFILE_PARAMS = (
    ('amplitude', -3.0, 3.0, 'Profile amplitude A [rad].'),
    ('offset', -3.0, 3.0, 'Profile offset r0 [rad] (the one-shot value).'),
    ('period_s', 0.01, 3600.0, 'Period P (ramp duration, sine/square period, chirp 1/f0) [s].'),
    ('delay_s', 0.0, 3600.0, 'Time at r0 before the profile starts [s].'),
    ('chirp_end_hz', 0.001, 20.0, 'Chirp end frequency f1 [Hz].'),
    ('chirp_duration_s', 0.1, 3600.0, 'Chirp sweep duration D [s].'),
)
PARAMETERS = (
    Param('profile', _D.kind, 'Setpoint profile (changeable at runtime).', choices=PROFILES),
    *(Param(name, getattr(_D, name), desc, (lo, hi)) for name, lo, hi, desc in PROFILE_PARAMS),
    Param('rate_hz', 40.0, 'Publication rate [Hz].', (0.1, 1000.0), read_only=True),
    Param('duration_s', 0.0, 'Stop publishing after this long [s] of the node clock (sim '
          'time with use_sim_time) and exit; 0 = never.', (0.0, 1e6), read_only=True),
    Param('one_shot', False, 'Publish `offset` once and exit.', read_only=True),
)


class Setpoint(Node):
    """
    Setpoint source node (see module docstring).

    :param kwargs: rclpy ``Node`` keyword arguments (context, parameter_overrides,
        namespace: default ``sma``, ...); the parameters are those of ``PARAMETERS``.
    :raises ParameterError: A parameter value the node cannot run with.
    """

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('setpoint', **c.node_options(kwargs))
        p = declare_parameters(self, PARAMETERS)
        self.profile = Profile(p['profile'], **{name: p[name] for name, *_ in PROFILE_PARAMS})
        rate, self.duration_s, self.one_shot = p['rate_hz'], p['duration_s'], p['one_shot']
        self.pub = self.create_publisher(Float64, c.SETPOINT, c.COMMAND_QOS)
        self.diag = Diagnostics(self, 'setpoint')
        self.add_on_set_parameters_callback(self.on_set_parameters)
        self.t0 = None
        self.value = None
        self.done = False
        if not self.one_shot:
            self.timer = self.create_timer(1.0 / rate, self.on_tick)
            self.create_timer(1.0, self.publish_status)

    def on_tick(self) -> None:
        """Publish the profile value at the node-clock time since the first tick."""
        now = self.get_clock().now().nanoseconds * 1e-9
        if now <= 0.0:          # use_sim_time and no /clock yet
            return
        if self.t0 is None:
            self.t0 = now
        t = now - self.t0
        if self.duration_s > 0 and t > self.duration_s:
            self.done = True
            self.timer.cancel()
            return
        self.value = float(self.profile(t))
        self.pub.publish(Float64(data=self.value))

    def publish_status(self) -> None:
        """Publish the 1 Hz diagnostics status."""
        p = self.profile
        self.diag.publish(OK, 'done' if self.done else f'profile {p.kind}',
                          {'profile': p.kind, 'amplitude_rad': p.amplitude, 'offset_rad': p.offset,
                           'period_s': p.period_s, 'setpoint_rad': self.value})

    def publish_once(self, wait_s: float = 5.0,
                     stop: Optional[threading.Event] = None) -> bool:
        """
        One-shot: wait for a subscriber, publish `offset`, wait for the acknowledgement.

        `stop` (a threading.Event, set by SIGINT/SIGTERM) ends the wait early.
        """
        stop = stop or threading.Event()
        deadline = time.monotonic() + wait_s
        while (self.pub.get_subscription_count() == 0 and time.monotonic() < deadline
               and not stop.wait(0.05)):
            pass
        if stop.is_set():
            return False
        if self.pub.get_subscription_count() == 0:
            self.get_logger().error(f'no subscriber on {c.SETPOINT} within {wait_s:g} s')
            return False
        self.pub.publish(Float64(data=self.profile.offset))
        acked = self.pub.wait_for_all_acked(rclpy.duration.Duration(seconds=wait_s))
        self.get_logger().info(f'published setpoint {self.profile.offset:g} rad'
                               f'{"" if acked else " (not acknowledged)"}')
        return acked

    def on_set_parameters(self, params: List[Parameter]) -> SetParametersResult:
        """Apply a runtime profile change; refuse (WARN) one the profile rejects."""
        names = {f.name for f in fields(Profile)}
        changes = {('kind' if p.name == 'profile' else p.name): p.value for p in params
                   if p.name in names or p.name == 'profile'}
        if not changes:
            return SetParametersResult(successful=True)
        try:
            self.profile = replace(self.profile, **changes)
        except (ValueError, TypeError) as e:
            self.diag.publish(WARN, f'rejected profile change: {e}')
            return SetParametersResult(successful=False, reason=str(e))
        return SetParametersResult(successful=True)


def main(args: Optional[Sequence[str]] = None) -> None:
    """Publish the profile until SIGINT/SIGTERM or duration_s; exit 1 if a one-shot fails."""
    handle_command_line('setpoint', __doc__, PARAMETERS, args)
    stop = init_with_stop_signals(args, 'setpoint')
    node, ok = None, True
    try:
        node = create_node('setpoint', Setpoint, args)
        if node.one_shot:
            ok = node.publish_once(stop=stop)
        else:
            spin_until_stopped(node, stop, done=lambda: node.done, poll_s=0.1)
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    if not ok:
        sys.exit(1)


if __name__ == '__main__':
    main()

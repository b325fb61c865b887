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
Dead-time interlock on the applied duty, and the two-controller scenario of issue 13.

The rule (`control.interlock`) is checked on its own; then plant_sim runs with two
controller processes of opposite setpoints, and the plant's applied duties must never
heat both wires within the dead time of each other, while /diagnostics shows ERROR.
"""
import os
import subprocess
import sys
import time

from conftest import spin_until
import pytest

from sma_actuator.control.interlock import BOTH_REQUESTED, DEAD_TIME, DeadTimeInterlock

# (time [s], requested pair, applied pair, reason) with a 0.1 s dead time
STEPS = [
    (0.000, (0.5, 0.0), (0.5, 0.0), None),            # nothing was hot: a may heat
    (0.025, (0.0, 0.5), (0.0, 0.0), DEAD_TIME),        # a just went off: b held
    (0.050, (0.5, 0.0), (0.5, 0.0), None),             # b never heated: a again
    (0.075, (0.5, 0.5), (0.0, 0.0), BOTH_REQUESTED),   # both at once: both off
    (0.100, (0.0, 0.3), (0.0, 0.0), DEAD_TIME),        # a off since 0.075
    (0.170, (0.0, 0.3), (0.0, 0.0), DEAD_TIME),
    (0.180, (0.0, 0.3), (0.0, 0.3), None),             # over 0.1 s after a went off
    (0.200, (0.2, 0.0), (0.0, 0.0), DEAD_TIME),
    (0.290, (0.2, 0.0), (0.0, 0.0), DEAD_TIME),        # b off since 0.2
    (0.310, (0.2, 0.0), (0.2, 0.0), None),
]


def test_dead_time_rule_step_by_step():
    lock = DeadTimeInterlock(0.1)
    for t, request, applied, reason in STEPS:
        got, why = lock.apply(*request, t)
        assert (got, why) == (applied, reason), t
    assert lock.held == 6
    assert lock.reset(0.4) == (0.0, 0.0)


def test_dead_time_rule_on_a_wrapping_microsecond_counter():
    lock = DeadTimeInterlock(100_000, elapsed=lambda now, then: (now - then) & 0xFFFFFFFF)
    start = 0xFFFFFFFF - 30_000
    assert lock.apply(1000, 0, start) == ((1000, 0), None)
    assert lock.apply(0, 1000, (start + 50_000) & 0xFFFFFFFF) == ((0, 0), DEAD_TIME)
    assert lock.apply(0, 1000, (start + 149_999) & 0xFFFFFFFF) == ((0, 0), DEAD_TIME)
    assert lock.apply(0, 1000, (start + 150_000) & 0xFFFFFFFF) == ((0, 1000), None)


def test_zero_dead_time_still_refuses_both_at_once():
    lock = DeadTimeInterlock(0.0)
    assert lock.apply(0.4, 0.0, 0.0)[0] == (0.4, 0.0)
    assert lock.apply(0.0, 0.4, 0.0)[0] == (0.0, 0.4)     # a off for 0 s is long enough
    assert lock.apply(0.4, 0.4, 0.0)[0] == (0.0, 0.0)
    assert lock.apply(0.4, 0.0, 0.0)[0] == (0.4, 0.0)
    with pytest.raises(ValueError):
        DeadTimeInterlock(-0.1)


@pytest.mark.slow
def test_two_controllers_never_heat_both_wires_and_the_plant_reports_error(
        ros_context, ros_domain_id):
    rclpy = pytest.importorskip('rclpy')
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.parameter import Parameter
    from sensor_msgs.msg import Temperature

    from sma_actuator.nodes import common as c
    from sma_actuator.nodes.plant_sim import PlantSim

    dead_time_s = 0.05                  # the default
    ex = SingleThreadedExecutor(context=ros_context)
    plant = PlantSim(context=ros_context, parameter_overrides=[
        Parameter('interlock_dead_time_s', value=dead_time_s)])
    watcher = rclpy.create_node('watcher', context=ros_context, namespace=c.NAMESPACE)
    diags, temps = [], {'wire_a': [], 'wire_b': []}
    watcher.create_subscription(
        DiagnosticArray, c.DIAGNOSTICS,
        lambda m: diags.extend(s for s in m.status if s.name.startswith('plant_sim')),
        c.DIAGNOSTICS_QOS)
    for frame, topic in zip(c.WIRE_FRAMES, c.WIRE_TEMPERATURES):
        watcher.create_subscription(
            Temperature, topic, lambda m, frame=frame: temps[frame].append(m.temperature),
            c.SENSOR_QOS)
    for n in (plant, watcher):
        ex.add_node(n)
    env = dict(os.environ, ROS_DOMAIN_ID=str(ros_domain_id))
    procs = [subprocess.Popen([sys.executable, '-m', 'sma_actuator.nodes.controller',
                               '--ros-args', '-r', f'__node:={name}',
                               '-p', f'initial_setpoint_rad:={sp}'],
                              env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
             for name, sp in (('ca', 0.6), ('cb', -0.6))]
    record = []    # (plant time [s], applied duty pair) after every executor callback

    def spin(seconds):
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            ex.spin_once(timeout_sec=0.01)
            if not record or record[-1][1] != plant.applied:
                record.append((plant.applied_time_s, plant.applied))

    try:
        assert spin_until(ex, lambda: plant.count_publishers(c.DUTY) >= 2, 30), \
            'controller processes did not come up'
        spin(6.0)
    finally:
        for proc in procs:
            proc.kill()
            proc.wait(10)
    try:
        assert any(s.level == DiagnosticStatus.ERROR and 'publishers' in s.message
                   for s in diags), 'no ERROR for two publishers on the duty topic'
        assert all(not (a > 0 and b > 0) for _, (a, b) in record)
        # after a wire went off, the other waits the dead time (plant time)
        off_at, before = [None, None], (0.0, 0.0)
        for t, pair in record:
            for wire in (0, 1):
                if before[wire] > 0 and not pair[wire] > 0:
                    off_at[wire] = t
            for wire in (0, 1):
                other = off_at[1 - wire]
                if pair[wire] > 0 and other is not None:
                    assert t - other >= dead_time_s - 1e-9, (t, pair, record[-20:])
            before = pair
        hot_a = max(temps['wire_a']) - plant.params.ambient_c
        hot_b = max(temps['wire_b']) - plant.params.ambient_c
        assert min(hot_a, hot_b) < 15.0, (hot_a, hot_b)   # never both wires hot
    finally:
        ex.shutdown()
        for n in (plant, watcher):
            n.destroy_node()

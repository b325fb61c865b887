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

The rule (`control.interlock`) is checked on its own; then plant_sim runs with one
controller, and a second of the opposite setpoint joins: the applied duties never heat
both wires within the dead time of each other, and from the plant's discovery of the
second publisher on both wires get zero while /diagnostics shows ERROR.
"""
import os
import subprocess
import sys
import time

from conftest import spin_until
import numpy as np
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


def test_a_dead_time_of_two_periods_ends_on_the_third_sample_on_any_summed_clock():
    # plant_sim sums its 25 ms period in floating point, the controller its stamps' dt: two
    # periods from most sample times come a rounding error short of 0.05 s, and the plant
    # and the controller must release the wire on the same sample, or the controller's
    # model heats a wire the plant still holds off
    summed = [0.0]
    for k in range(1, 2000):
        summed.append(summed[-1] + 0.025)
    product = [k * 0.025 for k in range(2000)]
    short = sum(summed[k + 2] - summed[k] < 0.05 for k in range(1997))
    assert short > 1000                       # the ties this is about
    for clock in (summed, product):
        for k in range(1996):
            lock = DeadTimeInterlock(0.05)
            assert lock.apply(0.0, 0.3, clock[k])[0] == (0.0, 0.3)
            assert lock.apply(0.0, 0.0, clock[k + 1])[0] == (0.0, 0.0)     # b goes off
            assert lock.apply(0.3, 0.0, clock[k + 2]) == ((0.0, 0.0), DEAD_TIME), k
            assert lock.apply(0.3, 0.0, clock[k + 3]) == ((0.3, 0.0), None), k


def test_the_core_plant_holds_a_reversal_for_the_dead_time_as_plant_sim_does():
    # the ROS-free loop's plant (`control.closed_loop.CorePlant`) applies plant_sim's
    # interlock, so a command that reverses at once (a second publisher, an excitation
    # without a switch gap) is held there as well
    from sma_actuator.control.closed_loop import CorePlant
    from sma_actuator.core.actuator import ActuatorParams

    def wire_b_heat(dead_time_s):
        plant = CorePlant(ActuatorParams(), noise_rad=0.0, dead_time_s=dead_time_s)
        for _ in range(40):
            plant.step(1.0, 0.0)
        theta_b = [plant.actuator.temperature_c[1]]
        for _ in range(3):    # reverse at once: b asks for full duty from the next sample
            plant.step(0.0, 1.0)
            theta_b.append(plant.actuator.temperature_c[1])
        return (np.diff(theta_b) > 0.1).tolist(), plant.interlock.held

    assert wire_b_heat(0.05) == ([False, False, True], 2)    # held two 25 ms samples
    assert wire_b_heat(0.0) == ([True, True, True], 0)


@pytest.mark.parametrize('mode', ['pi', 'pi_inverse', 'on_off'])
def test_the_controller_sends_only_duties_the_plants_interlock_applies(mode):
    # the controller keeps the dead time in every mode, so the duty it publishes (and a
    # recorder logs) is the duty the wires get: the plant's interlock has nothing to hold
    from sma_actuator.control import ControllerCore, ControllerSettings
    from sma_actuator.control.closed_loop import CorePlant, run_tracking
    from sma_actuator.core.actuator import ActuatorParams
    from sma_actuator.profiles import Profile
    plant = CorePlant(ActuatorParams(), seed=3)
    run = run_tracking(ControllerCore(ActuatorParams(), ControllerSettings(mode)), plant,
                       Profile('square', 0.3, period_s=4.0, delay_s=0.5), 20.0)
    heated = np.flatnonzero(run.duty.max(axis=1) > 0)
    switches = np.count_nonzero(np.diff(run.duty[heated].argmax(axis=1)))
    assert switches >= 8 and plant.interlock.held == 0, (switches, plant.interlock.held)


def test_zero_dead_time_still_refuses_both_at_once():
    lock = DeadTimeInterlock(0.0)
    assert lock.apply(0.4, 0.0, 0.0)[0] == (0.4, 0.0)
    assert lock.apply(0.0, 0.4, 0.0)[0] == (0.0, 0.4)     # a off for 0 s is long enough
    assert lock.apply(0.4, 0.4, 0.0)[0] == (0.0, 0.0)
    assert lock.apply(0.4, 0.0, 0.0)[0] == (0.4, 0.0)
    with pytest.raises(ValueError):
        DeadTimeInterlock(-0.1)


@pytest.mark.slow
def test_a_second_controller_zeroes_both_wires_and_the_plant_reports_error(
        ros_context, ros_domain_id):
    rclpy = pytest.importorskip('rclpy')
    from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.parameter import Parameter

    from sma_actuator.nodes import common as c
    from sma_actuator.nodes.plant_sim import PlantSim

    dead_time_s = 0.05                  # the default
    ex = SingleThreadedExecutor(context=ros_context)
    plant = PlantSim(context=ros_context, parameter_overrides=[
        Parameter('interlock_dead_time_s', value=dead_time_s)])
    watcher = rclpy.create_node('watcher', context=ros_context, namespace=c.NAMESPACE)
    diags = []
    watcher.create_subscription(
        DiagnosticArray, c.DIAGNOSTICS,
        lambda m: diags.extend(s for s in m.status if s.name.startswith('plant_sim')),
        c.DIAGNOSTICS_QOS)
    for n in (plant, watcher):
        ex.add_node(n)
    env = dict(os.environ, ROS_DOMAIN_ID=str(ros_domain_id))

    def controller(name, setpoint_rad):
        return subprocess.Popen(
            [sys.executable, '-m', 'sma_actuator.nodes.controller', '--ros-args',
             '-r', f'__node:={name}', '-p', f'initial_setpoint_rad:={setpoint_rad}'],
            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)

    # (plant time [s], applied duty pair, two publishers seen, wire temperatures [degC])
    # after every executor callback from the start of the second controller on
    record = []

    def spin(seconds, until=lambda: False):
        end = time.monotonic() + seconds
        while time.monotonic() < end and not until():
            ex.spin_once(timeout_sec=0.01)
            record.append((plant.applied_time_s, plant.applied, plant.duty_publishers > 1,
                           tuple(plant.actuator.temperature_c)))

    procs = [controller('cb', -0.6)]
    try:
        # one controller alone heats its wire, as it should
        assert spin_until(ex, lambda: plant.applied[1] > 0, 30), 'controller cb never heated'
        procs.append(controller('ca', 0.6))
        spin(30.0, until=lambda: plant.duty_publishers >= 2)
        assert plant.duty_publishers >= 2, 'the plant never saw the second controller'
        seen = len(record)
        spin(6.0)
    finally:
        for proc in procs:
            proc.kill()
            proc.wait(10)
    try:
        assert any(s.level == DiagnosticStatus.ERROR and 'publishers' in s.message
                   for s in diags), 'no ERROR for two publishers on the duty topic'
        # until the second publisher is discovered, the dead-time interlock keeps the
        # wires apart: never both on, and a wire heats only after the other's dead time
        assert all(not (a > 0 and b > 0) for _, (a, b), _, _ in record)
        off_at, before = [None, None], (0.0, 0.0)
        for t, pair, _, _ in record:
            for wire in (0, 1):
                if before[wire] > 0 and not pair[wire] > 0:
                    off_at[wire] = t
            for wire in (0, 1):
                other = off_at[1 - wire]
                if pair[wire] > 0 and other is not None:
                    assert t - other >= dead_time_s - 1e-9, (t, pair)
            before = pair
        # once it is discovered, both wires get zero and only cool
        after = record[seen:]
        assert all(conflict for _, _, conflict, _ in after), 'a controller went away'
        assert all(pair == (0.0, 0.0) for _, pair, _, _ in after), 'heat with two publishers'
        temps = [theta for *_, theta in after]
        for wire in (0, 1):
            assert all(b[wire] <= a[wire] + 1e-9 for a, b in zip(temps, temps[1:])), wire
        assert temps[-1][1] < temps[0][1] - 1.0, (temps[0], temps[-1])   # cb's wire cools
    finally:
        ex.shutdown()
        for n in (plant, watcher):
            n.destroy_node()

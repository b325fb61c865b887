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
In-process closed loop for the demo, the benchmarks and the tests.

`run_closed_loop` puts plant_sim (accelerated: it owns time and publishes /clock),
controller and setpoint (both on use_sim_time) plus a `TraceProbe` on one executor, spins
until `duration_s` of sim time have passed and returns the probe's `Trace`. The nodes
talk only over the real topics. `attach` hooks let a caller add more nodes (e.g. a bag
recorder) to the same executor for the run.
"""
from __future__ import annotations

from dataclasses import dataclass, field
import functools
import time
from typing import Any, Callable, Dict, Iterable, List, Optional, Tuple

import numpy as np
from numpy.typing import ArrayLike
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState, Temperature
from std_msgs.msg import Float64, Float64MultiArray

from .nodes import common as c
from .nodes.controller import Controller
from .nodes.plant_sim import PlantSim
from .nodes.setpoint import Setpoint

# a loaded host can stall the controller for tens of ms; only a dead one should make the
# plant step without its reply (that would change the loop delay and the results)
LOCKSTEP_TIMEOUT_S = 1.0


@dataclass
class Trace:
    """Samples seen on the topics, on the plant's (sim) time axis [s]."""

    time_s: list = field(default_factory=list)       # joint-state stamps
    position: list = field(default_factory=list)     # measured shaft angle [rad]
    setpoint: list = field(default_factory=list)     # latest setpoint at that stamp [rad]
    duty: list = field(default_factory=list)         # latest duty pair at that stamp
    theta: list = field(default_factory=list)        # latest plant wire temperatures [°C]

    def arrays(self) -> Dict[str, np.ndarray]:
        """Return a dict of numpy arrays: time_s, position, setpoint (n,); duty, theta (n, 2)."""
        out = {k: np.asarray(getattr(self, k), dtype=float)
               for k in ('time_s', 'position', 'setpoint')}
        out.update({k: np.asarray(getattr(self, k), dtype=float).reshape(-1, 2)
                    for k in ('duty', 'theta')})
        return out


class TraceProbe(Node):
    """Listens to setpoint, duty, wire temperatures and joint states; one row per joint state."""

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('trace_probe', **c.node_options(kwargs))
        self.trace = Trace()
        self.setpoint = None
        self.duty = (0.0, 0.0)
        self.theta = [float('nan'), float('nan')]
        self.create_subscription(Float64, c.SETPOINT, self._sp, c.COMMAND_QOS)
        self.create_subscription(Float64MultiArray, c.DUTY, self._duty, c.COMMAND_QOS)
        for wire, topic in enumerate(c.WIRE_TEMPERATURES):
            self.create_subscription(Temperature, topic, functools.partial(self._temp, wire),
                                     c.SENSOR_QOS)
        self.create_subscription(JointState, c.JOINT_STATES, self._js, c.SENSOR_QOS)

    def _sp(self, msg: Float64) -> None:
        """Keep the latest setpoint [rad]."""
        self.setpoint = msg.data

    def _duty(self, msg: Float64MultiArray) -> None:
        """Keep the latest duty pair."""
        self.duty = tuple(msg.data)

    def _temp(self, wire: int, msg: Temperature) -> None:
        """Keep the latest temperature [°C] of wire 0 (a) or 1 (b)."""
        self.theta[wire] = msg.temperature

    def _js(self, msg: JointState) -> None:
        """Add a trace row: the joint state with the latest setpoint, duty and temperatures."""
        if self.setpoint is None:      # the loop starts with the first setpoint
            return
        t = self.trace
        t.time_s.append(c.stamp_to_s(msg.header.stamp))
        t.position.append(msg.position[0])
        t.setpoint.append(self.setpoint)
        t.duty.append(self.duty)
        t.theta.append(tuple(self.theta))

    def sim_time(self) -> float:
        """Return the sim time covered by the trace so far [s]."""
        return self.trace.time_s[-1] - self.trace.time_s[0] if self.trace.time_s else 0.0


class ExcitationSource(Node):
    """
    Open-loop duty source for identification.

    Answers each joint state with the next duty of a sequence (so the plant's lockstep holds) and
    logs (stamp t_k, position at t_k, duty sent in reply, which the plant holds over [t_k, t_k+1)).
    """

    def __init__(self, duty_a: ArrayLike, duty_b: ArrayLike, **kwargs: Any) -> None:
        super().__init__('excitation', **c.node_options(kwargs))
        self.sequence = np.column_stack([duty_a, duty_b])
        self.k = 0
        self.applied = (0.0, 0.0)
        self.rows = []
        self.pub = self.create_publisher(Float64MultiArray, c.DUTY, c.COMMAND_QOS)
        self.create_subscription(JointState, c.JOINT_STATES, self._js, c.SENSOR_QOS)

    def _js(self, msg: JointState) -> None:
        """Answer a joint state with the next duty (zero duty once the sequence is done)."""
        if self.k >= len(self.sequence):
            self.pub.publish(Float64MultiArray(data=[0.0, 0.0]))
            return
        self.applied = tuple(float(d) for d in self.sequence[self.k])
        self.rows.append((c.stamp_to_s(msg.header.stamp), msg.position[0], *self.applied))
        self.k += 1
        self.pub.publish(Float64MultiArray(data=list(self.applied)))

    def done(self) -> bool:
        """Return whether every duty of the sequence was sent."""
        return self.k >= len(self.sequence)


def run_excitation(context: Context, duty_a: ArrayLike, duty_b: ArrayLike,
                   plant: Optional[Dict[str, Any]] = None,
                   real_time_factor: float = 100.0) -> Tuple[np.ndarray, ...]:
    """
    Drive the plant node open loop with a duty sequence (one entry per 25 ms plant step).

    Returns arrays (time_s, duty_a, duty_b, position): position sampled at time_s[k], and
    duty_*[k] held from time_s[k] over the next step (sample, then hold: the convention of
    `core.actuator.simulate` and `core.identification.DynamicData`).
    """
    kw = {'context': context, 'start_parameter_services': False}
    executor = SingleThreadedExecutor(context=context)
    nodes = []
    try:
        source = ExcitationSource(duty_a, duty_b, **kw)
        nodes.append(source)
        # dead time 0: the rows must hold the duties the plant applied, and an excitation
        # switches from one wire straight to the other; both at once is still refused
        plant_node = PlantSim(**kw, parameter_overrides=_overrides(
            {'accelerated': True, 'lockstep': True, 'lockstep_timeout_s': LOCKSTEP_TIMEOUT_S,
             'real_time_factor': float(real_time_factor), 'interlock_dead_time_s': 0.0,
             **(plant or {})}))
        plant_node.timer.cancel()
        nodes.append(plant_node)
        for n in nodes:
            executor.add_node(n)
        end = time.monotonic() + 0.3
        while time.monotonic() < end:
            executor.spin_once(timeout_sec=0.05)
        plant_node.timer.reset()
        deadline = time.monotonic() + 10.0 + len(duty_a) * 0.025
        while not source.done():
            if time.monotonic() > deadline:
                raise TimeoutError('excitation run did not finish')
            executor.spin_once(timeout_sec=0.05)
        rows = np.array(source.rows)
        return rows[:, 0], rows[:, 2], rows[:, 3], rows[:, 1]
    finally:
        executor.shutdown()
        for n in reversed(nodes):
            n.destroy_node()


def _overrides(d: Optional[Dict[str, Any]]) -> List[Parameter]:
    """Return parameter overrides as a list of rclpy Parameters."""
    return [Parameter(k, value=v) for k, v in (d or {}).items()]


def run_closed_loop(context: Context, profile: Dict[str, Any], duration_s: float,
                    mode: str = 'pi', real_time_factor: float = 20.0,
                    plant: Optional[Dict[str, Any]] = None,
                    controller: Optional[Dict[str, Any]] = None,
                    setpoint: Optional[Dict[str, Any]] = None,
                    attach: Iterable[Callable[[Context], Node]] = (),
                    warmup_s: Optional[float] = None,
                    wall_timeout_s: Optional[float] = None) -> Trace:
    """
    Run one closed-loop experiment; return the `Trace`.

    profile: dict of setpoint parameters (profile, amplitude, offset, period_s, delay_s...);
    plant / controller / setpoint: extra parameter overrides of each node; attach:
    callables factory(context) -> Node added to the executor for this run (and destroyed
    after it), e.g. a bag recorder. The plant's clock is held for `warmup_s` wall seconds
    (default 0.3, 1.0 with attachments) so discovery completes before sim time starts.
    """
    sim = [Parameter('use_sim_time', value=True)]
    # no parameter services: nothing sets parameters during a run, and 6 services per node
    # would double the executor's wait set (its rebuild is most of the per-step cost)
    kw = {'context': context, 'start_parameter_services': False}
    nodes = []
    executor = SingleThreadedExecutor(context=context)
    try:
        probe = TraceProbe(**kw, parameter_overrides=sim)
        nodes.append(probe)
        nodes.append(Controller(**kw, parameter_overrides=sim + _overrides(
            {'mode': mode, **(controller or {})})))
        nodes.append(Setpoint(**kw, parameter_overrides=sim + _overrides(
            {**profile, **(setpoint or {})})))
        plant_node = PlantSim(**kw, parameter_overrides=_overrides(
            {'accelerated': True, 'lockstep': True, 'lockstep_timeout_s': LOCKSTEP_TIMEOUT_S,
             'real_time_factor': float(real_time_factor), **(plant or {})}))
        plant_node.timer.cancel()             # sim time starts after the warm-up
        nodes.append(plant_node)
        nodes.extend(factory(context) for factory in attach)
        for n in nodes:
            executor.add_node(n)
        warmup_s = (1.0 if attach else 0.3) if warmup_s is None else warmup_s
        end = time.monotonic() + warmup_s
        while time.monotonic() < end:
            executor.spin_once(timeout_sec=0.05)
        plant_node.timer.reset()
        limit = wall_timeout_s or 10.0 + 5.0 * duration_s / min(real_time_factor, 5.0)
        deadline = time.monotonic() + limit
        while probe.sim_time() < duration_s:
            if time.monotonic() > deadline:
                raise TimeoutError(f'closed loop reached {probe.sim_time():.1f} of '
                                   f'{duration_s:g} sim s in {limit:.0f} wall s')
            executor.spin_once(timeout_sec=0.05)
        return probe.trace
    finally:
        executor.shutdown()
        for n in reversed(nodes):
            n.destroy_node()

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
ROS-free closed loop: a `ControllerCore` against a plant, sample by sample.

The plant is any object with `measure()` -> reading [rad] now and `step(duty_a, duty_b)`
-> reading one control period later (duties held over it), optionally `ambient_c()` ->
measured ambient [°C]. `CorePlant` is the package's own plant, the core actuator with the
plant node's potentiometer (`core.sensor.Potentiometer`: noise, 12-bit ADC) and its
dead-time interlock (`interlock.DeadTimeInterlock`), as plant_sim steps it. Used by the
tracking benchmark and the controller tests.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Protocol, TYPE_CHECKING

import numpy as np

from .interlock import DeadTimeInterlock, DEFAULT_DEAD_TIME_S
from .metrics import summarize
from ..core.actuator import ActuatorParams, AntagonisticActuator
from ..core.sensor import POT_RANGE_RAD, Potentiometer

if TYPE_CHECKING:
    from .law import ControllerCore


class Plant(Protocol):
    """What `run_tracking` needs of a plant (`ambient_c()` [°C] is optional)."""

    def measure(self) -> float:
        """Return the reading [rad] now."""

    def step(self, duty_a: float, duty_b: float) -> float:
        """Hold the duties for one control period; return the reading then [rad]."""


class CorePlant:
    """
    `core.AntagonisticActuator` + plant_sim's potentiometer and interlock, stepped every dt_s.

    dead_time_s: the interlock's dead time [s] (plant_sim's `interlock_dead_time_s`; 0: none,
    though a request to heat both wires at once still applies zero to both).
    """

    def __init__(self, params: ActuatorParams, dt_s: float = 0.025, noise_rad: float = 0.001,
                 seed: int = 7, bits: int = 12, dead_time_s: float = DEFAULT_DEAD_TIME_S):
        self.actuator = AntagonisticActuator(params)
        self.pot = Potentiometer(bits, *POT_RANGE_RAD, noise_rad)
        self.rng = np.random.default_rng(seed)
        self.dt_s = dt_s
        self.interlock = DeadTimeInterlock(dead_time_s)
        self.time_s = 0.0
        self.applied = (0.0, 0.0)   # duties the interlock let through over the last step
        self.reading = self._read(self.actuator.reading_now)

    def _read(self, angle: float) -> float:
        """Return the potentiometer's reading [rad] of shaft angle `angle` [rad]."""
        return self.pot.angle(self.pot.counts(angle, self.rng))

    def measure(self) -> float:
        """Return the reading [rad] now."""
        return self.reading

    def ambient_c(self) -> float:
        """Measured ambient [°C]: the model's constant ambient."""
        return self.actuator.params.ambient_c

    def command_time_s(self) -> float:
        """Return the time [s] the interlock sees this step's command at: as plant_sim, its end."""
        return self.time_s

    def step(self, duty_a: float, duty_b: float) -> float:
        """Hold the duties the interlock lets through for dt_s; return the reading then [rad]."""
        self.time_s += self.dt_s
        self.applied, _ = self.interlock.apply(duty_a, duty_b, self.command_time_s())
        self.reading = self._read(self.actuator.step(*self.applied, self.dt_s))
        return self.reading


@dataclass
class TrackingRun:
    """Time [s], setpoint and reading [rad], duties (n, 2) of one closed-loop run."""

    time_s: np.ndarray
    setpoint: np.ndarray
    position: np.ndarray
    duty: np.ndarray

    def summary(self, t_start: float, tolerance_rad: float = 0.025) -> dict:
        """`metrics.summarize` from t_start [s]: rms_error, max_error, settling_time."""
        return summarize(self.time_s, self.setpoint, self.position, tolerance_rad, t_start)


def run_tracking(controller: ControllerCore, plant: Plant, reference: Callable[[float], float],
                 seconds: float, dt_s: float = 0.025) -> TrackingRun:
    """
    Run `controller` against `plant` for `seconds`; reference(t) -> setpoint [rad].

    The setpoint and the reading at t_k give the duties held over [t_k, t_k + dt_s).
    """
    n = int(round(seconds / dt_s))
    rows = np.empty((n, 5))
    y = plant.measure()
    ambient = getattr(plant, 'ambient_c', None)
    for k in range(n):
        t = k * dt_s
        r = reference(t)
        out = controller.step(r, y, dt_s, ambient() if ambient else None)
        rows[k] = (t, r, y, out.duty_a, out.duty_b)
        y = plant.step(out.duty_a, out.duty_b)
    return TrackingRun(rows[:, 0], rows[:, 1], rows[:, 2], rows[:, 3:5])

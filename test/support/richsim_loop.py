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
Streaming form of the rich simulator, for closed-loop tests of the package's controller.

`RichPlant(effect, magnitude).step(duty_a, duty_b)` holds the duties for one 25 ms command
tick on the simulator's fine grid and returns the potentiometer reading at the next tick,
with the same physics as `richsim.run` (its numba helpers are called, nothing is
re-derived): transport delay in the command path, current limit, 1/2-node RK4 thermal
network, Preisach hysteresis, fatigue, kinematics, sensor polynomial, noise and 12-bit ADC.
"""
import math

from numba import njit
import numpy as np

from .richsim import _everett, _params, build_plant
from .richsim_kernel import adc, ambient, fine_step, sensor_ideal, shaft_angle
from .richsim_preisach import new_state


@njit(cache=True)
def _tick(p, wires, tab, lo, step, pstate, th, aus, cycles, ring, k0, n_fine, dt, da, db):
    """Advance n_fine fine steps from fine index k0 with commands (da, db); return phi."""
    nd = ring.shape[1] - 1
    for i in range(n_fine):
        k = k0 + i
        ring[0, k % (nd + 1)], ring[1, k % (nd + 1)] = da, db
        fine_step(p, wires, tab, lo, step, pstate, th, aus, cycles, ring, k, ambient(p, k * dt),
                  dt)
    return shaft_angle(p, wires, aus, cycles)


class RichPlant:
    """The rich simulator stepped one command tick at a time (see module docstring)."""

    def __init__(self, effect='none', magnitude=1.0, noise_rad=0.002, seed=0, params=None,
                 duration_s=600.0):
        self.pp = _params(params)
        rng = np.random.default_rng(seed)
        self.p, self.wires, _ = build_plant(self.pp, effect, magnitude, duration_s, rng)
        self.tab, self.lo, self.grid_step = _everett(self.pp)
        self.dt_cmd = self.pp['cmd_dt_s']
        self.n_fine = max(1, int(math.ceil(self.dt_cmd / self.pp['fine_dt_s'] - 1e-9)))
        self.dt = self.dt_cmd / self.n_fine
        amb0 = ambient(self.p, 0.0)
        self.pstate = new_state(2, amb0)
        self.th = np.full((2, 2), amb0)
        self.aus = np.zeros(2)
        self.cycles = np.zeros(2)
        self.ring = np.zeros((2, int(round(self.p.delay_s / self.dt)) + 1))
        self.k = 0
        self.noise_rad = noise_rad
        self.rng = np.random.default_rng(seed + 1)
        self.phi = self.p.phi0_rad

    @property
    def time_s(self):
        """Plant time [s]."""
        return self.k * self.dt

    def measure(self):
        """Potentiometer reading [rad] now (noise, 12-bit ADC)."""
        y = sensor_ideal(self.p, self.phi) + self.noise_rad * self.rng.standard_normal()
        return float(adc(self.p, y))

    def ambient_c(self):
        """Measured ambient [°C] (the true ambient; the simulator's sensor noise is small)."""
        return float(ambient(self.p, self.time_s))

    def step(self, duty_a, duty_b):
        """Hold the duties for one command tick; return the reading at the next tick [rad]."""
        self.phi = _tick(self.p, self.wires, self.tab, self.lo, self.grid_step, self.pstate,
                         self.th, self.aus, self.cycles, self.ring, self.k, self.n_fine,
                         self.dt, float(duty_a), float(duty_b))
        self.k += self.n_fine
        return self.measure()

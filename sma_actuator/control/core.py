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
`ControllerCore`: one control step of modes pi, pi_inverse and on_off (no ROS).

Per sample k (period dt, nominally the paper's 25 ms):

  1. estimator  advance the model by dt with the duties applied over the last period
                (θ̂, ŷ), and move the inverse's hysteresis state along with it
  2. guard      per-wire duty limits L_a, L_b = min(duty_max, thermal-guard limit)
  3. command    e = r − φ_meas;   u in [−L_b, L_a] (signed, + heats wire a)
                  pi:          u = PI(e)
                  pi_inverse:  u = PI(e) around u_ff = d_a,ff − d_b,ff (`feedforward`)
                  on_off:      u = relay(r − φ0) (±on_duty: one end position or the other)
  4. split      duty_a = clip(u, 0, L_a), duty_b = clip(−u, 0, L_b), then never both
                above `both_threshold`
"""
from dataclasses import dataclass, replace

from .estimator import WireEstimator
from .feedforward import InverseFeedforward
from .guard import ThermalGuard
from .on_off import OnOffRelay
from .pi import DiscretePI
from .split import exclusive, split
from ..core.validate import finite_scalar

MODES = ('pi', 'pi_inverse', 'on_off')


@dataclass
class ControllerSettings:
    """Tunable settings (the controller node's parameters of the same names)."""

    mode: str = 'pi'
    kp: float = 3.0                 # [duty / rad]
    ki: float = 4.0                 # [duty / (rad s)]
    duty_max: float = 1.0           # per-wire duty limit
    both_threshold: float = 0.05    # never both duties above this
    max_temp_c: float = 110.0       # thermal guard maximum [°C]
    guard_horizon_s: float = 0.5    # thermal guard look-ahead [s]
    on_off_band_rad: float = 0.05   # relay half-band of mode on_off [rad]
    on_off_duty: float = 1.0        # heating duty of mode on_off
    ff_horizon_s: float = 0.5       # pi_inverse thermal inverse horizon [s]; 0: static map

    def __post_init__(self):
        if self.mode not in MODES:
            raise ValueError(f'mode must be one of {MODES}, got {self.mode!r}')
        for name in ('kp', 'ki', 'duty_max', 'both_threshold', 'max_temp_c',
                     'guard_horizon_s', 'on_off_band_rad', 'on_off_duty', 'ff_horizon_s'):
            setattr(self, name, finite_scalar(name, getattr(self, name)))
        if not 0.0 <= self.duty_max <= 1.0 or not 0.0 <= self.both_threshold <= 1.0:
            raise ValueError('duty_max and both_threshold must be in [0, 1]')
        if self.kp < 0 or self.ki < 0 or self.ff_horizon_s < 0 or self.guard_horizon_s <= 0:
            raise ValueError('kp, ki, ff_horizon_s must be >= 0 and guard_horizon_s > 0')


@dataclass
class ControlStep:
    """Result of one step: duties and the internals reported in diagnostics."""

    duty_a: float
    duty_b: float
    error: float = 0.0
    feedforward: float = 0.0
    limits: tuple = (1.0, 1.0)
    theta_est_c: tuple = (0.0, 0.0)
    saturated: bool = False
    guard_active: bool = False


class ControllerCore:
    """The controller's state machine; `model` is the identified `ActuatorParams`."""

    def __init__(self, model, settings=None):
        self.model = model
        self.settings = ControllerSettings() if settings is None else settings
        self.estimator = WireEstimator(model)
        self.pi = DiscretePI(self.settings.kp, self.settings.ki)
        self.feedforward = InverseFeedforward(model)
        self._apply(self.settings)
        self.reset()

    def _apply(self, s):
        self.pi.set_gains(s.kp, s.ki)
        self.feedforward.duty_max = s.duty_max
        self.feedforward.horizon_s = s.ff_horizon_s
        self.guard = ThermalGuard(self.model, s.max_temp_c, s.guard_horizon_s)
        self.relay = OnOffRelay(s.on_off_band_rad, s.on_off_duty)

    def reset(self):
        """Back to rest: wires estimated cold, integrator and relay cleared, duties zero."""
        self.estimator.reset()
        self.feedforward.reset()
        self.pi.reset()
        self.relay.reset()
        self.last_duty = (0.0, 0.0)

    def configure(self, **changes):
        """Apply validated setting changes at runtime (gains, mode, limits)."""
        new = replace(self.settings, **changes)
        if new.mode != self.settings.mode:
            self.pi.reset()     # the integral of one mode means nothing in another
        state = self.relay.state
        self._apply(new)
        self.relay.state = state if new.mode == self.settings.mode else 0
        self.settings = new

    def _advance(self, dt, ambient_c):
        self.estimator.update(*self.last_duty, dt, ambient_c)
        self.feedforward.track(self.estimator.hysteresis_inputs())

    def step(self, setpoint, measured, dt, ambient_c=None):
        """One control sample: setpoint and measured angle [rad], dt [s] since the last step."""
        s = self.settings
        dt = finite_scalar('dt', dt)
        self._advance(dt, ambient_c)
        theta = self.estimator.temperature_c
        g_a, g_b = self.guard.limits(theta, self.last_duty, ambient_c)
        lim_a, lim_b = min(s.duty_max, g_a), min(s.duty_max, g_b)
        error = finite_scalar('setpoint', setpoint) - finite_scalar('measured', measured)
        u_ff = 0.0
        if s.mode == 'on_off':
            u = min(max(self.relay.step(setpoint - self.model.offset_rad), -lim_b), lim_a)
        else:
            if s.mode == 'pi_inverse':
                (ff_a, ff_b), _ = self.feedforward.duties(setpoint, ambient_c,
                                                          self.estimator.contraction, theta)
                u_ff = ff_a - ff_b
            u = self.pi.step(error, dt, -lim_b, lim_a, feedforward=u_ff)
        duty_a, duty_b = exclusive(*split(u, lim_a, lim_b), s.both_threshold)
        self.last_duty = (duty_a, duty_b)
        return ControlStep(duty_a, duty_b, error, u_ff, (lim_a, lim_b), tuple(theta),
                           self.pi.saturated, min(g_a, g_b) < s.duty_max)

    def idle(self, dt, ambient_c=None):
        """Fault path (stale feedback): zero duty, integrator cleared, estimate keeps running."""
        self._advance(finite_scalar('dt', dt), ambient_c)
        self.pi.reset()
        self.relay.reset()
        self.last_duty = (0.0, 0.0)
        return ControlStep(0.0, 0.0, theta_est_c=tuple(self.estimator.temperature_c))

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

Per sample k (period dt, nominally the paper's 25 ms), with r the setpoint and y the
measured angle, both in sensor units [rad] (the error that is judged is r − y):

  1. estimator  advance the model by dt with the duties applied over the last period
                (θ̂, ŷ; the measured ambient, `ambient_c`, drives it), and move the
                inverse's hysteresis state along with it
  2. guard      per-wire duty limits L_a, L_b = min(duty_max, thermal-guard limit)
  3. command    u in [−L_b, L_a] (signed, + heats wire a)
                  pi:          u = PI(r − y)
                  pi_inverse:  u = PI(e) around u_ff = d_a,ff − d_b,ff (`feedforward`), with
                               every effect of the model used (below)
                  on_off:      u = relay(r − φ0) (±on_duty: one end position or the other)
  4. split      duty_a = clip(u, 0, L_a), duty_b = clip(−u, 0, L_b), then never both
                above `both_threshold`
  5. interlock  a wire heats only `dead_time_s` after the other stopped (`interlock`, the
                rule plant_sim and the hardware bridge apply), in every mode: the duty
                published is the duty applied, so a recorded `/sma/duty` is what the
                wires got

pi_inverse, effect by effect:
  * sensor nonlinearity: the PI and the inverse work on true angles, p^-1(r) and p^-1(y),
    the potentiometer polynomial (`core.actuator.sensor_polynomial`) inverted on its rising branch;
  * delay D: the measurement is predicted D ahead (Smith predictor, `estimator`), and the
    reference is extrapolated D ahead (r + D ṙ, ṙ from the last two setpoints; a jump
    larger than `JUMP_RATE_RAD_S` dt is a step and is not extrapolated), so the PI compares
    where the shaft will read D from now with where the reference will be then;
  * thermal lag: the thermal inverse brings the wire to the target of t + h + D in h
    (`ff_horizon_s`), the reference extrapolated over h + D;
  * loop reversal: where the reference's own curvature says it turns within
    L = min(`REVERSAL_LEAD_S`, sqrt(2 `REVERSAL_SHORTFALL_RAD` / |r̈|)) (+ D), the inverse
    aims at r + L ṙ + L² r̈ / 2, past the turn: the active wire starts through its loop
    (about 1 s of cooling) before the peak instead of after it;
  * zero crossings: the incoming wire is heated early (`handover`);
  * asymmetric wires, current limit, convection, phase resistance, stress coupling: per-
    wire H^-1 and thermal inverse (`feedforward`);
  * ambient: the measured ambient drives the estimate and the thermal inverse (a model fitted
    at constant ambient, `ambient_gain` 0, is used with the physical gain 1: its fitted
    ambient is the recording's);
  * drift (`drift_correction`): offset and stroke corrected from the measurements
    (`estimator.DriftEstimator`), bounded.
Gains: kp, ki default to SIMC rules on the model (`tuning`), gentler with a longer delay;
pi_inverse bounds the closed-loop time constant by `TAU_C_INVERSE_S`.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
import math
from typing import Any, Optional, Sequence, Tuple

import numpy as np

from .estimator import DriftEstimator, WireEstimator
from .feedforward import InverseFeedforward
from .guard import ThermalGuard
from .handover import MIN_RATE_RAD_S, Preheat
from .interlock import DeadTimeInterlock, DEFAULT_DEAD_TIME_S
from .on_off import OnOffRelay
from .pi import DiscretePI
from .split import exclusive, split
from .tuning import simc_gains, TAU_C_MIN_S, transformation_start_c
from ..core.actuator import ActuatorParams, sensor_is_linear, sensor_rising_branch
from ..core.validate import finite_scalar

MODES = ('pi', 'pi_inverse', 'on_off')
# a setpoint moving faster than this [rad/s] between two samples is a step, not a trajectory
JUMP_RATE_RAD_S = 3.0
# longest reference extrapolation [rad]
MAX_EXTRAPOLATION_RAD = 0.5
NOMINAL_DT_S = 0.025
# ṙ and r̈ of the reference are smoothed over these [s] (`ReferencePredictor`)
RATE_TIME_S = 0.1
ACCEL_TIME_S = 0.2
# loop reversal anticipated up to this far [s], and no further than where the turn costs
# this much of the reference's height [rad], so a fast sine turns early but not short
REVERSAL_LEAD_S = 0.9
REVERSAL_SHORTFALL_RAD = 0.02
# the one-sided PI lets the antagonist pull once the shaft is this share of the stroke off
# its target on the antagonist's side: the active wire cools more slowly than the target
# moves away, or the shaft overshot a moving or held target, and only the antagonist takes
# it back
ANTAGONIST_LAG_SHARE = 0.05
# τc bound of pi_inverse [s] (`tuning`): with the feed-forward in the loop a faster PI makes a
# step overshoot, the wire reverse onto its cooling branch and the shaft cycle around it
TAU_C_INVERSE_S = 0.25


@dataclass
class ControllerSettings:
    """
    Tunable settings (the controller node's parameters of the same names).

    kp, ki: None (or negative) = derived from the model (`tuning.simc_gains`).
    """

    mode: str = 'pi'
    kp: Optional[float] = None      # [duty / rad]; None: SIMC from the model
    ki: Optional[float] = None      # [duty / (rad s)]; None: SIMC from the model
    duty_max: float = 1.0           # per-wire duty limit
    both_threshold: float = 0.05    # never both duties above this
    max_temp_c: float = 110.0       # thermal guard maximum [°C]
    guard_horizon_s: float = 0.5    # thermal guard look-ahead [s]
    on_off_band_rad: float = 0.05   # relay half-band of mode on_off [rad]
    on_off_duty: float = 1.0        # heating duty of mode on_off
    ff_horizon_s: float = 0.2       # pi_inverse thermal inverse horizon [s]; 0: static map
    smith: bool = True              # pi_inverse: predict the measurement over the delay
    drift_correction: bool = False  # pi_inverse: correct offset/stroke from measurements
    drift_time_s: float = 30.0      # memory of the drift estimator [s]
    preheat: bool = True            # pi_inverse: preheat the incoming wire (`handover`)
    dead_time_s: float = DEFAULT_DEAD_TIME_S   # interlock dead time [s] (every mode)

    def __post_init__(self) -> None:
        """Check and normalise the settings (a negative gain: from the model)."""
        if self.mode not in MODES:
            raise ValueError(f'mode must be one of {MODES}, got {self.mode!r}')
        for name in ('kp', 'ki'):
            value = getattr(self, name)
            if value is not None:
                value = finite_scalar(name, value)
                setattr(self, name, None if value < 0 else value)
        for name in ('duty_max', 'both_threshold', 'max_temp_c', 'guard_horizon_s',
                     'on_off_band_rad', 'on_off_duty', 'ff_horizon_s', 'drift_time_s',
                     'dead_time_s'):
            setattr(self, name, finite_scalar(name, getattr(self, name)))
        self.smith, self.drift_correction = bool(self.smith), bool(self.drift_correction)
        self.preheat = bool(self.preheat)
        if not 0.0 <= self.duty_max <= 1.0 or not 0.0 <= self.both_threshold <= 1.0:
            raise ValueError('duty_max and both_threshold must be in [0, 1]')
        if self.ff_horizon_s < 0 or self.guard_horizon_s <= 0 or self.drift_time_s <= 0:
            raise ValueError('ff_horizon_s must be >= 0, guard_horizon_s and drift_time_s > 0')
        if not 0.0 <= self.dead_time_s <= 1.0:
            raise ValueError(f'dead_time_s must be in [0, 1] s, got {self.dead_time_s}')


@dataclass
class ControlStep:
    """Result of one step: duties and the internals reported in diagnostics."""

    duty_a: float
    duty_b: float
    error: float = 0.0
    feedforward: float = 0.0
    limits: Tuple[float, float] = (1.0, 1.0)
    theta_est_c: Tuple[float, float] = (0.0, 0.0)
    saturated: bool = False
    guard_active: bool = False


class ReferencePredictor:
    """
    r(t + L) ≈ r + L ṙ (+ L² r̈ / 2) from the setpoint samples; steps are not extrapolated.

    ṙ is the setpoint's rate smoothed over `RATE_TIME_S` and r̈ the rate's change smoothed
    over `ACCEL_TIME_S` (exponential averages, ṙ ← ṙ + (Δr / dt − ṙ) dt / τ): a publisher
    on its own clock delivers a new setpoint in some control samples and two in others.
    """

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        """Forget the setpoint history."""
        self.last, self.rate, self.accel = None, 0.0, 0.0

    def update(self, r: float, dt: float) -> None:
        """Take the setpoint r [rad] of this sample."""
        if self.last is not None:
            raw = (r - self.last) / dt
            if abs(raw) <= JUMP_RATE_RAD_S:
                rate = self.rate + (raw - self.rate) * min(dt / RATE_TIME_S, 1.0)
                k = min(dt / ACCEL_TIME_S, 1.0)
                self.accel += ((rate - self.rate) / dt - self.accel) * k
                self.rate = rate
            else:
                self.rate, self.accel = 0.0, 0.0
        self.last = r

    def ahead(self, r: float, lead_s: float) -> float:
        """Extrapolated setpoint lead_s [s] ahead [rad]."""
        shift = self.rate * lead_s
        return r + min(max(shift, -MAX_EXTRAPOLATION_RAD), MAX_EXTRAPOLATION_RAD)

    def reversal(self, r: float, lead_s: float) -> Optional[float]:
        """
        Return r(t + L) = r + L ṙ + L² r̈ / 2 when ṙ changes sign within L, else None.

        r̈ is the difference of successive rates, smoothed over `ACCEL_TIME_S`.
        """
        if self.rate * (self.rate + lead_s * self.accel) >= 0.0:
            return None
        return r + lead_s * self.rate + 0.5 * lead_s ** 2 * self.accel


class SensorMap:
    """The model's potentiometer polynomial p and its exact inverse, tabulated once."""

    def __init__(self, params: ActuatorParams) -> None:
        self.identity = sensor_is_linear(params)
        if not self.identity:
            # the rising branch of p through the centre of travel, over the travel and well
            # beyond it (x = ±2)
            angles = params.sensor_centre_rad + params.sensor_half_span_rad * np.linspace(
                -2.0, 2.0, 8001)
            self._readings, self._angles = sensor_rising_branch(params, angles)

    def angle(self, reading_rad: float) -> float:
        """Return the true angle [rad] of a sensor reading (p^-1 on the tabulated branch)."""
        if self.identity:
            return reading_rad
        return float(np.interp(reading_rad, self._readings, self._angles))


def control_model(model: ActuatorParams) -> ActuatorParams:
    """
    Return the model as the controller runs it.

    A model fitted at constant ambient (`ambient_gain` 0: the recording's ambient is its
    `ambient_c`) is used with the physical gain 1, so the measured ambient moves the
    estimated wire temperatures.
    """
    return model.with_changes(ambient_gain=1.0) if model.ambient_gain == 0.0 else model


class ControllerCore:
    """
    The controller's state machine for an identified model (`ActuatorParams`, `load_model`).

    `step(setpoint_rad, measured_rad, dt_s, ambient_c=None)` -> `ControlStep` with
    `duty_a`, `duty_b` in [0, 1]. ambient_c: measured ambient [°C] (None: the model's).
    """

    def __init__(self, model: ActuatorParams,
                 settings: Optional[ControllerSettings] = None) -> None:
        self.fitted_model = model
        self.model = control_model(model)
        self.settings = ControllerSettings() if settings is None else settings
        self.estimator = WireEstimator(self.model)
        self.drift = DriftEstimator(self.model, self.settings.drift_time_s)
        self.sensor = SensorMap(self.model)
        self.reference = ReferencePredictor()
        self.pi = DiscretePI(0.0, 0.0)
        self.feedforward = InverseFeedforward(self.model)
        self.handover = Preheat(self.feedforward, transformation_start_c(self.model),
                                ambient_c=self.model.ambient_c)
        self._apply(self.settings)
        self.reset()

    def gains(self, settings: Optional[ControllerSettings] = None) -> Tuple[float, float]:
        """(kp, ki) in use for `settings` (default: the current ones): given or SIMC."""
        s = self.settings if settings is None else settings
        smith = s.mode == 'pi_inverse' and s.smith
        kp, ki = simc_gains(self.model, NOMINAL_DT_S, smith=smith,
                            tau_c_min_s=TAU_C_INVERSE_S if s.mode == 'pi_inverse' else TAU_C_MIN_S)
        return (kp if s.kp is None else s.kp), (ki if s.ki is None else s.ki)

    def _apply(self, s: ControllerSettings) -> None:
        """Hand the settings to the PI, inverse, drift estimator, guard, relay and handover."""
        self.pi.set_gains(*self.gains(s))
        self.feedforward.duty_max = s.duty_max
        self.feedforward.horizon_s = s.ff_horizon_s
        self.drift.time_s = s.drift_time_s
        self.guard = ThermalGuard(self.model, s.max_temp_c, s.guard_horizon_s)
        self.relay = OnOffRelay(s.on_off_band_rad, s.on_off_duty)
        self.handover.dead_time_s = s.dead_time_s

    def reset(self) -> None:
        """Back to rest: wires estimated cold, integrator and relay cleared, duties zero."""
        self.estimator.reset()
        self.feedforward.reset()
        self.drift.reset()
        self.reference.reset()
        self.pi.reset()
        self.relay.reset()
        self.handover.reset()
        self.handover.mismatch_ms = 0.0     # the estimate restarts: trust it again
        self.crossing, self.ff_temps = (None, math.inf), None
        self.interlock = DeadTimeInterlock(self.settings.dead_time_s)
        self.clock_s = 0.0
        self.last_duty = (0.0, 0.0)

    def configure(self, **changes: Any) -> None:
        """Apply validated setting changes at runtime (gains, mode, limits)."""
        new = replace(self.settings, **changes)
        if new.mode != self.settings.mode:
            self.pi.reset()     # the integral of one mode means nothing in another
        state = self.relay.state
        self._apply(new)
        self.interlock.dead_time = new.dead_time_s
        self.relay.state = state if new.mode == self.settings.mode else 0
        self.settings = new

    def _advance(self, dt: float, ambient_c: Optional[float]) -> None:
        """Step the estimate by dt [s] with the last duties; the inverse follows its state."""
        self.estimator.update(*self.last_duty, dt, ambient_c)
        self.feedforward.track(self.estimator.hysteresis_inputs())

    def _ambient(self, ambient_c: Optional[float]) -> float:
        """Ambient [°C] the model's wires feel for a measured ambient (None: model's)."""
        p = self.model
        if ambient_c is None:
            return p.ambient_c
        return p.ambient_c + p.ambient_gain * (ambient_c - p.ambient_c)

    def step(self, setpoint_rad: float, measured_rad: float, dt_s: float,
             ambient_c: Optional[float] = None) -> ControlStep:
        """
        Run one control sample and return its `ControlStep` (duty_a, duty_b, internals).

        setpoint_rad, measured_rad: desired and measured shaft angle [rad]; dt_s: time
        since the last step [s]; ambient_c: measured ambient [°C] or None.
        """
        s = self.settings
        dt = finite_scalar('dt_s', dt_s)
        if dt <= 0:
            raise ValueError(f'dt_s must be positive, got {dt}')
        r = finite_scalar('setpoint_rad', setpoint_rad)
        y = finite_scalar('measured_rad', measured_rad)
        if ambient_c is not None and not math.isfinite(ambient_c):
            ambient_c = None
        self._advance(dt, ambient_c)
        self.clock_s += dt
        self.reference.update(r, dt)
        theta = self.estimator.temperature_c
        g_a, g_b = self.guard.limits(theta, self.last_duty, ambient_c)
        lim_a, lim_b = min(s.duty_max, g_a), min(s.duty_max, g_b)
        error = r - y
        u_ff = 0.0
        if s.mode == 'on_off':
            u = min(max(self.relay.step(r - self.model.offset_rad), -lim_b), lim_a)
        elif s.mode == 'pi':
            u = self.pi.step(error, dt, -lim_b, lim_a)
        else:
            integral = self.pi.integral
            u, u_ff = self._inverse_step(r, y, dt, ambient_c, theta, lim_a, lim_b)
        duty_a, duty_b = exclusive(*split(u, lim_a, lim_b), s.both_threshold)
        if s.mode == 'pi_inverse':
            self.handover.observe(y - self.estimator.reading_delayed, dt)
            shared = self.handover.duties(
                *self.crossing, theta, self._ambient(ambient_c), dt, self.ff_temps,
                u) if s.preheat else None
            if shared is not None:
                self.pi.integral = integral
                duty_a, duty_b = min(shared[0], lim_a), min(shared[1], lim_b)
        (duty_a, duty_b), _ = self.interlock.apply(duty_a, duty_b, self.clock_s)
        self.last_duty = (duty_a, duty_b)
        return ControlStep(duty_a, duty_b, error, u_ff, (lim_a, lim_b), tuple(theta),
                           self.pi.saturated, min(g_a, g_b) < s.duty_max)

    def _inverse_step(self, r: float, y: float, dt: float, ambient_c: Optional[float],
                      theta: Sequence[float], lim_a: float,
                      lim_b: float) -> Tuple[float, float]:
        """Mode pi_inverse (module docstring): (u, u_ff)."""
        s, p = self.settings, self.model
        delay = p.delay_s
        predicted = y + (self.estimator.smith_correction() if s.smith else 0.0)
        angle = self.sensor.angle(predicted)
        if s.drift_correction:
            self.drift.update(self.estimator.contraction, self.sensor.angle(y), dt)
        target = self.sensor.angle(self.reference.ahead(r, delay if s.smith else 0.0))
        ff_r = self.reference.ahead(r, delay + s.ff_horizon_s)
        lead = REVERSAL_LEAD_S
        if self.reference.accel != 0.0:
            lead = min(lead, math.sqrt(2.0 * REVERSAL_SHORTFALL_RAD / abs(self.reference.accel)))
        turn = self.reference.reversal(r, delay + lead)
        ff_target = self.sensor.angle(ff_r if turn is None else turn)
        (ff_a, ff_b), self.ff_temps = self.feedforward.duties(
            ff_target, self._ambient(ambient_c), self.estimator.contraction, theta,
            self.drift.offset, self.drift.stroke)
        u_ff = ff_a - ff_b
        lo, hi = -lim_b, lim_a
        self.crossing = self._crossing(r)
        incoming, t_cross = self.crossing
        if incoming is None or t_cross > self.handover.free_lead_s[incoming]:
            # a reference far from a crossing (or held) and far on one side: the antagonist,
            # cold, would only heat, or pull a small overshoot back too far once it reaches
            # its transformation, unless the shaft is off the target on its side by more
            # than a small error, or the target runs away on its side faster than the active
            # wire cools
            side = self.feedforward.target_side(target, self.drift.offset, self.drift.stroke)
            off = ANTAGONIST_LAG_SHARE * abs(p.stroke_rad)
            outrun = self._outrun(target, ff_target, angle)
            lo = 0.0 if side > 0 and target - angle > -off and not outrun[0] else lo
            hi = 0.0 if side < 0 and target - angle < off and not outrun[1] else hi
        return self.pi.step(target - angle, dt, lo, hi, feedforward=u_ff), u_ff

    def _outrun(self, target: float, ff_target: float, angle: float) -> Tuple[bool, bool]:
        """
        Return, per wire, whether its target runs away from the shaft faster than it cools.

        True for wire a when the shaft is above the target and the inverse's target (its
        horizon and any reversal ahead) lies further down, φ_ff < φ* < φ, while wire a's
        thermal inverse asks for less than zero duty (`InverseFeedforward.cooling_short`):
        cooling freely it falls behind, and only the antagonist can follow; mirrored for b.
        """
        short = self.feedforward.cooling_short
        return (short[0] and ff_target < target < angle,
                short[1] and ff_target > target > angle)

    def _crossing(self, r: float) -> Tuple[Optional[int], float]:
        """
        Return (incoming wire or None, t_c [s]) of the next zero crossing of the target.

        The crossing is predicted in true angle: t_c = (φ0 − p⁻¹(r)) / ṙ, ṙ the
        extrapolated rate of p⁻¹(r) over 0.1 s; the incoming wire is a (0) for ṙ > 0, b (1)
        for ṙ < 0; (None, inf) when the reference does not head for a crossing.
        """
        now = self.sensor.angle(r)
        rate = (self.sensor.angle(self.reference.ahead(r, 0.1)) - now) / 0.1
        distance = self.drift.offset - now
        incoming, t_cross = None, math.inf
        if abs(rate) >= MIN_RATE_RAD_S and distance * rate > 0:
            incoming, t_cross = (0 if rate > 0 else 1), distance / rate
        return incoming, t_cross

    def idle(self, dt: float, ambient_c: Optional[float] = None) -> ControlStep:
        """Fault path (stale feedback): zero duty, integrator cleared, estimate keeps running."""
        self._advance(finite_scalar('dt', dt), ambient_c)
        self.pi.reset()
        self.relay.reset()
        self.reference.reset()
        self.clock_s += finite_scalar('dt', dt)
        self.interlock.apply(0.0, 0.0, self.clock_s)
        self.last_duty = (0.0, 0.0)
        return ControlStep(0.0, 0.0, theta_est_c=tuple(self.estimator.temperature_c))

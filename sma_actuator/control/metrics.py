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
Tracking metrics of a closed-loop run (the demo's summary.json figures).

e(t) = r(t) − φ(t) on the feedback samples, over the evaluation window [t_start, t_end]:
  rms_error     sqrt(mean e²) [rad]
  max_error     max |e| [rad]
  settling_time time from t_start until |e| stays within `tolerance_rad` to the end of
                the run [s]; None if the run ends outside the band (never settled).

Step response to r: φ0 = φ(t_start) -> r1 = r(t_end), step height h = r1 − φ0:
  rise_time           t(φ first reaches φ0 + 0.9 h) − t(φ first reaches φ0 + 0.1 h) [s];
                      None if φ never reaches 90 % of the step
  overshoot           100 · max(0, max sign(h) (φ − r1)) / |h| [%]
  steady_state_error  mean of e over the last `window_s` of the run [rad]

Periodic tracking of r = r0 + A sin(ω t + α): least-squares fits
x(t) ≈ a sin ωt + b cos ωt + c of r and of φ give the phases θ = atan2(b, a);
  phase_lag  (θ_r − θ_φ) wrapped to (−π, π], as [s] = lag / ω and [deg]: positive when
             φ trails r
  gain       sqrt(a² + b²) of φ over that of r (amplitude ratio)
"""
from __future__ import annotations

import math
from typing import Dict, Optional, Tuple

import numpy as np
from numpy.typing import ArrayLike

from ..core.validate import finite_array


def tracking_errors(setpoint: ArrayLike, position: ArrayLike) -> np.ndarray:
    """E = r − φ [rad] as an array."""
    r, y = finite_array('setpoint', setpoint), finite_array('position', position)
    if r.shape != y.shape:
        raise ValueError(f'setpoint and position differ in length ({r.size} vs {y.size})')
    return r - y


def rms_error(setpoint: ArrayLike, position: ArrayLike) -> float:
    """Root-mean-square tracking error [rad]."""
    return float(np.sqrt(np.mean(tracking_errors(setpoint, position) ** 2)))


def max_error(setpoint: ArrayLike, position: ArrayLike) -> float:
    """Largest absolute tracking error [rad]."""
    return float(np.max(np.abs(tracking_errors(setpoint, position))))


def settling_time(time_s: ArrayLike, setpoint: ArrayLike, position: ArrayLike,
                  tolerance_rad: float, t_start: Optional[float] = None) -> Optional[float]:
    """Time [s] from t_start (default: first sample) until |e| <= tolerance for good, or None."""
    t = finite_array('time_s', time_s)
    e = np.abs(tracking_errors(setpoint, position))
    if t.shape != e.shape:
        raise ValueError('time_s must match setpoint/position in length')
    t0 = t[0] if t_start is None else float(t_start)
    outside = np.flatnonzero((e > tolerance_rad) & (t >= t0))
    if outside.size == 0:
        return 0.0
    last = outside[-1]
    if last == len(t) - 1:
        return None
    return float(t[last + 1] - t0)


def summarize(time_s: ArrayLike, setpoint: ArrayLike, position: ArrayLike, tolerance_rad: float,
              t_start: Optional[float] = None) -> Dict[str, Optional[float]]:
    """{'rms_error', 'max_error', 'settling_time'} over samples with t >= t_start."""
    t = finite_array('time_s', time_s)
    keep = t >= (t[0] if t_start is None else t_start)
    r, y = np.asarray(setpoint, float)[keep], np.asarray(position, float)[keep]
    return {'rms_error': rms_error(r, y), 'max_error': max_error(r, y),
            'settling_time': settling_time(t[keep], r, y, tolerance_rad, t_start)}


def _window(time_s: ArrayLike, setpoint: ArrayLike, position: ArrayLike,
            t_start: Optional[float]) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Return (t [s], r, φ [rad]) checked (finite, one length) from t_start on."""
    t = finite_array('time_s', time_s)
    r, y = finite_array('setpoint', setpoint), finite_array('position', position)
    if not t.shape == r.shape == y.shape:
        raise ValueError('time_s, setpoint and position differ in length')
    keep = t >= (t[0] if t_start is None else float(t_start))
    if keep.sum() < 2:
        raise ValueError('fewer than 2 samples in the evaluation window')
    return t[keep], r[keep], y[keep]


def rise_time(time_s: ArrayLike, setpoint: ArrayLike, position: ArrayLike,
              t_start: Optional[float] = None) -> Optional[float]:
    """Return the 10-90 % rise time [s] of a step response, or None if 90 % is not reached."""
    t, r, y = _window(time_s, setpoint, position, t_start)
    y0, h = y[0], r[-1] - y[0]
    if h == 0:
        return None
    progress = (y - y0) / h
    at10, at90 = np.flatnonzero(progress >= 0.1), np.flatnonzero(progress >= 0.9)
    if at90.size == 0:
        return None
    return float(t[at90[0]] - t[at10[0]])


def overshoot_pct(time_s: ArrayLike, setpoint: ArrayLike, position: ArrayLike,
                  t_start: Optional[float] = None) -> float:
    """Return the overshoot of a step response beyond its final setpoint [% of the step]."""
    t, r, y = _window(time_s, setpoint, position, t_start)
    h = r[-1] - y[0]
    if h == 0:
        return 0.0
    return float(100.0 * max(0.0, np.max(np.sign(h) * (y - r[-1]))) / abs(h))


def steady_state_error(time_s: ArrayLike, setpoint: ArrayLike, position: ArrayLike,
                       window_s: float = 2.0) -> float:
    """Return the mean error r − φ over the last `window_s` of the run [rad]."""
    t, r, y = _window(time_s, setpoint, position, None)
    keep = t >= t[-1] - window_s
    return float(np.mean(r[keep] - y[keep]))


def _phase_amplitude(t: np.ndarray, x: np.ndarray, omega: float) -> Tuple[float, float]:
    """Fit x ≈ a sin ωt + b cos ωt + c; return (phase atan2(b, a) [rad], amplitude)."""
    basis = np.column_stack([np.sin(omega * t), np.cos(omega * t), np.ones_like(t)])
    (a, b, _), *_ = np.linalg.lstsq(basis, x, rcond=None)
    return math.atan2(b, a), math.hypot(a, b)


def phase_lag(time_s: ArrayLike, setpoint: ArrayLike, position: ArrayLike, period_s: float,
              t_start: Optional[float] = None) -> Dict[str, float]:
    """
    Return {'phase_lag_s', 'phase_lag_deg', 'gain'} of φ against a sine reference r.

    Both are fitted at the reference's angular frequency ω = 2π / period_s; a positive lag
    means φ trails r. The window should hold whole periods.
    """
    if not period_s > 0:
        raise ValueError(f'period_s must be positive, got {period_s}')
    t, r, y = _window(time_s, setpoint, position, t_start)
    omega = 2.0 * math.pi / period_s
    (theta_r, amp_r), (theta_y, amp_y) = (_phase_amplitude(t, x, omega) for x in (r, y))
    if amp_r == 0:
        raise ValueError('the setpoint does not vary at the given period')
    lag = (theta_r - theta_y + math.pi) % (2.0 * math.pi) - math.pi
    return {'phase_lag_s': lag / omega, 'phase_lag_deg': math.degrees(lag),
            'gain': amp_y / amp_r}

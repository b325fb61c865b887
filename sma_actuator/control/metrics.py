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
"""
import numpy as np

from ..core.validate import finite_array


def tracking_errors(setpoint, position):
    """E = r − φ [rad] as an array."""
    r, y = finite_array('setpoint', setpoint), finite_array('position', position)
    if r.shape != y.shape:
        raise ValueError(f'setpoint and position differ in length ({r.size} vs {y.size})')
    return r - y


def rms_error(setpoint, position):
    """Root-mean-square tracking error [rad]."""
    return float(np.sqrt(np.mean(tracking_errors(setpoint, position) ** 2)))


def max_error(setpoint, position):
    """Largest absolute tracking error [rad]."""
    return float(np.max(np.abs(tracking_errors(setpoint, position))))


def settling_time(time_s, setpoint, position, tolerance_rad, t_start=None):
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


def summarize(time_s, setpoint, position, tolerance_rad, t_start=None):
    """{'rms_error', 'max_error', 'settling_time'} over samples with t >= t_start."""
    t = finite_array('time_s', time_s)
    keep = t >= (t[0] if t_start is None else t_start)
    r, y = np.asarray(setpoint, float)[keep], np.asarray(position, float)[keep]
    return {'rms_error': rms_error(r, y), 'max_error': max_error(r, y),
            'settling_time': settling_time(t[keep], r, y, tolerance_rad, t_start)}

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
Duty profiles of a rig's few short records, played on the rich simulator as a stand-in rig.

The three shared spring-biased wire records (`square_a`: full duty D from 10 s to 30 s,
then off, 70 s; `step_a`: D from 10 s, 50 s; `ramp_a`: 0 -> D from 5 s to 25 s, then
held, 50 s), a staircase up and down in fifths of D, and six other records of the same
rig: steps to 0.6 D and 0.7 D, a triangle, a ramp down, a 0.05 Hz sine and a pulse train.
`benchmarks/bench_other_records.py` and the duty-level tests use them.
"""
import numpy as np
from sma_actuator.core.datakinds import DynamicData
from support.richsim import simulate_profile

TICK_S = 0.025   # the simulator's command clock
SHARED = ('square', 'step', 'ramp')
EXTRA = 'stairs'


def hold(level, seconds):
    """Return `seconds` of commands at `level`."""
    return np.full(int(round(seconds / TICK_S)), float(level))


def ramp(start, stop, seconds):
    """Return `seconds` of commands from `start` to `stop`."""
    return np.linspace(start, stop, int(round(seconds / TICK_S)))


def profiles(d):
    """Return {name: duty commands}: the three shared records' profiles, then the others."""
    t = np.arange(int(round(120 / TICK_S))) * TICK_S
    fifths = [0.2 * k * d for k in (1, 2, 3, 4, 5, 4, 3, 2, 1, 0)]
    return {
        'square': np.r_[hold(0, 10), hold(d, 20), hold(0, 40)],
        'step': np.r_[hold(0, 10), hold(d, 40)],
        'ramp': np.r_[hold(0, 5), ramp(0, d, 20), hold(d, 25)],
        'stairs': np.concatenate([hold(0, 5)] + [hold(level, 12) for level in fifths]),
        'step_0.7': np.r_[hold(0, 10), hold(0.7 * d, 40), hold(0, 30)],
        'step_0.6': np.r_[hold(0, 10), hold(0.6 * d, 40), hold(0, 30)],
        'triangle': np.r_[hold(0, 5), ramp(0, d, 20), ramp(d, 0, 20), hold(0, 25)],
        'ramp_down': np.r_[hold(0, 5), hold(d, 25), ramp(d, 0, 25), hold(0, 25)],
        'sine': np.r_[hold(0, 5), d * (0.6 + 0.3 * np.sin(2 * np.pi * 0.05 * t))],
        'pulses': np.concatenate([hold(0, 5)] + [np.r_[hold(d, 5), hold(0, 5)]] * 5
                                 + [hold(0, 30)]),
    }


def records(effect, magnitude, duty, params=None):
    """Return [(name, DynamicData)] of every profile on the rig with `effect` (100 Hz)."""
    out = []
    for name, cmd in profiles(duty).items():
        r = simulate_profile(cmd, np.zeros_like(cmd), effect=effect, magnitude=magnitude,
                             rate_hz=100, noise_rad=0.001, seed=1, params=params)
        out.append((name, DynamicData(r['time'], r['duty_a'], r['duty_b'], r['position'],
                                      r['ambient_temperature'], layout='single')))
    return out

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
Excitation generators on the 25 ms command clock (open-loop duties, closed-loop setpoints).

Open loop: random multilevel duty sequences that heat one wire at a time (the other wire
gets 0 or a sub-transformation preheat <= 0.12, so both wires are never above 0.2 duty at
once), mixing fast pulses, slow ramps and sines, nested partial reversals (minor loops),
fast antagonist switching, co-contraction (one wire held warm at <= 0.2 while the other
heats) and rests.  Closed loop: steps, ramps, sines and random setpoints
within +-0.6 rad.  `hard` in [0, 1] (saturation case) replaces that fraction of segments by
long full-transformation pulses / out-of-reach setpoints that drive both ends of travel.
"""
import numpy as np

PREHEAT_MAX = 0.12    # passive-wire duty: keeps it below Mf..Ms (~43 degC at steady state)


def _n(rng, lo_s, hi_s, dt):
    """Random whole number of command ticks for a duration drawn from U(lo_s, hi_s) [s]."""
    return max(1, int(round(rng.uniform(lo_s, hi_s) / dt)))


def _on(active, level, passive, n):
    """(duty_a, duty_b) rows: `active` wire (0=a, 1=b) at `level`, the other at `passive`."""
    seg = np.empty((n, 2))
    seg[:, active], seg[:, 1 - active] = level, passive
    return seg


def _preheat(rng):
    """Passive-wire duty: 0, or with probability 0.3 a small preheat U(0.03, PREHEAT_MAX)."""
    return rng.uniform(0.03, PREHEAT_MAX) if rng.random() < 0.3 else 0.0


def _level(rng, duty_max):
    """
    Pulse level.

    Half partial (0.25-0.33: inside the heating band As..Af at steady state for the default wire),
    half full transformation (0.33-duty_max).
    """
    return rng.uniform(0.25, 0.33) if rng.random() < 0.5 else rng.uniform(0.33, duty_max)


def _pulse(rng, dt, duty_max):
    """One wire on at a random level for 0.5-8 s, then off for 0.5-8 s."""
    w, pre = rng.integers(2), _preheat(rng)
    level = _level(rng, duty_max)
    return np.vstack([_on(w, level, pre, _n(rng, 0.5, 8, dt)),
                      _on(w, 0.0, pre, _n(rng, 0.5, 8, dt))])


def _ramp(rng, dt, duty_max):
    """Slow triangular ramp 0 -> level -> 0 (3-15 s each way): quasi-static major loop."""
    w, level = rng.integers(2), rng.uniform(0.3, duty_max)
    up, down = _n(rng, 3, 15, dt), _n(rng, 3, 15, dt)
    prof = np.concatenate([np.linspace(0, level, up), np.full(_n(rng, 0.5, 3, dt), level),
                           np.linspace(level, 0, down)])
    return _on(w, prof, 0.0, prof.size)


def _sine(rng, dt, duty_max):
    """D = L (1 - cos(2 pi f t))/2 for 1-3 periods, f ~ U(0.03, 0.25) Hz (slow and fast)."""
    w, level, f = rng.integers(2), rng.uniform(0.28, duty_max), rng.uniform(0.03, 0.25)
    t = np.arange(int(rng.integers(1, 4) / f / dt)) * dt
    return _on(w, level * 0.5 * (1 - np.cos(2 * np.pi * f * t)), 0.0, t.size)


def _minor(rng, dt, duty_max):
    """
    Nested partial reversals.

    Heat into the heating band (duty 0.26-0.34 ~ As..Af at steady state), cool towards the cooling
    band (0.04-0.16 ~ below Mf..Ms); maxima fall and minima rise so the loops nest (Preisach minor
    loops).
    """
    w, pre = rng.integers(2), _preheat(rng)
    hi, lo = rng.uniform(0.29, min(0.34, duty_max)), rng.uniform(0.04, 0.1)
    rows = [_on(w, hi, pre, _n(rng, 1.5, 6, dt))]
    for _ in range(int(rng.integers(2, 6))):
        lo, hi = rng.uniform(lo, 0.16), rng.uniform(0.26, hi)
        for level in (lo, hi):
            rows.append(_on(w, level, pre, _n(rng, 2, 6, dt)))
    rows.append(_on(w, 0.0, pre, _n(rng, 1, 6, dt)))
    return np.vstack(rows)


def _switch(rng, dt, duty_max):
    """Fast antagonist switching without a cooling gap (the cold wire is still warm)."""
    w, rows = rng.integers(2), []
    for _ in range(int(rng.integers(2, 6))):
        rows.append(_on(w, _level(rng, duty_max), 0.0, _n(rng, 0.5, 2.5, dt)))
        w = 1 - w
    rows.append(_on(w, 0.0, 0.0, _n(rng, 1, 5, dt)))
    return np.vstack(rows)


def _cocontract(rng, dt, duty_max):
    """
    Co-contraction.

    Contract one wire fully, hold it warm with a 0.15-0.2 duty (around Ms, so it stays mostly
    austenitic) while the antagonist heats: both wires pull at once.
    """
    w = rng.integers(2)
    hold, level = rng.uniform(0.15, 0.2), _level(rng, duty_max)
    return np.vstack([_on(w, rng.uniform(0.4, duty_max), 0.0, _n(rng, 2, 5, dt)),
                      _on(1 - w, level, hold, _n(rng, 2, 6, dt)),
                      _on(w, 0.0, 0.0, _n(rng, 1, 5, dt))])


def _rest(rng, dt, duty_max):
    """Both wires off or slightly preheated for 1-8 s."""
    return _on(0, _preheat(rng), _preheat(rng), _n(rng, 1, 8, dt))


def _hard(rng, dt, duty_max):
    """Long full-transformation pulses on alternating wires: both ends of travel."""
    w, rows = rng.integers(2), []
    for _ in range(2):
        rows.append(_on(w, rng.uniform(0.9 * duty_max, duty_max), 0.0, _n(rng, 3, 8, dt)))
        rows.append(_on(w, 0.0, 0.0, _n(rng, 1, 4, dt)))
        w = 1 - w
    return np.vstack(rows)


_OPEN = ((_pulse, 0.23), (_ramp, 0.12), (_sine, 0.1), (_minor, 0.22), (_switch, 0.12),
         (_cocontract, 0.08), (_rest, 0.13))


def open_loop_duty(rng, duration_s, cmd_dt_s=0.025, duty_max=0.5, hard=0.0):
    """
    Duty commands [0..1] per 25 ms tick, shape (n_ticks, 2) for wires (a, b).

    Segments are drawn from _OPEN (or _hard with probability `hard`) until duration_s is filled.
    """
    n_ticks = int(np.ceil(duration_s / cmd_dt_s)) + 1
    makers, probs = zip(*_OPEN)
    rows, total = [], 0
    while total < n_ticks:
        maker = _hard if rng.random() < hard else makers[rng.choice(len(makers), p=probs)]
        seg = maker(rng, cmd_dt_s, duty_max)
        rows.append(seg)
        total += seg.shape[0]
    return np.clip(np.vstack(rows)[:n_ticks], 0.0, duty_max)


def _sp_step(rng, dt, amp, cur):
    """Constant setpoint for 2-10 s."""
    return np.full(_n(rng, 2, 10, dt), rng.uniform(-amp, amp))


def _sp_ramp(rng, dt, amp, cur):
    """Linear ramp from the current setpoint to a random one over 3-15 s."""
    return np.linspace(cur, rng.uniform(-amp, amp), _n(rng, 3, 15, dt))


def _sp_sine(rng, dt, amp, cur):
    """C + a sin(2 pi f t), f ~ U(0.02, 0.12) Hz, |c| + a <= amp, for 10-30 s."""
    a = rng.uniform(0.1, 0.5 * amp / 0.6)
    c = rng.uniform(-(amp - a), amp - a)
    t = np.arange(_n(rng, 10, 30, dt)) * dt
    return c + a * np.sin(2 * np.pi * rng.uniform(0.02, 0.12) * t)


def _sp_random(rng, dt, amp, cur):
    """3-7 random levels held 0.5-3 s each."""
    parts = [np.full(_n(rng, 0.5, 3, dt), rng.uniform(-amp, amp))
             for _ in range(int(rng.integers(3, 8)))]
    return np.concatenate(parts)


def _sp_zero(rng, dt, amp, cur):
    """Setpoint 0 (both wires relax) for 2-6 s."""
    return np.zeros(_n(rng, 2, 6, dt))


_CLOSED = ((_sp_step, 0.3), (_sp_ramp, 0.2), (_sp_sine, 0.2), (_sp_random, 0.2),
           (_sp_zero, 0.1))


def closed_loop_setpoint(rng, duration_s, cmd_dt_s=0.025, amplitude=0.6, hard=0.0,
                         hard_amplitude=1.1):
    """
    Setpoint [rad] per 25 ms tick, |sp| <= amplitude.

    With probability `hard` a segment is an out-of-reach hold at +-hard_amplitude for 3-8 s (drives
    the wire through full transformation).
    """
    n_ticks = int(np.ceil(duration_s / cmd_dt_s)) + 1
    makers, probs = zip(*_CLOSED)
    parts, total, cur = [], 0, 0.0
    while total < n_ticks:
        if rng.random() < hard:
            seg = np.full(_n(rng, 3, 8, cmd_dt_s), rng.choice([-1.0, 1.0]) * hard_amplitude)
        else:
            seg = makers[rng.choice(len(makers), p=probs)](rng, cmd_dt_s, amplitude, cur)
        parts.append(seg)
        total, cur = total + seg.size, float(np.clip(seg[-1], -amplitude, amplitude))
    return np.concatenate(parts)[:n_ticks]

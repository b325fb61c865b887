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
Open-loop excitation for identifying the controller's model (duty sequences, no ROS).

A good identification record moves each wire through its major loop and through nested
minor loops from both branches, with holds long enough (several T = 2 s) for the thermal
time constant to show. `multilevel` builds that: alternating wires, each segment a held
duty level drawn from `levels` for a random hold in [hold_min_s, hold_max_s], with the
other wire cold; some segments step down or up within the same wire (minor loops).
"""
from __future__ import annotations

from typing import Optional, Sequence, Tuple

import numpy as np

from .validate import finite_scalar


def multilevel(duration_s: float, dt: float, seed: int = 0,
               levels: Sequence[float] = (0.25, 0.32, 0.38, 0.45, 0.55, 0.7),
               hold_min_s: float = 1.5, hold_max_s: float = 5.0,
               rest_probability: float = 0.2,
               switch_gap_s: float = 0.0) -> Tuple[np.ndarray, np.ndarray]:
    """
    (duty_a, duty_b) arrays of n = duration_s/dt samples (held per sample), seeded.

    switch_gap_s: where a segment heats one wire right after a segment that heated the
    other, its first ceil(switch_gap_s / dt) samples hold both wires at zero, so that a
    drive with a dead-time interlock (`control.interlock`) applies every command as written.
    """
    duration_s, dt = finite_scalar('duration_s', duration_s), finite_scalar('dt', dt)
    if duration_s <= 0 or dt <= 0 or hold_min_s <= 0 or hold_max_s < hold_min_s:
        raise ValueError('duration_s, dt, hold_min_s must be positive, hold_max_s >= hold_min_s')
    if not finite_scalar('switch_gap_s', switch_gap_s) >= 0:
        raise ValueError(f'switch_gap_s must be >= 0, got {switch_gap_s}')
    gap = int(np.ceil(switch_gap_s / dt - 1e-9))
    rng = np.random.default_rng(seed)
    n = int(round(duration_s / dt))
    duty = np.zeros((n, 2))
    k, wire, heated = 0, 0, None
    while k < n:
        hold = int(round(rng.uniform(hold_min_s, hold_max_s) / dt))
        if rng.random() < rest_probability:
            level = 0.0                                    # both cold: back to the major loop
        else:
            level = float(rng.choice(levels))
            if rng.random() < 0.5:
                wire = 1 - wire                            # else: a minor loop, same wire
        start = k + gap if level > 0 and heated == 1 - wire else k
        duty[start:k + hold, wire] = level
        heated = wire if level > 0 else None
        k += hold
    return duty[:, 0].copy(), duty[:, 1].copy()


#: Levels of `rig_excitation`, as fractions of the duty that holds a wire at its full stroke.
LEVEL_FRACTIONS = (0.5, 0.6, 0.7, 0.8, 0.9, 1.0)
#: Holds of `rig_excitation` in thermal time constants: `multilevel`'s 1.5-5 s at T = 2 s.
HOLD_TAUS = (0.75, 2.5)
#: Zero duty of `rig_excitation` where heating passes from one wire to the other [s]: the
#: hardware bridge's default interlock dead time (0.05 s) and two 25 ms commands of arrival
#: jitter, so the bridge applies every command of the sequence and the recorded duties are
#: the applied ones (a held command would be logged as heating that never happened).
SWITCH_GAP_S = 0.1


def rig_excitation(duration_s: float, dt: float, tau_s: float, duty_full: float,
                   layout: str = 'antagonistic', seed: int = 0,
                   duty_full_b: Optional[float] = None,
                   switch_gap_s: float = SWITCH_GAP_S) -> Tuple[np.ndarray, np.ndarray]:
    """
    Return (duty_a, duty_b) for an identification record of a rig, in its own time scale.

    `multilevel` with holds of 0.75-2.5 τ (τ = tau_s, the wire's basic time constant
    T = C / hA [s] of eq. (7)) at levels 0.5-1.0 × duty_full (the duty that holds a wire at
    its full stroke): each hold lets the temperature settle near one of six steady values
    θa + G d, so the record shows the heating law at several duties and minor loops from
    both branches. layout 'single' (one wire against a bias spring): every segment on wire
    a, duty_b 0. duty_full_b: wire b's full-stroke duty when it differs from wire a's
    (unequal wires, G_b = G r_G); wire b then holds the same fractions of it.
    switch_gap_s: both wires cold for this long [s] where heating passes from one wire to
    the other (`multilevel`; longer than the interlock dead time of the drive it is played
    through; none on a single wire).
    """
    tau_s, duty_full = finite_scalar('tau_s', tau_s), finite_scalar('duty_full', duty_full)
    full_b = duty_full if duty_full_b is None else finite_scalar('duty_full_b', duty_full_b)
    if tau_s <= 0 or not (0 < duty_full <= 1 and 0 < full_b <= 1):
        raise ValueError('tau_s must be positive and duty_full, duty_full_b in (0, 1]')
    if layout not in ('antagonistic', 'single'):
        raise ValueError(f"layout must be 'antagonistic' or 'single', got {layout!r}")
    levels = tuple(duty_full * f for f in LEVEL_FRACTIONS)
    duty_a, duty_b = multilevel(duration_s, dt, seed, levels, HOLD_TAUS[0] * tau_s,
                                HOLD_TAUS[1] * tau_s,
                                switch_gap_s=switch_gap_s if layout == 'antagonistic' else 0.0)
    if layout == 'single':
        return np.maximum(duty_a, duty_b), np.zeros_like(duty_b)
    return duty_a, duty_b * (full_b / duty_full)
